"""What a full disk leaves behind in colcon's trees, found by content: configure files cut short
(a `<pkg>Config.cmake` ending mid-line), ninja's dependency log cut in its header, and archives
whose member table does not reach their end.
A build that ran out of disk marks its target; the next one drops what these find. Pure.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from uros_build.target import arfile

# What CMake's configure writes into a package's build folder and reads back at every build. A
# write that fails on a full disk leaves it empty or cut short, and every later build fails
# (ninja: "unknown build rule", CMake: "Parse error in cache file") until the folder is dropped.
CONFIGURE_FILES = (
    "CMakeCache.txt",
    "build.ninja",
    "CMakeFiles/rules.ninja",
    "Makefile",
    "CMakeFiles/Makefile2",
)
_TAIL = 4096
# ninja's dependency log: its header (this signature and a 4-byte version), then records. One cut
# inside its header (a full disk: the file made, its header not written) is deleted by ninja when it
# loads it ("bad deps log signature or version; starting over"), and `ninja -t recompact`, which
# CMake runs after each configure, then fails to replace the file it deleted ("failed recompaction:
# No such file or directory"): every later configure of the package fails. A log cut after its
# header ninja recovers itself. https://github.com/ninja-build/ninja/blob/master/src/deps_log.cc
NINJA_DEPS = ".ninja_deps"
_NINJA_DEPS_SIGNATURE = b"# ninjadeps\n"
_NINJA_DEPS_HEADER = len(_NINJA_DEPS_SIGNATURE) + 4


def configure_damage(name: str, size: int, tail: bytes) -> str | None:
    """Why a configure file is damaged, from its size and its last bytes, or None (pure). Each is
    a text file CMake writes whole, ending in a line break; the cache ends with its INTERNAL
    entries."""
    if size == 0:
        return f"{name} is empty"
    if b"\0" in tail:
        return f"{name} holds NUL bytes"
    if not tail.endswith(b"\n"):
        return f"{name} is cut short"
    if name == "CMakeCache.txt" and b":INTERNAL=" not in tail:
        return f"{name} is cut short (no INTERNAL entries at its end)"
    return None


def ninja_deps_damage(head: bytes) -> str | None:
    """Why ninja's dependency log, whose first bytes are ``head``, breaks the package's next
    configure (its header cut short), or None (pure)."""
    if len(head) < _NINJA_DEPS_HEADER or not head.startswith(_NINJA_DEPS_SIGNATURE):
        return f"{NINJA_DEPS} is cut short in its header"
    return None


def archive_damage(size: int, read_at: Callable[[int, int], bytes]) -> str | None:
    """Why an ar archive of ``size`` bytes is cut short or broken, or None: its member headers,
    read with ``read_at(offset, length)``, must chain exactly to its end (pure over the reader)."""
    try:
        for _entry in arfile.entries(read_at, size):
            pass
    except arfile.ArFormatError as exc:
        return f"{exc} (a write cut short?)" if exc.kind == "not ar" else str(exc)
    return None


def damaged_archives(folders: list[Path]) -> list[tuple[Path, str]]:
    """The static libraries (``*.a``) in ``folders`` that are cut short or broken, with why."""
    found = []
    for folder in folders:
        for path in sorted(folder.glob("*.a")) if folder.is_dir() else []:
            try:
                with path.open("rb") as handle:
                    read_at, size = arfile.stream_reader(handle)
                    why = archive_damage(size, read_at)
            except OSError as exc:
                why = f"cannot be read ({exc.strerror})"
            if why is not None:
                found.append((path, why))
    return found


def _configure_file(name: str) -> Callable[[BinaryIO], str | None]:
    def judge(handle: BinaryIO) -> str | None:
        size = os.fstat(handle.fileno()).st_size
        handle.seek(max(0, size - _TAIL))
        return configure_damage(name, size, handle.read())

    return judge


def _ninja_deps(handle: BinaryIO) -> str | None:
    return ninja_deps_damage(handle.read(_NINJA_DEPS_HEADER))


# what each package build folder is checked for, in order: a folder's first damage is its reason
_CHECKS = (*((name, _configure_file(name)) for name in CONFIGURE_FILES), (NINJA_DEPS, _ninja_deps))


def damaged_configures(build_base: Path) -> list[tuple[Path, str]]:
    """The package build folders under ``build_base`` whose configure files (or ninja's dependency
    log) are damaged, with why."""
    found = []
    for folder in sorted(p for p in build_base.iterdir() if p.is_dir()) if build_base.is_dir() else []:
        for name, judge in _CHECKS:
            try:
                with (folder / name).open("rb") as handle:
                    why = judge(handle)
            except FileNotFoundError:
                continue
            except OSError as exc:
                why = f"{name} cannot be read ({exc.strerror})"
            if why is not None:
                found.append((folder, why))
                break
    return found
