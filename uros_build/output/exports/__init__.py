"""The export formats (`uros export KIND`), one module a format, each with its ``FORMAT`` record,
registered once here: the CLI's commands (cli/data.py), the check of the folder before anything is
written (commands/export.py) and the carry-over after a build (steps/deliver.py) all read
:data:`FORMATS`, so a new format is one module and one line below. (`uros export arduino` takes
several outputs and has a command of its own: exports/arduino.py.)"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from uros_build.errors import ConfigError
from uros_build.output.exports import cmake, espidf, make, meson, pkgconfig, platformio, zephyr
from uros_build.output.exports.base import ExportFormat, rule_refusal

if TYPE_CHECKING:
    from uros_build.output.buildinfo import BuildInfo

FORMATS: tuple[ExportFormat, ...] = (
    cmake.FORMAT,
    espidf.FORMAT,
    make.FORMAT,
    pkgconfig.FORMAT,
    meson.FORMAT,
    platformio.FORMAT,
    zephyr.FORMAT,
)
_BY_KIND = {f.kind: f for f in FORMATS}
assert len(_BY_KIND) == len(FORMATS), "two export formats of one kind"


def by_kind(kind: str) -> ExportFormat:
    return _BY_KIND[kind]


def folder_refusal(kind: str, folder: str) -> tuple[str, str, str] | None:
    """(the character, the consumer, why) when the consumer of export ``kind`` cannot use a
    package in ``folder``; None when it can (pure)."""
    found = _BY_KIND.get(kind)
    return rule_refusal(found.folder_rule if found else None, folder)


def refuse_package_folder(kind: str, folder: Path, flag: str, fix: str) -> None:
    """One line, before anything is written, for a folder whose package the consumer of ``kind``
    could not use (folder_refusal): `uros export` and `uros build --output` (its CMake package)."""
    refused = folder_refusal(kind, str(folder))
    if refused is not None:
        char, fmt, why = refused
        raise ConfigError(
            f"{flag} {folder}: holds {char!r}, which {fmt} cannot use in the folder of a package ({why})",
            f"{fix} (or link one to it)",
        )


def carry_over(out: Path, staging: Path, info: BuildInfo) -> list[str]:
    """The exports an earlier `uros export KIND --output OUT` wrote into the output ``out`` (its
    marker names them), written again into the next build's ``staging`` for its library, so that
    the build's swap does not drop them. Returns the kinds carried over."""
    from uros_build.output import folders  # after a build only: every start reads FORMATS (start-up cost)

    owned = folders.owned_entries(out) or frozenset()

    def present(fmt: ExportFormat) -> bool:
        if not fmt.marks or not all(n in owned and (out / n).exists() for n in fmt.marks):
            return False
        try:
            fmt.check(info, out)
        except ConfigError:
            return False  # this library cannot have it (an ESP-IDF component of a non-IDF build)
        return True

    carried = [fmt for fmt in FORMATS if present(fmt)]
    replaced = {kind for fmt in carried for kind in fmt.replaces}
    kinds = []
    for fmt in carried:
        if fmt.kind not in replaced:
            fmt.write(staging, info, out)
            kinds.append(fmt.kind)
    return kinds
