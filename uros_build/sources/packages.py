"""What a workspace's package.xml files say, for choices colcon cannot make itself (pure)."""

from __future__ import annotations

import contextlib
import difflib
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import ConfigError

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

# What a package's own build needs (REP 149: build and buildtool dependencies; <depend> is both
# build and exec), without the export and exec dependencies its dependents need.
_CONFIGURE_DEPS = ("depend", "build_depend", "buildtool_depend")


@dataclass(frozen=True)
class PackageInfo:
    name: str
    build_type: str
    build_deps: frozenset[str]
    path: Path
    # REP 149 groups: <group_depend> names a group, <member_of_group> joins one (colcon-ros
    # resolves a group dependency to every member in the workspace)
    group_deps: frozenset[str] = frozenset()
    groups: frozenset[str] = frozenset()
    # what its own configure and build need (not what its dependents or its users need)
    configure_deps: frozenset[str] = frozenset()


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
        xml = Path(dirpath) / "package.xml"
        # colcon only logs an unreadable manifest (at debug level) and then builds the folder as a
        # plain CMake or Python package, without its dependencies: say so before it does.
        hint = "fix it, or leave the package out with an empty COLCON_IGNORE file in its folder"
        try:
            root = ET.parse(xml).getroot()
        except ET.ParseError as exc:
            raise ConfigError(f"{xml}: not a valid package.xml ({exc})", hint) from None
        except OSError as exc:
            raise ConfigError(f"{xml}: cannot read: {exc.strerror}", hint) from None
        name = (root.findtext("name") or "").strip()
        if not name:
            raise ConfigError(f"{xml}: has no <name>", hint)
        build_type = (root.findtext("export/build_type") or "ament_cmake").strip()
        deps = frozenset((e.text or "").strip() for tag in _BUILD_DEPS for e in root.findall(tag))
        group_deps = frozenset((e.text or "").strip() for e in root.findall("group_depend"))
        groups = frozenset((e.text or "").strip() for e in root.findall("member_of_group"))
        own = frozenset((e.text or "").strip() for tag in _CONFIGURE_DEPS for e in root.findall(tag))
        found.append(PackageInfo(name, build_type, deps, Path(dirpath), group_deps, groups, own))
    return sorted(found, key=lambda p: p.name)


_PROJECT = re.compile(r"^\s*project\s*\(\s*([A-Za-z0-9_.+-]+)", re.IGNORECASE | re.MULTILINE)


def plain_cmake_packages(source_dir: Path) -> set[str]:
    """Packages colcon finds without a package.xml: folders with a CMakeLists.txt, named by their
    project() (colcon-cmake's identification). Only looked for when a name is not found among the
    package.xml packages, so that such a package is never reported missing."""
    found = set()
    for dirpath, dirnames, filenames in os.walk(source_dir):
        if "COLCON_IGNORE" in filenames or "package.xml" in filenames:
            dirnames[:] = []
            continue
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        if "CMakeLists.txt" in filenames:
            dirnames[:] = []
            text = (Path(dirpath) / "CMakeLists.txt").read_text(encoding="utf-8", errors="replace")
            match = _PROJECT.search(text)
            if match:
                found.add(match[1])
    return found


def closest(name: str, names: Iterable[str]) -> list[str]:
    """Package names that look like ``name`` (a typo in --set or a meta file), best first."""
    return difflib.get_close_matches(name, list(names), n=3, cutoff=0.6)


def closure(packages: Iterable[PackageInfo], roots: Iterable[str]) -> set[str]:
    """``roots`` and every package of ``packages`` they depend on, transitively, through the
    dependencies colcon's --packages-up-to follows (names not among ``packages`` are left out:
    they come from elsewhere or are not needed)."""
    by_name = {p.name: p for p in packages}
    members: dict[str, list[str]] = {}
    for p in by_name.values():
        for group in p.groups:
            members.setdefault(group, []).append(p.name)
    found: set[str] = set()
    todo = [r for r in roots if r in by_name]
    while todo:
        name = todo.pop()
        if name in found:
            continue
        found.add(name)
        info = by_name[name]
        todo.extend(d for d in info.build_deps if d in by_name)
        todo.extend(m for group in info.group_deps for m in members.get(group, ()))
    return found


def left_out(packages: Iterable[PackageInfo], roots: Iterable[str]) -> set[str] | None:
    """The packages a build of ``roots`` and what they need (no test dependency) leaves out, for
    colcon's --packages-ignore; None when a root has no package.xml (a plain CMake package, whose
    dependencies only colcon-cmake knows): then colcon's own --packages-up-to must choose."""
    packages = list(packages)
    roots = list(roots)
    names = {p.name for p in packages}
    if not set(roots) <= names:
        return None
    return names - closure(packages, roots)


def tool_closure(mcu: Iterable[PackageInfo], dev: Iterable[PackageInfo]) -> set[str]:
    """The host tools workspace's packages an MCU build needs (pure): those the MCU packages
    depend on (every dependency but tests and docs: build tools, CMake modules they find,
    generators' run-time imports), and everything those need in turn. Linters and uncrustify are
    only test dependencies, which a BUILD_TESTING=OFF build never calls: they are left out."""
    dev = list(dev)
    names = {p.name for p in dev}
    groups = {g for p in dev for g in p.groups}
    roots: set[str] = set()
    for package in mcu:
        roots |= package.build_deps & names
        # an MCU package in a group of dev packages needs the group's members
        for group in package.group_deps & groups:
            roots |= {p.name for p in dev if group in p.groups}
    return closure(dev, roots)


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


# Build types colcon builds through CMake (colcon-ros's ros.cmake and ros.ament_cmake, colcon-cmake's
# cmake): any other one (ament_python, or one uros does not know) may need colcon's Python extensions.
CMAKE_BUILD_TYPES = frozenset({"cmake", "ament_cmake"})
# The files colcon's Python package identification reads (setup.py; setup.cfg beside it)
# https://github.com/colcon/colcon-core/blob/master/colcon_core/package_identification/python.py
# https://github.com/colcon/colcon-python-setup-py/blob/master/colcon_python_setup_py/package_identification/python_setup_py.py
PYTHON_PACKAGE_FILES = frozenset({"setup.py", "setup.cfg"})


def builds_python(packages: Iterable[PackageInfo], built: Collection[str]) -> list[str]:
    """The packages of ``built`` (the names colcon builds) whose package.xml names a build type
    other than CMake's (pure); a name without a package.xml is a plain CMake package."""
    return sorted(p.name for p in packages if p.name in built and p.build_type not in CMAKE_BUILD_TYPES)


def python_outside_packages(
    packages: Iterable[PackageInfo], source_dir: Path, files: Iterable[str]
) -> list[str]:
    """The setup.py and setup.cfg among ``files`` (paths relative to ``source_dir``, '/'-separated:
    the workspace's scan, which leaves out COLCON_IGNORE folders as colcon does) that are not in the
    folder of a package.xml package (pure): colcon would identify a Python package there that uros
    does not list (one nested in a package's folder, where colcon does not look, is counted too)."""
    folders = set()
    for p in packages:
        with contextlib.suppress(ValueError):
            rel = p.path.relative_to(source_dir).as_posix()
            folders.add("" if rel == "." else rel)
    found = []
    for path in files:
        folder, _, name = path.rpartition("/")
        if name in PYTHON_PACKAGE_FILES and folder not in folders:
            found.append(path)
    return sorted(found)
