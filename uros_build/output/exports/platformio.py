"""`uros export platformio`: a library folder for lib_deps
(https://docs.platformio.org/en/latest/manifests/library-json/)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import __version__, templating
from uros_build.output.exports.base import ExportFormat, abi_flags, plain, write_files

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo

LIBRARY_NAME = "micro_ros_uros"  # the name the library goes by (PlatformIO, Arduino, Zephyr)
PLATFORMIO_FILE = "library.json"
# PlatformIO gives a library's build.flags to the compiler only: its extra script puts the CPU
# flags on the firmware's link (templates/platformio-abi.py.j2 says how and why)
PLATFORMIO_SCRIPT = "uros_platformio_abi.py"


def platformio_manifest(target: str) -> dict[str, str]:
    """library.json beside libmicroros.a and include/: nothing to compile, the headers on the
    include path, the prebuilt archive linked (flags are relative to the library's folder), and
    the extra script that links the firmware with the library's CPU flags."""
    data = {
        "name": LIBRARY_NAME,
        "version": __version__,
        "description": f"micro-ROS, prebuilt by uros for {target}",
        "keywords": ["micro-ros", "ros2", "uros"],
        "license": "Apache-2.0",
        "frameworks": "*",
        "platforms": "*",
        "build": {
            "includeDir": "include",
            "srcFilter": ["-<*>"],
            "libArchive": False,
            "flags": ["-L.", "-lmicroros"],
            "extraScript": PLATFORMIO_SCRIPT,
        },
    }
    return {PLATFORMIO_FILE: json.dumps(data, indent=2, sort_keys=True) + "\n"}


def platformio_files(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """library.json and its extra script (pure)."""
    abi = {name: value for name, value in abi_flags(cpu_flags).items() if value}
    script = templating.render(
        "platformio-abi.py.j2", version=__version__, target=target, cpu_flags=list(cpu_flags), abi=abi
    )
    return {**platformio_manifest(target), PLATFORMIO_SCRIPT: script}


def platformio_build_flags(cpu_flags: tuple[str, ...]) -> str:
    """The platformio.ini line that compiles a firmware with the library's ABI (pure)."""
    return "build_flags = " + " ".join(cpu_flags)


def write_platformio(out: Path, info: BuildInfo, _folder: Path | None = None) -> list[str]:
    return write_files(out, platformio_files(info.target, info.flags.cpu))


FORMAT = ExportFormat(
    kind="platformio",
    what="Write library.json: the output as a PlatformIO library for lib_deps = file://...",
    output_help="Folder of the PlatformIO library (library.json).",
    folder_rule=None,  # -L. from the library's own folder: the folder is not written
    write=write_platformio,
    done=plain(
        lambda info: (
            f"in platformio.ini: lib_deps = file://<that folder> and {platformio_build_flags(info.flags.cpu)}"
        )
    ),
    marks=(PLATFORMIO_FILE,),
)
