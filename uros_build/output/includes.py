"""The include tree: one folder so that ``#include <rcl/rcl.h>`` works with one -I.

Since Humble, ROS 2 packages install headers to ``include/<pkg>/<pkg>/...`` (REP 122 style
isolation, https://github.com/ros2/ros2/issues/1150); the nested level is folded into one here,
as micro_ros_setup's build script does. Only headers are copied (rosidl leaves .c files next to
generated headers in some versions).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import VerifyError

HEADER_SUFFIXES = (".h", ".hpp", ".hh", ".hxx", ".inc", ".inl", ".idl", ".def")


@dataclass(frozen=True)
class IncludeReport:
    files: int
    packages: int
    bytes: int


def _copy_headers(src: Path, dst: Path, origin: dict[Path, Path], only: frozenset[Path] | None) -> None:
    for path in sorted(src.rglob("*")):
        if not path.is_file() or path.suffix not in HEADER_SUFFIXES:
            continue
        if only is not None and path not in only:
            continue
        _copy_headers_file(path, dst / path.relative_to(src), origin)


def flatten_includes(install_include: Path, out: Path, only: frozenset[Path] | None = None) -> IncludeReport:
    """Flatten ``install_include`` into ``out``; ``only``: copy just these files (the headers of
    one build's packages), so that headers of packages outside the build stay out."""
    out.mkdir(parents=True, exist_ok=True)
    origin: dict[Path, Path] = {}
    packages = 0
    if install_include.is_dir():
        for entry in sorted(install_include.iterdir()):
            if entry.is_dir():
                before = len(origin)
                nested = entry / entry.name
                if nested.is_dir():
                    # include/<pkg>/<pkg>/x.h -> include/<pkg>/x.h; siblings of the nested folder
                    # (rare) are kept at include/<pkg>/ too.
                    _copy_headers(nested, out / entry.name, origin, only)
                    for other in sorted(entry.iterdir()):
                        if other != nested:
                            if other.is_dir():
                                _copy_headers(other, out / entry.name / other.name, origin, only)
                            elif other.suffix in HEADER_SUFFIXES and (only is None or other in only):
                                _copy_headers_file(other, out / entry.name / other.name, origin)
                else:
                    _copy_headers(entry, out / entry.name, origin, only)
                packages += len(origin) > before
            elif entry.is_file() and entry.suffix in HEADER_SUFFIXES and (only is None or entry in only):
                _copy_headers_file(entry, out / entry.name, origin)
    size = sum(p.stat().st_size for p in origin)
    return IncludeReport(files=len(origin), packages=packages, bytes=size)


def _copy_headers_file(path: Path, target: Path, origin: dict[Path, Path]) -> None:
    """One header to its flattened place; the same place from another header is an error unless
    the two are the same bytes (a library whose headers silently lost one would lie)."""
    if target in origin:
        if target.read_bytes() != path.read_bytes():
            raise VerifyError(
                f"two different headers flatten to {target}: {origin[target]} and {path}",
                "rename one of the headers, or keep that package's headers nested",
            )
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(path, target)
    origin[target] = path
