"""`uros toolchain render` as a user runs it, and the names uros suggests for typos."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from uros_helpers import need, run_uros, run_uros_here

pytestmark = pytest.mark.integration


def test_micro_ros_toolchain_to_stdout_keeps_the_clock_header(tmp_path: Path) -> None:
    proc = run_uros("toolchain", "render", "cortex-m7", "--for", "micro-ros", cwd=tmp_path)
    header = tmp_path / "uros_clock_gettime.h"
    assert f"-include {header}" in proc.stdout  # as in the -o file
    assert "int clock_gettime(" in header.read_text()
    assert f"wrote {header}" in proc.stderr
    out = tmp_path / "tc" / "micro-ros.cmake"
    run_uros("toolchain", "render", "cortex-m7", "--for", "micro-ros", "-o", str(out), cwd=tmp_path)
    assert f"-include {out.parent / 'uros_clock_gettime.h'}" in out.read_text()


def test_firmware_toolchain_keeps_the_users_debug_flags(tmp_path: Path) -> None:
    """Release builds get the profile's -Os (CMake would append -O3 after it); a Debug build keeps
    what the user set for Debug."""
    need("arm-none-eabi-gcc", "cmake", "ninja")
    toolchain = tmp_path / "toolchain.cmake"
    run_uros("toolchain", "render", "cortex-m7", "-o", str(toolchain))
    src = tmp_path / "src"
    src.mkdir()
    (src / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(fw C)\nadd_library(fw STATIC fw.c)\n"
    )
    (src / "fw.c").write_text("int fw(void) { return 1; }\n")

    def command(build_type: str, *extra: str) -> str:
        build = tmp_path / f"build-{build_type}"
        subprocess.run(
            ["cmake", "-S", str(src), "-B", str(build), "-G", "Ninja", f"-DCMAKE_TOOLCHAIN_FILE={toolchain}",
             f"-DCMAKE_BUILD_TYPE={build_type}", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", *extra],
            check=True, capture_output=True, text=True,
        )  # fmt: skip
        entries = json.loads((build / "compile_commands.json").read_text())
        return str(entries[0]["command"])

    debug = command("Debug", "-DCMAKE_C_FLAGS_DEBUG=-Og -g3")
    assert "-Og -g3" in debug and "-Os" not in debug
    release = command("Release")
    assert release.split().count("-Os") == 1 and "-O3" not in release


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["toolchain", "render", "cortex-m9"], "TARGET: unknown target 'cortex-m9' (did you mean cortex-m7"),
        (["meta", "write", "--transport", "udpp"], "unknown transport 'udpp' (did you mean udp?)"),
        (["meta", "write", "--preset", "humbel"], "unknown preset 'humbel' (did you mean humble?)"),
        (["create-firmware", "--distro", "humbel"], "unknown distro 'humbel' (did you mean humble?)"),
        (["biuld"], "No such command 'biuld' (did you mean build?)"),
        (["toolchain", "rendr"], "No such command 'rendr' (did you mean render?)"),
    ],
)
def test_typos_get_the_closest_names(tmp_path: Path, args: list[str], expected: str) -> None:
    proc = run_uros_here(*args, cwd=tmp_path, check=False)
    assert proc.returncode == 2 and expected in proc.stderr, proc.stderr


def test_render_of_an_unknown_target_names_only_what_render_takes(tmp_path: Path) -> None:
    proc = run_uros("toolchain", "render", "cortex-m9", cwd=tmp_path, check=False)
    assert "--toolchain" not in proc.stderr and ".cmake" not in proc.stderr, proc.stderr
    assert "profile (a path ending in .yaml)" in proc.stderr


def test_meta_options_and_set_checked_against_them(tmp_path: Path) -> None:
    rows = json.loads(run_uros("meta", "options", "--json", cwd=tmp_path).stdout)
    nodes = next(r for r in rows if r["option"] == "RMW_UXRCE_MAX_NODES")
    assert nodes["default"] == "4" and nodes["preset"] == "1" and "RAM" in nodes["cost"]
    header = run_uros("meta", "options", cwd=tmp_path).stdout.splitlines()[0].split()
    assert header == ["PACKAGE", "OPTION", "DEFAULT", "PRESET", "COST"]
    typo = run_uros("meta", "write", "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_NODE=2", cwd=tmp_path)
    assert "did you mean RMW_UXRCE_MAX_NODES" in typo.stderr and "-DRMW_UXRCE_MAX_NODE=2" in typo.stdout
    wrong = run_uros(
        "meta", "write", "--set", "rmw_microxrcedds.RMW_UXRCE_STREAM_HISTORY=3", cwd=tmp_path, check=False
    )
    assert wrong.returncode == 2 and "must be a power of two" in wrong.stderr
