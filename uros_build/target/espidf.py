"""An ESP-IDF project's build folder, read for what micro-ROS needs to compile against it.

micro_ros_espidf_component compiles micro-ROS inside the IDF configure with exactly these
(https://github.com/micro-ROS/micro_ros_espidf_component/blob/humble/CMakeLists.txt and its
esp32_toolchain.cmake.in):

- ``-I<dir>/<inc>`` for every public include folder of every build component
  (``idf_build_get_property(BUILD_COMPONENTS)``, then ``COMPONENT_DIR`` and ``INCLUDE_DIRS``;
  private include folders are not passed);
- ``-I<build>/config`` (IDF's CONFIG_DIR, where kconfgen writes sdkconfig.h) and
  ``-I<IDF_PATH>/components/soc/<IDF_TARGET>/include``;
- ``CMAKE_C_FLAGS``/``CMAKE_CXX_FLAGS`` of the IDF project (IDF's base flags: ``-mlongcalls``,
  ``-fno-builtin-memcpy``, ...);
- C17 from IDF 5 on (C11 before).

After ``idf.py reconfigure`` the same facts sit in the build folder: ``project_description.json``
(``build_components``; ``build_component_info[c].dir`` and ``.include_dirs``, relative to the
component, public only; ``target``; ``idf_path``; ``git_revision``), ``CMakeCache.txt`` and
``config/sdkconfig.h``. For an IDF 5.3 project with nvs_flash/esp_eth/lwip the description gives
the same 66 folders as the component's loop (checked by a probe component).

From IDF 5.5 on, ``CMAKE_C_FLAGS`` is a GCC response file, ``@"<build>/toolchain/cflags"``
(tools/cmake/toolchain.cmake; micro-ROS/micro_ros_espidf_component#327 is what breaks when the
component pastes it through sed). uros reads the file and splits it the way GCC itself does
(libiberty's ``buildargv``/``expandargv``), so each flag reaches the compiler as one word.

Pure: reads files, starts no process.
"""

from __future__ import annotations

import hashlib
import re
import shlex
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import loader
from uros_build.defaults import BUILD_INFO
from uros_build.errors import ConfigError

DESCRIPTION = "project_description.json"
CACHE = "CMakeCache.txt"
SDKCONFIG_H = "sdkconfig.h"
_RECONFIGURE = "run `idf.py reconfigure` in the ESP-IDF project and pass its build folder"
# GCC stops expanding nested response files at this depth (libiberty's expandargv has no limit
# but a file that names itself would never end).
_MAX_RESPONSE_DEPTH = 16
_VERSION = re.compile(r"v?(\d+)\.(\d+)(?:\.(\d+))?")
_CMAKE_VERSION_LINE = re.compile(r"^\s*set\(\s*IDF_VERSION_(MAJOR|MINOR|PATCH)\s+(\d+)\s*\)", re.M)
_SDKCONFIG_HEADER = re.compile(r"\(ESP-IDF\)\s+v?(\d+\.\d+(?:\.\d+)?)\s+Configuration Header")
# NAME:TYPE=VALUE, NAME=VALUE, or "NA:ME":TYPE=VALUE (CMake quotes a name holding ':' or '=')
_CACHE_LINE = re.compile(r'^(?:"(?P<quoted>[^"]*)"|(?P<name>[^:=]+?))(?::(?P<type>[A-Z_]+))?=(?P<value>.*)$')


@dataclass(frozen=True)
class IdfProject:
    """What micro-ROS compiles against, from one IDF build folder."""

    build_dir: str
    idf_path: str
    version: tuple[int, int, int]
    target: str  # IDF_TARGET
    include_dirs: tuple[str, ...]  # build components' public folders, then config/, then soc/<target>
    c_flags: tuple[str, ...]  # CMAKE_C_FLAGS, response files expanded
    cxx_flags: tuple[str, ...]
    sdkconfig_h: str
    sdkconfig_sha256: str
    components: int

    @property
    def version_text(self) -> str:
        return ".".join(str(n) for n in self.version)

    @property
    def c_standard(self) -> int:
        """micro_ros_espidf_component: C17 with IDF 5 (and later), C11 before."""
        return 17 if self.version[0] >= 5 else 11


# ---------------------------------------------------------------------------------------------
# command lines and GCC response files


def split_shell(text: str, where: str) -> list[str]:
    """A command-line fragment as the shell splits it (CMake hands CMAKE_<LANG>_FLAGS to the
    shell through build.ninja / the Makefiles)."""
    try:
        return shlex.split(text, comments=False, posix=True)
    except ValueError as exc:
        raise ConfigError(f"{where}: cannot split {text!r} into flags: {exc}", _RECONFIGURE) from None


def split_response_file(text: str) -> list[str]:
    """The arguments of a GCC response file, split as libiberty's ``buildargv`` does
    (https://github.com/gcc-mirror/gcc/blob/releases/gcc-12/libiberty/argv.c): white space
    separates arguments; single and double quotes group, and are removed; a backslash takes the
    next character literally, inside quotes too; ``""`` is an empty argument."""
    args: list[str] = []
    i, n = 0, len(text)
    while i < n:
        while i < n and text[i] in " \t\n\r\f\v":
            i += 1
        if i >= n:
            break
        arg: list[str] = []
        squote = dquote = bsquote = False
        while i < n:
            c = text[i]
            if c in " \t\n\r\f\v" and not (squote or dquote or bsquote):
                break
            if bsquote:
                bsquote = False
                arg.append(c)
            elif c == "\\":
                bsquote = True
            elif squote:
                if c == "'":
                    squote = False
                else:
                    arg.append(c)
            elif dquote:
                if c == '"':
                    dquote = False
                else:
                    arg.append(c)
            elif c == "'":
                squote = True
            elif c == '"':
                dquote = True
            else:
                arg.append(c)
            i += 1
        args.append("".join(arg))
    return args


def expand_response_files(
    args: list[str], read: Callable[[Path], str], base: Path, where: str, depth: int = 0
) -> list[str]:
    """``@file`` arguments replaced by the file's arguments, recursively, as GCC's ``expandargv``
    does; a relative file is found from ``base`` (the folder IDF's compiles run in). ``read`` is
    the file reader (a parameter so tests need no files). Unlike GCC, which passes an unreadable
    ``@file`` on as a plain argument, a missing file is an error: the flags would be wrong."""
    out: list[str] = []
    for arg in args:
        if not arg.startswith("@") or len(arg) == 1:
            out.append(arg)
            continue
        if depth >= _MAX_RESPONSE_DEPTH:
            raise ConfigError(f"{where}: response files nest deeper than {_MAX_RESPONSE_DEPTH}: {arg}")
        path = Path(arg[1:])
        path = path if path.is_absolute() else base / path
        inner = split_response_file(read(path))
        out += expand_response_files(inner, read, path.parent, f"{where} ({arg})", depth + 1)
    return out


# ---------------------------------------------------------------------------------------------
# CMakeCache.txt, versions


def parse_cmake_cache(text: str) -> dict[str, str]:
    """``NAME:TYPE=VALUE`` lines of a CMakeCache.txt -> {NAME: VALUE} (comments skipped)."""
    entries: dict[str, str] = {}
    for line in text.splitlines():
        if not line or line.startswith(("#", "//")):
            continue
        match = _CACHE_LINE.match(line)
        if match:
            entries[match["quoted"] if match["quoted"] is not None else match["name"]] = match["value"]
    return entries


def version_from_cmake(text: str) -> tuple[int, int, int] | None:
    """IDF's own tools/cmake/version.cmake: set(IDF_VERSION_MAJOR 5) ..."""
    parts = dict(_CMAKE_VERSION_LINE.findall(text))
    if "MAJOR" not in parts or "MINOR" not in parts:
        return None
    return int(parts["MAJOR"]), int(parts["MINOR"]), int(parts.get("PATCH", "0"))


def version_from_text(text: str) -> tuple[int, int, int] | None:
    """'v5.3.1', 'v5.3.1-dirty', 'v5.4-dev-123-gabcdef', '5.3' -> (5, 3, 1) / (5, 4, 0)."""
    match = _VERSION.match(text.strip())
    if match is None:
        return None
    return int(match[1]), int(match[2]), int(match[3] or 0)


def version_from_sdkconfig_h(text: str) -> tuple[int, int, int] | None:
    """kconfgen's header: '* Espressif IoT Development Framework (ESP-IDF) 5.3.1 Configuration Header'."""
    match = _SDKCONFIG_HEADER.search(text)
    return version_from_text(match[1]) if match else None


# ---------------------------------------------------------------------------------------------
# project_description.json


@dataclass(frozen=True)
class _Component:
    name: str
    dir: str
    include_dirs: tuple[str, ...]


@dataclass(frozen=True)
class Description:
    idf_path: str
    build_dir: str
    target: str
    git_revision: str
    config_file: str
    components: tuple[_Component, ...]


def parse_description(data: Any, source: str) -> Description:
    top = loader.mapping(data, source, required=("target", "idf_path", "build_components"))
    # IDF's list-to-JSON conversion leaves a trailing "" in build_components (IDF 5.3: `"xtensa", ""`)
    names = [n for n in loader.string_list(top, "build_components", source) if n]
    info = loader.mapping(top.get("build_component_info"), f"{source}: build_component_info")
    components = []
    for name in names:
        where = f"{source}: build_component_info.{name}"
        if name not in info:
            raise ConfigError(f"{where}: missing (the component is in build_components)", _RECONFIGURE)
        entry = loader.mapping(info[name], where, required=("dir",))
        components.append(
            _Component(
                name=name,
                dir=loader.string(entry, "dir", where),
                include_dirs=loader.string_list(entry, "include_dirs", where),
            )
        )
    revision = top.get("git_revision")
    return Description(
        idf_path=loader.string(top, "idf_path", source),
        build_dir=str(top.get("build_dir") or ""),
        target=loader.string(top, "target", source),
        git_revision=revision if isinstance(revision, str) else "",
        config_file=str(top.get("config_file") or ""),
        components=tuple(components),
    )


def _made_by_uros(folder: Path) -> bool:
    """A component `uros export esp-idf` wrote (its build-info.json says so). Its include folder
    is an older micro-ROS: compiling micro-ROS against it would mix old headers into the build."""
    info = folder / BUILD_INFO
    try:
        return info.is_file() and '"generated_by": "uros' in info.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False


def include_dirs(desc: Description) -> tuple[tuple[str, ...], int]:
    """Every build component's public include folder, in BUILD_COMPONENTS order, each once
    (micro_ros_espidf_component's loop); a uros-exported micro-ROS component is left out.
    Returns (folders, number of components used)."""
    out: list[str] = []
    used = 0
    for comp in desc.components:
        base = Path(comp.dir)
        if _made_by_uros(base):
            continue
        used += 1
        for inc in filter(None, comp.include_dirs):
            path = str(base / inc)
            if path not in out:
                out.append(path)
    return tuple(out), used


# ---------------------------------------------------------------------------------------------
# the build folder


def _read(path: Path, what: str, flag: str) -> str:
    if not path.is_file():
        raise ConfigError(f"{flag}: {what} {path} does not exist", _RECONFIGURE)
    return loader.read_text(path, flag, _RECONFIGURE)


def _version(desc: Description, sdkconfig_text: str, source: str, flag: str) -> tuple[int, int, int]:
    version_cmake = Path(desc.idf_path) / "tools" / "cmake" / "version.cmake"
    found = None
    if version_cmake.is_file():
        found = version_from_cmake(loader.read_text(version_cmake, flag))
    found = found or version_from_text(desc.git_revision) or version_from_sdkconfig_h(sdkconfig_text)
    if found is None:
        raise ConfigError(
            f"{source}: cannot tell the ESP-IDF version (no {version_cmake}, git_revision "
            f"{desc.git_revision!r}, no version in {SDKCONFIG_H})",
            "point IDF_PATH at a complete ESP-IDF and run `idf.py reconfigure` again",
        )
    if found[0] < 4:
        raise ConfigError(
            f"{source}: ESP-IDF {'.'.join(map(str, found))} is too old (micro-ROS needs ESP-IDF 4 or later)",
            "use ESP-IDF 4.4 or later (5.x recommended)",
        )
    return found


def _flags(cache: Mapping[str, str], name: str, build: Path, source: str, flag: str) -> tuple[str, ...]:
    words = split_shell(cache.get(name, ""), f"{source}: {name}")

    def read(path: Path) -> str:
        return _read(path, f"the response file in {name},", flag)

    return tuple(expand_response_files(words, read, build, f"{source}: {name}"))


def read_idf_build(build: Path, idf_target: str, uros_target: str, flag: str = "--idf-build") -> IdfProject:
    """The facts of an IDF build folder after ``idf.py reconfigure``, checked against the target
    uros builds for (``idf_target``, the profile's IDF_TARGET). One-line ConfigErrors naming
    ``flag`` (the option, or the uros.yaml key the folder came from)."""
    build = build.resolve()
    if not build.is_dir():
        raise ConfigError(f"{flag} {build}: no such folder", _RECONFIGURE)
    desc_path = build / DESCRIPTION
    if not desc_path.is_file():
        raise ConfigError(
            f"{flag} {build}: no {DESCRIPTION}, so it is not an ESP-IDF build folder "
            "(or the project was never configured)",
            _RECONFIGURE,
        )
    if not idf_target:
        raise ConfigError(
            f"{flag}: target {uros_target} is not an ESP-IDF target",
            "build for esp32, esp32s2, esp32s3, esp32c3, esp32c6, esp32h2 or esp32p4 "
            "(uros build --toolchain esp32s3 --idf-build DIR)",
        )
    source = f"{flag} {desc_path}"
    desc = parse_description(loader.load_json(desc_path, flag, _RECONFIGURE), source)
    if desc.target != idf_target:
        raise ConfigError(
            f"{flag} {build}: the project builds for IDF_TARGET {desc.target}, uros builds for "
            f"{idf_target} ({uros_target})",
            f"build with --toolchain {desc.target}, or run `idf.py set-target {idf_target}` in the project",
        )
    cache = parse_cmake_cache(_read(build / CACHE, "the CMake cache", flag))
    config_dir = build / "config"
    sdkconfig = config_dir / SDKCONFIG_H
    sdkconfig_text = _read(sdkconfig, "the IDF configuration header", flag)
    version = _version(desc, sdkconfig_text, source, flag)
    soc = Path(desc.idf_path) / "components" / "soc" / desc.target / "include"
    dirs, used = include_dirs(desc)
    for folder in (*dirs, str(soc)):
        if not Path(folder).is_dir():
            raise ConfigError(
                f"{flag} {build}: the include folder {folder} does not exist (IDF moved or the build "
                "folder is stale)",
                _RECONFIGURE,
            )
    return IdfProject(
        build_dir=str(build),
        idf_path=desc.idf_path,
        version=version,
        target=desc.target,
        include_dirs=tuple(dict.fromkeys((*dirs, str(config_dir), str(soc)))),
        c_flags=_flags(cache, "CMAKE_C_FLAGS", build, f"{flag} {build / CACHE}", flag),
        cxx_flags=_flags(cache, "CMAKE_CXX_FLAGS", build, f"{flag} {build / CACHE}", flag),
        sdkconfig_h=str(sdkconfig),
        sdkconfig_sha256=hashlib.sha256(sdkconfig.read_bytes()).hexdigest(),
        components=used,
    )
