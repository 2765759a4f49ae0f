"""Issue 19, item 1: packages that compile nothing are built once per workspace, for the host (the
host stage), and copied into each target's install tree; the library and include tree are byte for
byte those of a build that configures them for the target (UROS_HOST_STAGE=off), a listed package
that does compile code is built per target, and no copied file names the stage's folder."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from fixture_ws import add_vendor_package, make_fixture_workspace
from uros_helpers import build_fixture, need, once_then_restored, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

_XML = """<?xml version="1.0"?>
<package format="3"><name>{name}</name><version>0.1.0</version><description>fixture</description>
<maintainer email="dev@example.com">uros tests</maintainer><license>Apache-2.0</license>
{deps}<export><build_type>cmake</build_type></export></package>
"""

# names from meta/host-stage.yaml, shaped as the real ones are: a header (and a C project, as the
# real rosidl_typesupport_interface declares), CMake modules, and a "tracetools" that compiles a
# library (its real one does unless TRACETOOLS_DISABLED)
HEADER_ONLY = """cmake_minimum_required(VERSION 3.16)
project(rosidl_typesupport_interface C)
install(DIRECTORY include/ DESTINATION include/rosidl_typesupport_interface)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/rosidl_typesupport_interfaceConfig.cmake
  "set(rosidl_typesupport_interface_INCLUDE_DIRS \\"\\${CMAKE_CURRENT_LIST_DIR}/../../../include/rosidl_typesupport_interface\\")\\n")
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/rosidl_typesupport_interfaceConfig.cmake
  DESTINATION share/rosidl_typesupport_interface/cmake)
"""
MODULES = """cmake_minimum_required(VERSION 3.16)
project(rmw_implementation_cmake NONE)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/rmw_implementation_cmakeConfig.cmake "set(FX_RMW_CMAKE_FOUND 1)\\n")
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/rmw_implementation_cmakeConfig.cmake
  DESTINATION share/rmw_implementation_cmake/cmake)
"""
COMPILES = """cmake_minimum_required(VERSION 3.16)
project(tracetools C)
add_library(tracetools STATIC tracetools.c)
install(TARGETS tracetools ARCHIVE DESTINATION lib)
"""
USER = """cmake_minimum_required(VERSION 3.16)
project(fx_user C)
find_package(rosidl_typesupport_interface REQUIRED)
find_package(rmw_implementation_cmake REQUIRED)
add_library(fx_user STATIC user.c)
target_include_directories(fx_user PRIVATE ${rosidl_typesupport_interface_INCLUDE_DIRS})
install(TARGETS fx_user ARCHIVE DESTINATION lib)
"""


def _package(
    root: Path, name: str, cmake: str, deps: tuple[str, ...] = (), files: dict[str, str] | None = None
) -> None:
    folder = root / "mcu_ws" / "src" / name
    folder.mkdir(parents=True)
    lines = "".join(f"<build_depend>{d}</build_depend>\n" for d in deps)
    (folder / "package.xml").write_text(_XML.format(name=name, deps=lines))
    (folder / "CMakeLists.txt").write_text(cmake)
    for rel, text in (files or {}).items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_text(text)


def _workspace(root: Path) -> Path:
    ws = make_fixture_workspace(root)
    macros = "#define FX_TYPESUPPORT_SYMBOL(x) fx_typesupport_##x\n"
    _package(ws, "rosidl_typesupport_interface", HEADER_ONLY, files={"include/fx_macros.h": macros})
    _package(ws, "rmw_implementation_cmake", MODULES)
    _package(ws, "tracetools", COMPILES, files={"tracetools.c": "int fx_trace_value(void) { return 3; }\n"})
    source = '#include "fx_macros.h"\nint FX_TYPESUPPORT_SYMBOL(user)(void) { return 42; }\n'
    deps = ("rosidl_typesupport_interface", "rmw_implementation_cmake", "tracetools")
    _package(ws, "fx_user", USER, deps, files={"user.c": source})
    return ws


# a build of fx_user and what it needs: the host stage's packages and tracetools, which fx_user
# depends on, without the fixture's five packages (they have no part in the stage)
_UP_TO_USER = ("--packages-up-to", "fx_user")
# and of the vendor package too (an ExternalProject): what the staged workspace's builds are about
_UP_TO_STAGED = (*_UP_TO_USER, "--packages-up-to", "fx_vendor")


def _build(ws: Path, target: str, *more: str, **env: str) -> str:
    proc = build_fixture(ws, *more, toolchain=target, env={**os.environ, **env})
    return proc.stdout + proc.stderr


def _staged_build(ws: Path, *more: str, **env: str) -> str:
    """The cortex-m7 build of :func:`_staged_workspace`: fx_user, fx_vendor and what they need."""
    return _build(ws, "cortex-m7", *_UP_TO_STAGED, *more, **env)


def _staged_workspace(root: Path) -> Path:
    """The workspace of :func:`_workspace` with the vendor package (an ExternalProject) too."""
    ws = _workspace(root)
    add_vendor_package(ws)
    return ws


@pytest.fixture(scope="module")
def _first_build(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """:func:`_staged_workspace` built for cortex-m7 once for the module (its first build: the host
    stage built), kept as a snapshot beside it; (the snapshot, that build's output lines)."""
    need("cmake", "colcon", "arm-none-eabi-gcc", "gcc")
    top = tmp_path_factory.mktemp("host-stage")
    ws = _staged_workspace(top / "ws")
    out = _staged_build(ws)
    shutil.copytree(ws, top / "snapshot", symlinks=True)
    return top / "snapshot", out


@pytest.fixture
def first_build(_first_build: tuple[Path, str]) -> tuple[Path, str]:
    """The module's first build, restored for this test where it was built (copytree keeps every
    mtime: its next build is up to date): (the workspace, that first build's output lines)."""
    snapshot, out = _first_build
    return once_then_restored(snapshot, snapshot.with_name("ws")), out


def test_packages_that_compile_nothing_are_built_once_and_the_library_is_unchanged(
    tmp_path: Path, first_build: tuple[Path, str]
) -> None:
    ws, out = first_build  # the first build of the workspace, and what it said
    shared = ["rmw_implementation_cmake", "rosidl_typesupport_interface"]
    assert "the host stage" in out and "tracetools: compiled code in the host stage" in out, out
    info = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())
    assert info["host_stage_packages"] == shared
    assert set(shared) <= set(info["packages"]) and "tracetools" in info["packages"]
    # the listed package that compiles was built for the target: its object is in the library
    assert "libtracetools.a" in info["library"]["inputs"]
    # the header the stage installed is in the include tree, and was compiled against
    assert (ws / "build" / "cortex-m7" / "include" / "rosidl_typesupport_interface" / "fx_macros.h").is_file()
    # nothing the target's trees hold names the stage's folder (but uros's own record of it)
    target = ws / ".uros" / "targets" / "cortex-m7"
    for path in (target / "install").rglob("*"):
        if path.is_file():
            assert b".uros/shared" not in path.read_bytes(), path
    for path in (target / "build").rglob("CMakeCache.txt"):
        assert ".uros/shared" not in path.read_text(errors="replace"), path

    # a second target takes the stage as it is: no colcon run for it (fx_user and what it needs:
    # the stage's packages, not the fixture's five, which the stage does not concern)
    out = _build(ws, "cortex-m4", *_UP_TO_USER)
    assert "packages that compile nothing once" not in out and "from the host stage: 2 packages" in out, out
    info4 = json.loads((ws / "build" / "cortex-m4" / "build-info.json").read_text())
    assert info4["host_stage_packages"] == shared

    # the same target without the stage: the same library and include tree, byte for byte
    staged = tmp_path / "staged"
    shutil.copytree(ws / "build" / "cortex-m7", staged)
    out = _staged_build(ws, UROS_HOST_STAGE="off")
    assert "the host stage" not in out
    plain = ws / "build" / "cortex-m7"
    assert (plain / "libmicroros.a").read_bytes() == (staged / "libmicroros.a").read_bytes()
    inc = sorted(p.relative_to(staged) for p in (staged / "include").rglob("*") if p.is_file())
    assert inc == sorted(p.relative_to(plain) for p in (plain / "include").rglob("*") if p.is_file())
    assert all((plain / p).read_bytes() == (staged / p).read_bytes() for p in inc)
    assert "host_stage_packages" not in json.loads((plain / "build-info.json").read_text())

    # and back: the stage's files replace what the target built itself
    out = _staged_build(ws)
    assert "from the host stage: 2 packages" in out, out
    assert (plain / "libmicroros.a").read_bytes() == (staged / "libmicroros.a").read_bytes()

    # the stages are uros's: `uros clean --all` removes them with the targets
    stages = list((ws / ".uros" / "shared").iterdir())
    assert len(stages) == 1
    mine = ws / ".uros" / "shared" / "my-notes"  # not a folder uros names: not uros's to remove
    mine.mkdir()
    (mine / "keep.txt").write_text("mine\n")
    cleaned = run_uros("clean", "--all", "-w", str(ws))
    assert (mine / "keep.txt").read_text() == "mine\n"
    assert f"removed {stages[0]}" in cleaned.stdout + cleaned.stderr and not stages[0].exists()


def test_a_stage_that_fails_on_the_host_leaves_its_packages_to_each_target(tmp_path: Path) -> None:
    need("cmake", "colcon", "arm-none-eabi-gcc", "gcc")
    ws = _workspace(tmp_path)
    # a listed package whose configure works only for the target (as one needing a host compiler
    # the machine lacks would fail)
    cmake = ws / "mcu_ws" / "src" / "rmw_implementation_cmake" / "CMakeLists.txt"
    cmake.write_text(
        MODULES.replace(
            "project(rmw_implementation_cmake NONE)\n",
            "project(rmw_implementation_cmake NONE)\n"
            'if(NOT CMAKE_CROSSCOMPILING)\n  message(FATAL_ERROR "fixture: the host cannot configure me")\nendif()\n',
        )
    )
    # fx_user and what it needs: the stage's packages (and tracetools), not the fixture's five
    out = _build(ws, "cortex-m7", *_UP_TO_USER)
    assert "warning: the host stage failed" in out and "each target builds these packages itself" in out, out
    info = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())
    assert "host_stage_packages" not in info
    assert {"rmw_implementation_cmake", "rosidl_typesupport_interface"} <= set(info["packages"])
    # the failure is remembered for the stage's key: the next target does not try again
    out = _build(ws, "cortex-m4", *_UP_TO_USER)
    assert "the host stage" not in out, out


def test_a_team_cache_hit_builds_no_host_stage(tmp_path: Path, first_build: tuple[Path, str]) -> None:
    """The stage is built when colcon is about to run, not before the team cache is asked: a fresh
    checkout that takes its library from the cache runs no colcon at all."""
    store = tmp_path / "store"
    store.mkdir()
    first, said = first_build  # built (the host stage built in its first build), and up to date
    assert "the host stage" in said
    assert "uploaded entry" in _staged_build(first, "--cache", store.as_uri(), "--cache-upload")
    fresh = _staged_workspace(tmp_path / "fresh")
    out = _staged_build(fresh, "--cache", store.as_uri())
    assert "from the cache" in out and "host stage" not in out and "colcon build" not in out, out
    assert not (fresh / ".uros" / "shared").exists()


def _no_path_of(old: Path, folder: Path) -> None:
    for path in folder.rglob("*"):
        if path.is_file() and not path.is_symlink():
            assert str(old).encode() not in path.read_bytes(), path


def test_a_moved_or_copied_workspace_builds_the_same_library(
    tmp_path: Path, first_build: tuple[Path, str]
) -> None:
    """Issue 34, item 1: a built workspace copied (`cp -a`) or moved (`mv`) builds again with no hand
    work: the CMake trees configured in the old folder (an ExternalProject's nested one too, as
    libyaml_vendor's) are configured afresh, the host stage is built again where it is now and
    taken whole into the target's trees, and the library is the same bytes."""
    need("cp")
    ws, _ = first_build  # built where it is (the move and the copy are the subject, not this build)
    out = ws / "build" / "cortex-m7"
    digest = hashlib.sha256((out / "libmicroros.a").read_bytes()).hexdigest()
    headers = sorted(p.relative_to(out) for p in (out / "include").rglob("*") if p.is_file())
    assert (
        Path("include/fx_upstream/upstream.h") in headers
        and Path("include/rosidl_typesupport_interface/fx_macros.h") in headers
    )
    info = json.loads((out / "build-info.json").read_text())
    assert "libfx_upstream.a" in info["library"]["inputs"], info["library"]

    def builds_as_before(new: Path, how: str) -> None:
        text = _staged_build(new)
        assert "(the workspace moved or was copied): configuring its" in text, (how, text)
        assert "the host stage failed" not in text and "from the host stage: 2 packages" in text, (how, text)
        built = new / "build" / "cortex-m7"
        assert hashlib.sha256((built / "libmicroros.a").read_bytes()).hexdigest() == digest, how
        assert sorted(p.relative_to(built) for p in (built / "include").rglob("*") if p.is_file()) == headers
        # nothing the library, the output or the target's install tree holds names the old folder
        _no_path_of(ws, built)
        _no_path_of(ws, new / ".uros" / "targets" / "cortex-m7" / "install")
        # and the next build has nothing to redo
        assert "up to date" in _staged_build(new), how

    copy = tmp_path / "copy"
    subprocess.run(["cp", "-a", str(ws), str(copy)], check=True)
    builds_as_before(copy, "cp -a")
    # the original is untouched by its copy's build
    assert "up to date" in _staged_build(ws)
    moved = tmp_path / "moved"
    ws.rename(moved)
    builds_as_before(moved, "mv")
