"""A target's colcon trees, package by package, so that a library holds exactly one build.

colcon's merged install tree (``.uros/targets/<key>/install``) keeps whatever any earlier build put
there: the archives of a package since removed from the workspace, of packages a later
``--packages-up-to`` left out (built with other flags), of a package whose install step failed.
Taking every ``install/lib/*.a`` would ship them. Here every installed file is traced to its
package through the list its build wrote (CMake's ``install_manifest.txt``, setuptools'
``install.log`` from colcon-python-setup-py's ``--record``), so that:

- packages the workspace no longer has are dropped (their installed files, build folder and
  colcon's markers) before colcon runs;
- the merge takes the archives, and the include tree the headers, of this build's packages only;
- each package's build folder carries a stamp of the flags it was compiled with, written when
  colcon reports the package finished and compared before the merge.

Reads and writes files; starts no process.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

STAMP = "uros-stamp.json"
# What a package's build folder holds that lists the files its install step wrote.
_MANIFESTS = ("install_manifest.txt", "install.log")


def tree_packages(build_base: Path) -> set[str]:
    """The packages colcon has a build folder for (colcon names them after the package)."""
    if not build_base.is_dir():
        return set()
    return {p.name for p in build_base.iterdir() if p.is_dir() and not p.name.startswith(".")}


def installed_files(build_base: Path, package: str) -> tuple[Path, ...]:
    """The files ``package``'s last install step wrote, absolute; () when it recorded none."""
    for name in _MANIFESTS:
        manifest = build_base / package / name
        if manifest.is_file():
            lines = manifest.read_text(encoding="utf-8", errors="surrogateescape").splitlines()
            return tuple(Path(os.path.normpath(line.strip())) for line in lines if line.strip())
    return ()


def _inside(path: Path, folder: Path) -> bool:
    return str(path).startswith(str(folder) + os.sep)


def drop_package(build_base: Path, install_base: Path, package: str) -> int:
    """Remove what ``package`` put into the target's trees: the files it installed (only inside
    ``install_base``), colcon's per-package markers and hooks, and its build folder. Returns how
    many installed files were removed."""
    removed = 0
    parents: set[Path] = set()
    for path in installed_files(build_base, package):
        if _inside(path, install_base) and (path.is_file() or path.is_symlink()):
            path.unlink()
            removed += 1
            parents.add(path.parent)
    # colcon's own per-package files in a merged prefix (colcon_core/shell, colcon_core/location)
    (install_base / "share" / "colcon-core" / "packages" / package).unlink(missing_ok=True)
    shutil.rmtree(install_base / "share" / package, ignore_errors=True)
    for folder in sorted(parents, key=lambda p: len(p.parts), reverse=True):
        _prune_empty(folder, install_base)
    shutil.rmtree(build_base / package, ignore_errors=True)
    return removed


def _prune_empty(folder: Path, stop: Path) -> None:
    while _inside(folder, stop) and folder.is_dir() and not any(folder.iterdir()):
        folder.rmdir()
        folder = folder.parent


def drop_removed(build_base: Path, install_base: Path, workspace_packages: Iterable[str]) -> list[str]:
    """Drop every package the trees hold that the workspace no longer has; returns their names."""
    gone = sorted(tree_packages(build_base) - set(workspace_packages))
    for package in gone:
        drop_package(build_base, install_base, package)
    return gone


def archives(build_base: Path, install_base: Path, packages: Iterable[str]) -> dict[str, tuple[Path, ...]]:
    """Package -> the static libraries it installed into ``install_base/lib`` (that exist)."""
    lib = install_base / "lib"
    out = {}
    for package in packages:
        out[package] = tuple(
            sorted(
                p
                for p in installed_files(build_base, package)
                if p.suffix == ".a" and p.parent == lib and p.is_file()
            )
        )
    return out


def headers(build_base: Path, install_base: Path, packages: Iterable[str]) -> frozenset[Path]:
    """Every file ``packages`` installed under ``install_base/include``."""
    include = install_base / "include"
    return frozenset(
        p for package in packages for p in installed_files(build_base, package) if _inside(p, include)
    )


# ---------------------------------------------------------------------------------------------
# flag stamps


def package_stamp(build_fingerprint: str, package: str, meta_entry: Mapping[str, Any]) -> str:
    """What a package is compiled with: the target-wide flags (toolchain file, compiler, CMake
    arguments: ``build_fingerprint``) and its own colcon.meta entry (pure)."""
    text = json.dumps(
        {"build": build_fingerprint, "package": package, "meta": meta_entry}, sort_keys=True, default=list
    )
    return hashlib.sha256(text.encode()).hexdigest()


def write_stamp(build_base: Path, package: str, stamp: str) -> None:
    folder = build_base / package
    if folder.is_dir():  # a package colcon built has one; nothing to vouch for otherwise
        (folder / STAMP).write_text(json.dumps({"flags": stamp}) + "\n", encoding="utf-8")


def read_stamp(build_base: Path, package: str) -> str | None:
    try:
        data = json.loads((build_base / package / STAMP).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    value = data.get("flags") if isinstance(data, dict) else None
    return value if isinstance(value, str) else None


def stale(build_base: Path, expected: Mapping[str, str]) -> list[str]:
    """The packages whose stamp is missing or differs from ``expected`` (package -> stamp)."""
    return sorted(p for p, stamp in expected.items() if read_stamp(build_base, p) != stamp)


def forget_changed_configs(build_base: Path, expected: Mapping[str, str]) -> list[str]:
    """Packages built before with other flags (their stamp differs from ``expected``) configure
    afresh: a `--set PKG.KEY=VALUE` dropped from the command line leaves ``-DKEY=VALUE`` out of
    colcon's CMake arguments, but the package's CMakeCache.txt keeps KEY, so the library went on
    being built with it while build-info.json named no such option. Returns those packages."""
    changed = []
    for package in stale(build_base, expected):
        cache = build_base / package / "CMakeCache.txt"
        if read_stamp(build_base, package) is not None and cache.is_file():
            cache.unlink()
            changed.append(package)
    return changed


def forget_configured_flags(build_base: Path) -> None:
    """A changed toolchain file must reach the compiles: CMake reads CMAKE_<LANG>_FLAGS_INIT only
    when it creates the CMAKE_<LANG>_FLAGS cache entry, on the first configure
    (https://cmake.org/cmake/help/latest/variable/CMAKE_LANG_FLAGS_INIT.html), so a reconfigure
    would keep compiling with the old flags. Dropping each package's CMakeCache.txt makes colcon
    configure afresh in the same folder; ninja then recompiles what the new flags change."""
    for cache in sorted(build_base.glob("*/CMakeCache.txt")):
        cache.unlink()
