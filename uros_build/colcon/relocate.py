"""A workspace moved or copied to another folder (`mv ws ws2`, `cp -a ws ws2`, a container mount):
the CMake build trees it holds name the folder they were configured in, and CMake refuses to use a
cache made elsewhere ("The current CMakeCache.txt directory ... is different than the directory
... where CMakeCache.txt was created"). colcon configures again only a package whose top-level cache
is gone, and nothing reaches the trees an ExternalProject (libyaml_vendor's) configures nested in a
package's build folder. So every CMakeCache.txt under a build base that was not made where it now
is, nested ones included, is dropped: its tree is configured afresh in the same folder (the
project's own configure step runs again, since its command names the new folders), and nothing
else is redone. Each build base records where it was last checked, so the walk happens only after
a move. Reads and removes files; starts no process.
"""

from __future__ import annotations

import os
from pathlib import Path

from uros_build import console

CACHE = "CMakeCache.txt"
RECORD = ".uros-built-in"  # in a build base (colcon ignores names starting with '.'): its folder
_ENTRY = "CMAKE_CACHEFILE_DIR:INTERNAL="


def cache_dir(text: str) -> str | None:
    """The folder a CMakeCache.txt was created in (its CMAKE_CACHEFILE_DIR entry), or None (pure)."""
    for line in text.splitlines():
        if line.startswith(_ENTRY):
            return line[len(_ENTRY) :]
    return None


def made_elsewhere(cache: Path) -> str | None:
    """The other folder ``cache`` was created in, or None when it was created where it is. CMake
    compares the files, not the spellings (a symlinked path to the same folder is no move)."""
    try:
        recorded = cache_dir(cache.read_text(encoding="utf-8", errors="surrogateescape"))
    except OSError:
        return None
    if recorded is None:
        return None
    try:
        if os.path.samefile(os.path.join(recorded, CACHE), cache):
            return None
    except OSError:
        pass
    return recorded


def moved_caches(build_base: Path) -> list[tuple[Path, str]]:
    """Every CMakeCache.txt under ``build_base`` (nested ones included) created in another folder,
    with that folder."""
    found = []
    for dirpath, dirnames, filenames in os.walk(build_base):
        dirnames.sort()
        if CACHE in filenames:
            cache = Path(dirpath) / CACHE
            recorded = made_elsewhere(cache)
            if recorded is not None:
                found.append((cache, recorded))
    return found


def forget_moved(build_base: Path) -> list[tuple[Path, str]]:
    """When ``build_base`` was last checked in another folder (or never): drop the caches made
    elsewhere and record where it is now. Returns what was dropped, with the folder each named."""
    record = build_base / RECORD
    here = str(build_base)
    try:
        if record.read_text(encoding="utf-8", errors="surrogateescape") == here + "\n":
            return []
    except OSError:
        pass
    if not build_base.is_dir():
        return []
    dropped = moved_caches(build_base)
    for cache, _recorded in dropped:
        cache.unlink()
    record.write_text(here + "\n", encoding="utf-8", errors="surrogateescape")
    return dropped


def was_in(dropped: list[tuple[Path, str]], build_base: Path) -> str:
    """Where the trees were configured, for a message: the first dropped cache's folder with the
    part below ``build_base`` taken off (pure)."""
    cache, recorded = dropped[0]
    below = cache.parent.relative_to(build_base).parts
    old = Path(recorded).parts
    if below and len(old) > len(below) and old[-len(below) :] == below:
        return str(Path(*old[: -len(below)]))
    return recorded


def reconfigure_moved(build_base: Path, what: str) -> bool:
    """:func:`forget_moved`, said in one line. True when any tree is configured afresh."""
    dropped = forget_moved(build_base)
    if dropped:
        console.info(
            f"{what} was configured in {was_in(dropped, build_base)} (the workspace moved or was "
            f"copied): configuring its {len(dropped)} CMake trees afresh"
        )
    return bool(dropped)
