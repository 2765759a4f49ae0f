"""`uros export make`: microros.mk (MICROROS_CFLAGS, MICROROS_LIBS, MICROROS_CPU_FLAGS) for a Make
firmware."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import __version__, templating
from uros_build.output.exports.base import ExportFormat, plain, write_files

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo

MAKE_FILE = "microros.mk"


def make_fragment(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.mk: MICROROS_CFLAGS / MICROROS_LIBS / MICROROS_CPU_FLAGS for a Make firmware (pure)."""
    text = templating.render(f"{MAKE_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {MAKE_FILE: text}


def write_make_fragment(out: Path, info: BuildInfo, _folder: Path | None = None) -> list[str]:
    return write_files(out, make_fragment(info.target, info.flags.cpu))


FORMAT = ExportFormat(
    kind="make",
    what="Write microros.mk (MICROROS_CFLAGS, MICROROS_LIBS, MICROROS_CPU_FLAGS) for a Make firmware.",
    output_help="Folder of microros.mk (and a copy of the output with --from).",
    folder_rule="make",
    write=write_make_fragment,
    done=plain("include it from your Makefile (README: Make)"),
    marks=(MAKE_FILE,),
)
