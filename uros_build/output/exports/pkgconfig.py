"""`uros export pkg-config`: microros.pc, relocatable (${pcfiledir})."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import __version__, templating
from uros_build.output.exports.base import ExportFormat, plain, write_files

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo

PC_FILE = "microros.pc"


def pkg_config_file(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.pc, relocatable (${pcfiledir}) (pure)."""
    text = templating.render(f"{PC_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {PC_FILE: text}


def check_pkg_config(info: BuildInfo, _src: Path | None = None) -> None:
    pkg_config_file(info.target, info.flags.cpu)  # refuses flags pkg-config cannot pass on


def write_pkg_config(out: Path, info: BuildInfo, _folder: Path | None = None) -> list[str]:
    return write_files(out, pkg_config_file(info.target, info.flags.cpu))


FORMAT = ExportFormat(
    kind="pkg-config",
    what="Write microros.pc (relocatable) for pkg-config.",
    output_help="Folder of microros.pc.",
    folder_rule="pkg-config",
    write=write_pkg_config,
    done=plain("PKG_CONFIG_PATH=<that folder> pkg-config --cflags --libs microros"),
    check=check_pkg_config,
    marks=(PC_FILE,),
)
