"""Issue 19, item 4: ccache for what the caches above miss. Compiles go through ccache when it is
installed; another checkout at another path (with a space) hits every compile; and the library is
byte for byte the one built without ccache, __FILE__ of sources and of generated sources included
(ccache's base_dir hands the compiler relative paths: the toolchain's maps name them as the
absolute ones are named)."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE, fixture_build_args, make_fixture_workspace
from uros_helpers import REPO, build_fixture, env_without, need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

WHERE_CMAKE = """\
cmake_minimum_required(VERSION 3.16)
project(fx_where C)
add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/gen/where_gen.c
  COMMAND ${CMAKE_COMMAND} -E copy ${CMAKE_CURRENT_SOURCE_DIR}/where_gen.c.in ${CMAKE_CURRENT_BINARY_DIR}/gen/where_gen.c
  DEPENDS where_gen.c.in)
add_library(fx_where STATIC where.c ${CMAKE_CURRENT_BINARY_DIR}/gen/where_gen.c)
install(TARGETS fx_where ARCHIVE DESTINATION lib)
"""

PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>fx_where</name><version>0.1.0</version><description>__FILE__</description>
  <maintainer email="dev@example.com">uros tests</maintainer><license>Apache-2.0</license>
  <export><build_type>cmake</build_type></export>
</package>
"""


def _workspace(root: Path) -> Path:
    ws = make_fixture_workspace(root)
    pkg = ws / "mcu_ws" / "src" / "fx_where"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(PACKAGE_XML)
    (pkg / "CMakeLists.txt").write_text(WHERE_CMAKE)
    (pkg / "where.c").write_text("const char *fx_where(void) { return __FILE__; }\n")
    (pkg / "where_gen.c.in").write_text("const char *fx_where_gen(void) { return __FILE__; }\n")
    return ws


def test_another_checkout_hits_every_compile_and_the_library_keeps_its_bytes(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake", "ccache", "arm-none-eabi-strings")
    env = {**os.environ, "CCACHE_DIR": str(tmp_path / "ccache")}
    one = _workspace(tmp_path / "one")
    two = _workspace(tmp_path / "checkout two")
    plain = _workspace(tmp_path / "plain")

    def build(ws: Path, *more: str) -> str:
        args = ["build", "--toolchain", "cortex-m7", "-w", str(ws), "--meta", str(ws / "fixture.meta"), *more]
        return run_uros(*args, env=env).stderr

    first = build(one, "--ccache")
    assert "ccache: 0 of 10 compiles taken from the cache" in first, first
    # ccache's depend mode: each miss ran the compiler once, no preprocessor run before it
    stats = (one / ".uros" / "targets" / "cortex-m7" / "ccache-stats.log").read_text()
    assert stats.count("\ncache_miss") == 10 and "preprocessed_cache_miss" not in stats, stats
    second = build(two)  # ccache is the default where it is installed
    assert "ccache: 10 of 10 compiles taken from the cache (100%)" in second, second
    info = json.loads((two / "build" / "cortex-m7" / "build-info.json").read_text())
    assert info["ccache"] == {"hits": 10, "misses": 0}
    shown = run_uros("info", str(two / "build" / "cortex-m7"), env=env).stdout
    assert "ccache     10 of 10 compiles of this build taken from the cache" in shown
    doctor = run_uros("doctor", "-w", str(two), env=env, check=False).stdout
    assert "ccache" in doctor and "(uros build compiles through it)" in doctor
    without = build(plain, "--no-ccache")
    assert "ccache:" not in without
    assert "ccache" not in json.loads((plain / "build" / "cortex-m7" / "build-info.json").read_text())

    lib = Path("build") / "cortex-m7" / "libmicroros.a"
    assert (one / lib).read_bytes() == (two / lib).read_bytes() == (plain / lib).read_bytes()
    strings = subprocess.run(
        ["arm-none-eabi-strings", "-a", str(two / lib)], capture_output=True, text=True
    ).stdout
    assert "./mcu_ws/src/fx_where/where.c" in strings  # the workspace's sources: ./ and their path in it
    assert "gen/where_gen.c" in strings.split()  # generated ones: their path in the build folder
    assert str(tmp_path) not in strings and "../" not in strings
    shutil.rmtree(tmp_path / "ccache")


def _build(ws: Path, env: dict[str, str], *more: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return build_fixture(ws, *more, env=env, check=check)


MARK_PACKAGE_XML = PACKAGE_XML.replace("fx_where", "fx_mark")
MARK_CMAKE = """\
cmake_minimum_required(VERSION 3.16)
project(fx_mark C)
add_library(fx_mark STATIC mark.c)
install(TARGETS fx_mark ARCHIVE DESTINATION lib)
"""


def _compiler_folder(folder: Path, mark: str) -> Path:
    """arm-none-eabi-* linked into ``folder``, with a gcc that is a driver script around the real
    one adding ``-DFX_MARK="<mark>"`` (as distributions' wrapper drivers do): two such compilers
    with marks of one length have the same size, and os.utime gives them the same mtime."""
    folder.mkdir(parents=True, exist_ok=True)
    for tool in ("g++", "ar", "ranlib", "nm", "objcopy", "size", "readelf"):
        link = folder / f"arm-none-eabi-{tool}"
        if not link.exists():
            link.symlink_to(shutil.which(f"arm-none-eabi-{tool}") or f"/usr/bin/arm-none-eabi-{tool}")
    real = shutil.which("arm-none-eabi-gcc")
    new = folder / "arm-none-eabi-gcc.new"
    new.write_text(f'#!/bin/sh\nexec {real} \'-DFX_MARK="{mark}"\' "$@"\n')
    new.chmod(0o755)
    os.utime(new, ns=(1_600_000_000_000_000_000, 1_600_000_000_000_000_000))
    os.replace(new, folder / "arm-none-eabi-gcc")  # a new file at the path: as an upgrade installs one
    return folder / "arm-none-eabi-"


def test_a_compiler_replaced_with_the_same_size_and_mtime_never_gets_the_old_objects(tmp_path: Path) -> None:
    """Issue 34, item 7: ccache's default compiler check is the driver's size and mtime, so a
    compiler replaced by one with the same size and mtime got the old compiler's objects back
    (uros saw the change and rebuilt every package, and ccache served each compile). uros sets
    ccache's compiler check to the driver's content. fx_mark alone: its object is the one that
    shows which compiler made it (the fixture's packages added only their fixed cost)."""
    need("arm-none-eabi-gcc", "cmake", "ccache", "arm-none-eabi-strings")
    env = {**os.environ, "CCACHE_DIR": str(tmp_path / "ccache")}
    ws = make_fixture_workspace(tmp_path / "ws")
    pkg = ws / "mcu_ws" / "src" / "fx_mark"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(MARK_PACKAGE_XML)
    (pkg / "CMakeLists.txt").write_text(MARK_CMAKE)
    (pkg / "mark.c").write_text("const char *fx_mark(void) { return FX_MARK; }\n")
    prefix = _compiler_folder(tmp_path / "bin", "compiler-one")
    lib = ws / "build" / "cortex-m7-custom" / "libmicroros.a"  # a derived target's folder
    mark = ("--packages-up-to", "fx_mark", "--compiler-prefix", str(prefix), "--ccache")
    _build(ws, env, *mark)
    assert b"compiler-one" in lib.read_bytes()
    _compiler_folder(tmp_path / "bin", "compiler-two")
    second = _build(ws, env, *mark).stderr
    assert "the compiler changed" in second, second
    data = lib.read_bytes()
    assert b"compiler-two" in data and b"compiler-one" not in data


def _ccache_warnings(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("warning:") and "ccache" in line]


def test_ccache_trouble_falls_back_to_compiling_without_it(tmp_path: Path) -> None:
    """Issue 34, item 7: with ccache uninstalled every build failed `[code=126]` (each package's
    CMakeCache.txt held the launcher's path), `--no-ccache` included, until `--rebuild`; an
    unusable CCACHE_DIR (a regular file, a read-only mount) failed the build. Each now compiles
    without ccache, with one warning where ccache was wanted, and the library is the same bytes.
    fx_core alone (UP_TO_CORE): its CMakeCache.txt holds the launcher's path as every package's
    does, and the other packages added only their fixed cost to each of the six builds."""
    need("arm-none-eabi-gcc", "cmake", "ccache")
    ws = make_fixture_workspace(tmp_path / "ws")
    tools = tmp_path / "tools"  # the ccache this build finds, and the user then uninstalls
    tools.mkdir()
    (tools / "ccache").symlink_to(shutil.which("ccache") or "/usr/bin/ccache")
    env = env_without(("ccache",), tmp_path / "shadow")
    env["PATH"] = f"{tools}{os.pathsep}{env['PATH']}"
    env["CCACHE_DIR"] = str(tmp_path / "ccache")
    lib = ws / "build" / "cortex-m7" / "libmicroros.a"

    def build(
        ws: Path, env: dict[str, str], *more: str, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        return build_fixture(ws, *UP_TO_CORE, *more, env=env, check=check)

    assert "ccache: 0 of" in build(ws, env).stderr
    built = lib.read_bytes()
    source = ws / "mcu_ws" / "src" / "fx_core" / "src" / "core.c"

    def edit() -> None:  # a comment at the end: compiled again, the same object
        source.write_text(source.read_text() + "/* edited */\n")

    (tools / "ccache").unlink()  # uninstalled: its path stays in every package's CMakeCache.txt
    for more in (("--no-ccache",), ()):
        edit()
        done = build(ws, env, *more, check=False)
        assert done.returncode == 0, done.stderr
        assert "ccache:" not in done.stderr and not _ccache_warnings(done.stderr)
        assert lib.read_bytes() == built

    (tools / "ccache").symlink_to(shutil.which("ccache", path=os.environ["PATH"]) or "/usr/bin/ccache")
    assert "ccache: " in build(ws, env).stderr
    not_a_folder = tmp_path / "ccache-file"
    not_a_folder.write_text("a file where ccache keeps its cache\n")
    edit()
    done = build(ws, {**env, "CCACHE_DIR": str(not_a_folder)}, check=False)
    assert done.returncode == 0, done.stderr
    (warning,) = _ccache_warnings(done.stderr)
    assert str(not_a_folder) in warning and "compiling without it" in warning, warning
    assert lib.read_bytes() == built
    shown = run_uros("doctor", "-w", str(ws), env={**env, "CCACHE_DIR": str(not_a_folder)}).stdout
    line = next(x for x in shown.splitlines() if x[6:].startswith("ccache"))
    assert line.startswith("warn") and f"{not_a_folder} is not a folder" in line, line

    # a read-only mount (root: a folder's mode does not stop root), in a mount namespace
    read_only = tmp_path / "ccache-ro"
    read_only.mkdir()
    out = tmp_path / "ro"
    argv = [sys.executable, "-m", "uros_build", *fixture_build_args(ws, *UP_TO_CORE)]
    script = (
        f"mount --bind {read_only} {read_only} && mount -o remount,ro,bind {read_only} || exit 99\n"
        f"{shlex.join(argv)} >{out}.out 2>{out}.err; echo $? >{out}.rc\n"
    )
    edit()
    env_ro = {**env, "CCACHE_DIR": str(read_only), "PYTHONPATH": str(REPO)}
    done = subprocess.run(["unshare", "-m", "sh", "-c", script], env=env_ro, capture_output=True, text=True)
    if done.returncode == 99 or not Path(f"{out}.rc").is_file():
        pytest.skip(f"no mount namespace here: {done.stderr}")
    err = Path(f"{out}.err").read_text()
    assert Path(f"{out}.rc").read_text().strip() == "0", err
    (warning,) = _ccache_warnings(err)
    assert str(read_only) in warning, warning
    assert lib.read_bytes() == built
