"""What every export format shares: the record a format registers (:class:`ExportFormat`), the
folder rules of the consumers that find the package's folder themselves, the library's ABI flags,
and the copy of a build output an export from ``--from`` starts with."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from uros_build.defaults import BUILD_INFO

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo


@dataclass(frozen=True)
class ExportFormat:
    """One `uros export KIND`, registered once in ``exports.FORMATS``: the CLI's command, the
    folder check before anything is written and the carry-over after a build all read it."""

    kind: str  # `uros export KIND`
    what: str  # the command's --help
    output_help: str  # --output's help
    # the consumer whose folder rule applies (a key of FOLDER_RULES), None: the folder is not written
    folder_rule: str | None
    # (folder, build-info, the folder the files will be read from) -> the entries written there
    write: Callable[[Path, BuildInfo, Path], list[str]]
    # (build-info, folder, entries written) -> the line that tells the user how to use it
    done: Callable[[BuildInfo, Path, list[str]], str]
    # (build-info, the output's folder): raises ConfigError when the build cannot have this export
    # (checked before anything is copied)
    check: Callable[[BuildInfo, Path], object] = lambda _info, _src: None
    # the entries (all of them) an earlier export left in an output: the next build writes the
    # format again for its library, so that its swap does not drop them; () = never carried
    # (the build writes it itself)
    marks: tuple[str, ...] = ()
    # formats whose files this one writes too: where it is carried over, they are not
    replaces: tuple[str, ...] = ()


def write_files(out: Path, files: dict[str, str]) -> list[str]:
    """Write ``files`` (name -> text) into ``out``; the top-level entries written."""
    entries: list[str] = []
    for name, text in files.items():
        path = out / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        top = name.split("/", 1)[0]
        if top not in entries:
            entries.append(top)
    return entries


def plain(use: str | Callable[[BuildInfo], str] = "") -> Callable[[BuildInfo, Path, list[str]], str]:
    """The usual closing line: the files written, where, and (``use``) how to use them."""

    def done(info: BuildInfo, out: Path, entries: list[str]) -> str:
        how = use(info) if callable(use) else use
        line = f"wrote {', '.join(entries)} in {out}"
        return f"{line}: {how}" if how else line

    return done


# ---------------------------------------------------------------------------------------------
# The export's folder: what each consumer can carry in it (measured with pkgconf 1.8.1, Meson 1.0,
# CMake 3.25 and GNU make 4.3; tests/integration/test_export_consumers.py). None of them can be
# told the folder in an escaped form: pkg-config finds it as ${pcfiledir}, make as MAKEFILE_LIST,
# CMake as CMAKE_CURRENT_LIST_DIR, so what they cannot carry is refused before anything is written.

# pkgconf prints ${pcfiledir} into the compile line with only spaces (and non-ASCII bytes)
# escaped, a line a shell (or Meson's shlex) reads: any other shell character breaks it (a '$' is
# expanded, a quote left open, '(' or ';' a syntax error or a second command); microros.mk's
# -I$(MICROROS_DIR)/include reaches the recipe's shell the same way.
_SHELL_SAFE = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 /._+-,:@%=~^#")
_WHY_SHELL = "{tool} puts the folder unquoted into the command line a shell reads"
FOLDER_RULES = {
    "pkg-config": ("pkg-config", _WHY_SHELL.format(tool="pkg-config")),
    "make": ("make", _WHY_SHELL.format(tool="microros.mk")),
    # Meson decodes pkgconf's output as UTF-8 before undoing its byte escapes (e-acute: \\303\\251)
    "meson": ("Meson", "Meson reads pkg-config's answer, which escapes every non-ASCII byte, as UTF-8"),
    "cmake": (
        "CMake",
        "CMake splits the folder at ';' into a list, reads '\\' as an escape, and its Makefiles "
        "generator writes '\"' unescaped",
    ),
}


def rule_refusal(rule: str | None, folder: str) -> tuple[str, str, str] | None:
    """(the character, the consumer, why) when the consumer of ``rule`` cannot use a package in
    ``folder``; None when it can, or when no consumer reads the folder (``rule`` None) (pure)."""
    if rule is None or rule not in FOLDER_RULES:
        return None
    fmt, why = FOLDER_RULES[rule]
    for char in folder:
        if rule == "cmake":
            bad = char in ';\\"'
        elif rule == "meson":
            bad = char not in _SHELL_SAFE
        else:
            bad = char not in _SHELL_SAFE and char.isascii()
        if bad:
            return char, fmt, why
    return None


ABI_FLAGS = ("mcpu", "mfpu", "mfloat-abi", "mabi")


def abi_flags(cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """-mcpu/-mfpu/-mfloat-abi/-mabi -> the value the library was built with ('' when it names
    none; the last one wins, as with GCC) (pure)."""
    found = dict.fromkeys(ABI_FLAGS, "")
    for flag in cpu_flags:
        name, sep, value = flag[1:].partition("=")
        if flag.startswith("-") and sep and name in found:
            found[name] = value
    return found


def copy_build_output(src: Path, dst: Path) -> list[str]:
    """Copy library, headers and build-info from one output folder to another; returns the names
    copied."""
    dst.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src / "libmicroros.a", dst / "libmicroros.a")
    if (dst / "include").exists():
        shutil.rmtree(dst / "include")
    shutil.copytree(src / "include", dst / "include")
    copied = ["libmicroros.a", "include"]
    for name in (BUILD_INFO, "toolchain.cmake"):
        if (src / name).is_file():
            shutil.copy2(src / name, dst / name)
            copied.append(name)
    return copied
