"""Issue 19, item 1: CMake finds the target compilers' facts once per target, not once per
package, and the library is byte for byte the one a build without that makes: every package's
compile commands and CMake cache are the same, and a C-only package does not see C++ facts (rmw's
configure_rmw_library adds -fvisibility=hidden when CMAKE_CXX_COMPILER_ID is GNU: a seed that
gave every language's facts to every project changed rmw_microxrcedds' symbols)."""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _configure_logs(ws: Path) -> str:
    logs = ws / ".uros" / "targets" / "cortex-m7" / "log"
    return "".join(p.read_text(errors="replace") for p in logs.rglob("stdout_stderr.log"))


# a C-only package that, like rmw, decides a flag by the C++ compiler's id
FX_LANG_CMAKE = """cmake_minimum_required(VERSION 3.16)
project(fx_lang C)
add_library(fx_lang STATIC lang.c)
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  set_target_properties(fx_lang PROPERTIES COMPILE_FLAGS "-fvisibility=hidden")
endif()
install(TARGETS fx_lang ARCHIVE DESTINATION lib)
"""
FX_LANG_XML = """<?xml version="1.0"?>
<package format="3"><name>fx_lang</name><version>0.1.0</version><description>fixture</description>
<maintainer email="dev@example.com">uros tests</maintainer><license>Apache-2.0</license>
<export><build_type>cmake</build_type></export></package>
"""


def _workspace(root: Path) -> Path:
    return _add_lang(make_fixture_workspace(root))


def _add_lang(ws: Path) -> Path:
    lang = ws / "mcu_ws" / "src" / "fx_lang"
    lang.mkdir()
    (lang / "CMakeLists.txt").write_text(FX_LANG_CMAKE)
    (lang / "package.xml").write_text(FX_LANG_XML)
    (lang / "lang.c").write_text("int fx_lang_value(void) { return 7; }\n")
    return ws


def _configured(ws: Path) -> dict[str, str]:
    """Each package's compile commands and CMake cache, the workspace's path taken out (and the
    cache's comments, and the toolchain file's name: the seeded one includes the plain one)."""
    build = ws / ".uros" / "targets" / "cortex-m7" / "build"
    out = {}
    for commands in sorted(build.glob("*/compile_commands.json")):
        pkg = commands.parent
        entries = sorted((e["file"], e["command"]) for e in json.loads(commands.read_text()))
        cache = [
            line for line in (pkg / "CMakeCache.txt").read_text().splitlines()
            if line and not line.startswith(("#", "//")) and not line.startswith("CMAKE_TOOLCHAIN_FILE")
        ]  # fmt: skip
        out[pkg.name] = re.sub(re.escape(str(ws)), "<ws>", json.dumps(entries) + "\n".join(cache))
    return out


def test_compilers_are_found_once_per_target_and_the_bytes_do_not_change(
    tmp_path: Path, m7_build: Path
) -> None:
    need("arm-none-eabi-gcc", "cmake")
    # seeded: the built fixture (its five packages configured in its first build, seeded as every
    # build is) with fx_lang added, configured now; plain: all six configured cold, without the seed
    seeded = _add_lang(m7_build)
    plain = _workspace(tmp_path / "plain")
    args = ["build", "--toolchain", "cortex-m7", "--meta"]
    run_uros(*args, str(seeded / "fixture.meta"), "-w", str(seeded))
    run_uros(
        *args, str(plain / "fixture.meta"), "-w", str(plain), env={**os.environ, "UROS_COMPILER_SEED": "off"}
    )

    target = seeded / ".uros" / "targets" / "cortex-m7"
    seed = (target / "toolchain-seeded.cmake").read_text()
    assert seed.startswith("# Written by uros ") and 'include("' in seed and "CMAKE_MODULE_PATH" in seed
    assert (
        "set(CMAKE_C_COMPILER_ID_RUN 1)"
        in (target / "compiler-seed" / "CMakeDetermineCCompiler.cmake").read_text()
    )
    # every package configured without identifying the compiler; without the seed, each did
    packages = 6
    assert _configure_logs(seeded).count("The C compiler identification is") == 0
    assert _configure_logs(plain).count("The C compiler identification is") == packages
    assert _configured(seeded) == _configured(plain)
    assert "fvisibility" not in _configured(seeded)["fx_lang"]  # no C++ facts in a C project
    lib = Path("build") / "cortex-m7" / "libmicroros.a"
    assert (seeded / lib).read_bytes() == (plain / lib).read_bytes()

    # the static libraries: GNU ar with GCC's LTO plugin named and the index written by qcs (no
    # ranlib), where the compiler has the plugin; every package's archive the same bytes
    plugin = subprocess.run(
        ["arm-none-eabi-gcc", "-print-file-name=liblto_plugin.so"], capture_output=True, text=True, check=True
    ).stdout.strip()
    rules = (target / "build" / "fx_lang" / "CMakeFiles" / "rules.ninja").read_text()
    if os.path.isabs(plugin):
        assert f"--plugin {plugin} qcs" in rules and "ranlib" not in rules
        assert plugin in seed
    plain_rules = (
        plain / ".uros" / "targets" / "cortex-m7" / "build" / "fx_lang" / "CMakeFiles" / "rules.ninja"
    )
    assert "ranlib" in plain_rules.read_text() and "--plugin" not in plain_rules.read_text()
    archives = sorted(p.relative_to(target) for p in (target / "install").rglob("*.a"))
    assert Path("install/lib/libfx_lang.a") in archives
    for archive in archives:
        assert (target / archive).read_bytes() == (plain / ".uros/targets/cortex-m7" / archive).read_bytes()
