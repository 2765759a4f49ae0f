"""`uros export cmake`: the CMake config package (find_package(microros)) and microros.cmake (include)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import __version__, templating
from uros_build.output.exports.base import ExportFormat, abi_flags, plain, write_files

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo, RtosInfo

CMAKE_FILES = ("microrosConfig.cmake", "microrosConfigVersion.cmake", "microros.cmake")


def cmake_package_files(
    target: str, cpu_flags: tuple[str, ...], rtos: RtosInfo | None = None
) -> dict[str, str]:
    """File name -> text of the CMake package (pure). ``rtos``: the RTOS the library was compiled
    against, which the package asks the firmware for at configure time."""
    from uros_build.target import rtos as rtos_mod  # when writing: every start reads FORMATS (start-up cost)

    ctx = {
        "version": __version__,
        "target": target,
        "cpu_flags": list(cpu_flags),
        "abi": abi_flags(cpu_flags),
        "package_version": __version__,
        "rtos": rtos,
        # the define the library's headers were compiled with: the firmware's compile gets it too
        "rtos_define": rtos_mod.DEFINES.get(rtos.name, "") if rtos else "",
    }
    return {name: templating.render(f"{name}.j2", **ctx) for name in CMAKE_FILES}


def write_cmake_package(out: Path, info: BuildInfo, _folder: Path | None = None) -> list[str]:
    return write_files(out, cmake_package_files(info.target, info.flags.cpu, info.rtos))


FORMAT = ExportFormat(
    kind="cmake",
    what="Write microrosConfig.cmake (find_package) and microros.cmake (include) for a build output.",
    output_help="Folder of the CMake package.",
    folder_rule="cmake",
    write=write_cmake_package,
    done=plain(),
    # never carried over: every build writes the CMake package itself
)
