"""What a workspace's package.xml files say, for choices colcon cannot make itself (pure)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

# Every dependency but tests and docs: a generator package's exec and export dependencies run
# while its dependents build (iron's rosidl_generator_c imports rosidl_pycommon, an
# ament_python package it names as buildtool_export_depend).
_BUILD_DEPS = (
    "depend",
    "build_depend",
    "buildtool_depend",
    "build_export_depend",
    "buildtool_export_depend",
    "exec_depend",
    "run_depend",
)


@dataclass(frozen=True)
class PackageInfo:
    name: str
    build_type: str
    build_deps: frozenset[str]
    path: Path


def discover(source_dir: Path) -> list[PackageInfo]:
    """Every package colcon would find under ``source_dir`` (COLCON_IGNORE respected)."""
    found = []
    for dirpath, dirnames, filenames in os.walk(source_dir):
        if "COLCON_IGNORE" in filenames:
            dirnames[:] = []
            continue
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        if "package.xml" not in filenames:
            continue
        dirnames[:] = []  # packages do not nest
        try:
            root = ET.parse(Path(dirpath) / "package.xml").getroot()
        except ET.ParseError:
            continue  # colcon reports it
        name = (root.findtext("name") or "").strip()
        build_type = (root.findtext("export/build_type") or "ament_cmake").strip()
        deps = frozenset((e.text or "").strip() for tag in _BUILD_DEPS for e in root.findall(tag))
        if name:
            found.append(PackageInfo(name, build_type, deps, Path(dirpath)))
    return sorted(found, key=lambda p: p.name)


def host_only(packages: list[PackageInfo]) -> list[str]:
    """Pure-Python packages nothing compiled depends on (ros2trace, tracetools_*, sensor_msgs_py,
    rosidl_cli in humble): they put no object into libmicroros.a, yet colcon spends seconds on each
    at every build. micro_ros_setup builds them anyway."""
    by_name = {p.name: p for p in packages}
    python = {p.name for p in packages if p.build_type == "ament_python"}
    needed: set[str] = set()
    todo = [d for p in packages if p.build_type != "ament_python" for d in p.build_deps]
    while todo:  # what compiled packages need, transitively
        name = todo.pop()
        if name in needed:
            continue
        needed.add(name)
        if name in by_name:
            todo.extend(by_name[name].build_deps)
    return sorted(python - needed)
