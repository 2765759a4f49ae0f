"""Issue 19, item 4: ccache for what the caches above miss. Compiles go through ccache when it is
installed; another checkout at another path (with a space) hits every compile; and the library is
byte for byte the one built without ccache, __FILE__ of sources and of generated sources included
(ccache's base_dir hands the compiler relative paths: the toolchain's maps name them as the
absolute ones are named)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import need, run_uros

pytestmark = pytest.mark.integration

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
    import subprocess

    strings = subprocess.run(
        ["arm-none-eabi-strings", "-a", str(two / lib)], capture_output=True, text=True
    ).stdout
    assert "./mcu_ws/src/fx_where/where.c" in strings  # the workspace's sources: ./ and their path in it
    assert "gen/where_gen.c" in strings.split()  # generated ones: their path in the build folder
    assert str(tmp_path) not in strings and "../" not in strings
    shutil.rmtree(tmp_path / "ccache")
