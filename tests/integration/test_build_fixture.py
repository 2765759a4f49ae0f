"""The core pipeline end to end: real uros CLI, real colcon, real CMake, real arm-none-eabi-gcc."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import (
    FIXTURE_LIBRARIES,
    FIXTURE_MEMBERS,
    FIXTURE_SKIPPED_PYTHON,
    FIXTURE_SYMBOLS,
    UP_TO_CORE,
    VARIANTS,
    fixture_build_args,
)
from uros_helpers import build_fixture, defined_globals, need, run_uros, run_uros_here, sleeping_build

pytestmark = pytest.mark.integration


def _members(lib: Path) -> list[str]:
    out = subprocess.run(
        ["arm-none-eabi-ar", "t", str(lib)], capture_output=True, text=True, check=True
    ).stdout
    return out.split()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_library_keeps_every_member_and_symbol(m7_build: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    lib = out / "libmicroros.a"
    members = _members(lib)
    assert len(members) == FIXTURE_MEMBERS
    # the two same-named common.c.obj of one archive are both there, under distinct names
    assert sum("common.c" in m for m in members) == 2
    assert sum("util.c" in m for m in members) == 2  # fx_core's and fx_util's util.c
    assert len(set(members)) == len(members)
    assert defined_globals(lib) == Counter(FIXTURE_SYMBOLS)
    # the inputs add up to the same
    install_lib = m7_build / ".uros" / "targets" / "cortex-m7" / "install" / "lib"
    assert sorted(p.name for p in install_lib.glob("*.a")) == list(FIXTURE_LIBRARIES)
    assert sum(len(_members(p)) for p in install_lib.glob("*.a")) == FIXTURE_MEMBERS


def test_include_tree_is_flattened_headers_only(m7_build: Path) -> None:
    inc = m7_build / "build" / "cortex-m7" / "include"
    files = sorted(str(p.relative_to(inc)) for p in inc.rglob("*") if p.is_file())
    assert files == [
        "fx_core/core.h",
        "fx_core/detail/version.h",
        "fx_dup/dup.h",
        "fx_time/time_now.h",
        "fx_util/util.h",
        "fxflat/flat.h",
    ]


def test_build_info(m7_build: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text())
    assert info["target"] == "cortex-m7"
    assert info["flags"]["cpu"] == ["-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard"]
    assert info["flags"]["micro_ros_only"][0] == "-DCLOCK_MONOTONIC=0"
    assert info["compiler"]["path"].endswith("arm-none-eabi-gcc") and info["compiler"]["version"]
    assert info["packages"] == ["fx_core", "fx_dup", "fx_flat", "fx_time", "fx_util"]
    assert info["library"]["members"] == FIXTURE_MEMBERS
    assert info["library"]["defined_global_symbols"] == len(FIXTURE_SYMBOLS)
    assert info["library"]["sha256"] == _sha(out / "libmicroros.a")
    assert info["library"]["size"]["text"] > 0
    assert info["transport"] == "custom"
    assert info["include"]["files"] == 6
    assert info["skipped_python_packages"] == FIXTURE_SKIPPED_PYTHON
    # sorted keys, deterministic
    text = (out / "build-info.json").read_text()
    assert text == json.dumps(json.loads(text), indent=2, sort_keys=True) + "\n"


def test_profile_optimisation_applies_not_O3(m7_build: Path) -> None:
    cc = m7_build / ".uros" / "targets" / "cortex-m7" / "build" / "fx_core" / "compile_commands.json"
    commands = [entry["command"] for entry in json.loads(cc.read_text())]
    assert commands and all(" -Os " in c and "-O3" not in c for c in commands)
    assert all("-DCLOCK_MONOTONIC=0" in c for c in commands)


def test_second_build_reuses_trees_and_is_reproducible(m7_build: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    before = _sha(out / "libmicroros.a")
    cache = m7_build / ".uros" / "targets" / "cortex-m7" / "build" / "fx_core" / "CMakeCache.txt"
    cache_mtime = cache.stat().st_mtime_ns
    # Started through another spelling of the same interpreter (python3 vs python vs python3.X, as
    # `uros` and `python -m uros_build` differ): the CMake arguments must not change, or colcon
    # reconfigures every package (and rosidl regenerates every interface package).
    me = Path(sys.executable)
    names = ("python3", "python", f"python3.{sys.version_info.minor}")
    other = next((me.with_name(n) for n in names if me.with_name(n).is_file() and me.with_name(n) != me), me)
    again = [str(other), "-m", "uros_build", "build", "--toolchain", "cortex-m7", "--workspace", str(m7_build),
             "--meta", str(m7_build / "fixture.meta"), "--verbose"]  # fmt: skip
    proc = subprocess.run(again, capture_output=True, text=True, check=True)
    assert "up to date" in proc.stderr and "+ " not in proc.stderr  # no input changed: no process
    assert cache.stat().st_mtime_ns == cache_mtime  # not reconfigured
    # --rebuild redoes every step from scratch (issue 16: objects the build tools think current
    # may not be), and the library comes out byte-identical: the build is reproducible
    proc = subprocess.run([*again, "--rebuild"], capture_output=True, text=True, check=True)
    assert "--rebuild: building every package afresh" in proc.stderr
    assert cache.stat().st_mtime_ns != cache_mtime  # configured afresh
    assert "no work to do" not in proc.stderr  # ninja compiled
    assert "merging 5 libraries" in proc.stderr
    assert _sha(out / "libmicroros.a") == before


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_a_restored_fixture_build_is_up_to_date(built: Callable[[str], Path], variant: str) -> None:
    """The tests' built fixtures (integration/conftest.py): a copy restored where it was built is a
    build the same command finds up to date, so a test that starts from one starts from a real build."""
    built(variant)
    ws = built(variant)  # the first call may have built it: this one restored it
    proc = build_fixture(ws, *VARIANTS[variant], "--verbose")
    assert "up to date" in proc.stderr and "+ " not in proc.stderr, proc.stderr


def _built(ws: Path) -> tuple[Path, list[str], Path, str]:
    """A built fixture workspace: (the workspace, its build command, the output, the library's sha256)."""
    out = ws / "build" / "cortex-m7"
    return ws, fixture_build_args(ws), out, _sha(out / "libmicroros.a")


def test_failed_build_leaves_previous_output(m7_build: Path) -> None:
    ws, args, out, good = _built(m7_build)
    (ws / "mcu_ws/src/fx_util/src/scale.c").write_text("double fx_util_scale(double x) { return x * ; }\n")
    proc = run_uros(*args, check=False)
    assert proc.returncode == 4
    error_line = next(line for line in proc.stderr.splitlines() if line.startswith("error:"))
    assert "scale.c" in error_line and "colcon build failed" in error_line
    assert "log" in proc.stderr and ".uros/log/" in proc.stderr
    assert _sha(out / "libmicroros.a") == good
    assert not [p for p in (ws / "build").iterdir() if "staging" in p.name]


def test_interrupted_build_leaves_previous_output(m7_build: Path) -> None:
    ws, base, out, good = _built(m7_build)
    proc = sleeping_build(base, f"60.{os.getpid()}")  # inside fx_core's 60 s configure step
    os.kill(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err
    assert _sha(out / "libmicroros.a") == good
    assert not [p for p in (ws / "build").iterdir() if "staging" in p.name]


def test_two_targets_in_one_workspace_and_user_toolchain_file(m7_build: Path, tmp_path: Path) -> None:
    # A user's own toolchain file, used unchanged (here rendered by uros, then treated as foreign).
    tc = tmp_path / "my_board.cmake"
    run_uros("toolchain", "render", "cortex-m7", "--for", "micro-ros", "-o", str(tc))
    m7_lib = m7_build / "build" / "cortex-m7" / "libmicroros.a"
    before = _sha(m7_lib)
    run_uros(
        "build",
        "--toolchain",
        str(tc),
        "--workspace",
        str(m7_build),
        "--meta",
        str(m7_build / "fixture.meta"),
    )
    other = m7_build / "build" / "my_board" / "libmicroros.a"
    assert len(_members(other)) == FIXTURE_MEMBERS
    assert (m7_build / ".uros" / "targets" / "my_board" / "install").is_dir()
    assert _sha(m7_lib) == before  # the first target's output is untouched


def test_bad_input_is_one_line_and_nonzero(m7_build: Path, tmp_path: Path) -> None:
    cases = [
        (
            ["build", "--toolchain", "cortex-m99", "--workspace", str(m7_build)],
            2,
            "unknown target 'cortex-m99'",
        ),
        (["build", "--toolchain", "cortex-m7", "--workspace", str(tmp_path / "nope")], 2, "no such folder"),
        (["build", "--toolchain", "cortex-m7", "--workspace", str(tmp_path)], 2, "not a uros workspace"),
        (
            ["build", "--toolchain", "cortex-m7", "--workspace", str(m7_build), "--meta", "missing.meta"],
            2,
            "--meta missing.meta: no such file",
        ),
        (
            ["build", "--toolchain", "cortex-m7", "--workspace", str(m7_build), "--set", "oops"],
            2,
            "--set 'oops'",
        ),
        (["meta", "write", "--transport", "pigeon"], 2, "unknown transport 'pigeon'"),
    ]
    for args, code, text in cases:
        proc = run_uros_here(*args, check=False)
        assert proc.returncode == code, (args, proc.stderr)
        errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and text in errors[0], (args, proc.stderr)
        assert "Traceback" not in proc.stderr


def test_output_folder_of_the_user_is_not_replaced(m7_build: Path, tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    proc = run_uros_here(
        "build",
        "--toolchain",
        "cortex-m7",
        "--workspace",
        str(m7_build),
        "--output",
        str(mine),
        "--meta",
        str(m7_build / "fixture.meta"),
        check=False,
    )
    assert proc.returncode == 2 and "--force" in proc.stderr
    assert (mine / "notes.txt").read_text() == "keep me"


def test_export_cmake_rewrites_and_copies(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    out = ws / "build" / "cortex-m7"
    (out / "microros.cmake").unlink()
    run_uros("export", "cmake", "--output", str(out))
    assert (out / "microros.cmake").is_file()
    dest = tmp_path / "pkg"
    run_uros("export", "cmake", "--from", str(out), "--output", str(dest))
    assert (dest / "libmicroros.a").is_file() and (dest / "include" / "fx_core" / "core.h").is_file()
    assert "CLOCK_MONOTONIC" not in (dest / "microros.cmake").read_text()


def test_the_install_tree_holds_no_scripts_for_shells_nobody_sources(m7_build: Path) -> None:
    """colcon runs without its bash, zsh and PowerShell extensions: it writes only sh and dsv
    environment files into a cross-compiled install tree (346 fewer files a micro-ROS target; the
    local_setup.bash/.zsh ament_cmake packages install themselves stay, and the fixture has none)."""
    install = m7_build / ".uros" / "targets" / "cortex-m7" / "install"
    names = [p.name for p in install.rglob("*") if p.is_file()]
    assert any(n.endswith(".dsv") for n in names) and any(n.endswith(".sh") for n in names)
    assert not [n for n in names if n.endswith((".bash", ".zsh", ".ps1"))]


@pytest.mark.colcon
def test_an_edit_right_after_a_build_reaches_the_library(built: Callable[[str], Path]) -> None:
    """CMake's install leaves a file whose time is within a second of the installed copy's: an edit
    built right after the last build (a scripted loop) must still reach libmicroros.a."""
    need("arm-none-eabi-nm")
    ws = built("core")  # fx_core built (restored: the first edit follows no build of this test)
    args = fixture_build_args(ws, *UP_TO_CORE)
    core = ws / "mcu_ws" / "src" / "fx_core" / "src" / "core.c"
    # each edit lands within a second of the last build more often than not (one more edit than
    # the five of a cold first build: five follow a build of this test)
    for i in range(6):
        core.write_text(core.read_text() + f"int fx_core_step{i}(void) {{ return {i}; }}\n")
        run_uros(*args)
        nm = subprocess.run(
            ["arm-none-eabi-nm", str(ws / "build" / "cortex-m7" / "libmicroros.a")],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        assert f"fx_core_step{i}" in nm, f"edit {i} is not in the library"
