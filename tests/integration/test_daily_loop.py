"""The daily loop (issue 9) through the real CLI, colcon, CMake and arm-none-eabi-gcc: build only
what the firmware needs."""

from __future__ import annotations

import json
import re
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import need, once_then_restored, run_uros, run_uros_here

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _members(lib: Path) -> list[str]:
    out = subprocess.run(["arm-none-eabi-ar", "t", str(lib)], capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_for_firmware_builds_what_its_sources_use(built: Callable[[str], Path], tmp_path: Path) -> None:
    # the restored whole-fixture build: fx_flat and fx_time are built in the trees, and still left
    # out of the library of a firmware that does not use them
    ws = built("m7")
    # a test-only dependency of a chosen package is not built (colcon's --packages-up-to would)
    lint = ws / "mcu_ws" / "src" / "fx_lint"
    lint.mkdir()
    (lint / "package.xml").write_text(
        "<package format='3'><name>fx_lint</name><version>0.1.0</version><description>d</description>"
        "<maintainer email='m@example.com'>m</maintainer><license>MIT</license>"
        "<export><build_type>cmake</build_type></export></package>\n"
    )
    (lint / "CMakeLists.txt").write_text(
        'cmake_minimum_required(VERSION 3.16)\nproject(fx_lint NONE)\nmessage(FATAL_ERROR "a test tool")\n'
    )
    xml = ws / "mcu_ws" / "src" / "fx_util" / "package.xml"
    xml.write_text(xml.read_text().replace("<export>", "<test_depend>fx_lint</test_depend>\n  <export>"))
    app = tmp_path / "app"
    (app / "src").mkdir(parents=True)
    # the fixture packages stand in for interface packages: the scanner reads names, not files
    (app / "src" / "main.c").write_text(
        "#include <fx_util/msg/scale.h>\n"
        "// #include <fx_flat/msg/sum.h>  (commented out: not used)\n"
        "void *ts(void) { return ROSIDL_GET_MSG_TYPE_SUPPORT(fx_dup, msg, Common); }\n"
    )
    args = ["build", "--toolchain", "cortex-m7", "--workspace", str(ws), "--meta", str(ws / "fixture.meta")]
    proc = run_uros(*args, "--for-firmware", str(app))
    assert "the firmware uses (1 files read): fx_dup (msg/common); fx_util (msg/scale)" in proc.stderr
    out = ws / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text())
    assert info["packages"] == ["fx_core", "fx_dup", "fx_util"]  # and fx_util's dependency
    members = _members(out / "libmicroros.a")
    assert len(members) == 6 and not [m for m in members if m.startswith(("libfx_flat", "libfx_time"))]
    # --packages names them directly; a typo is one line with the closest name
    proc = run_uros(*args, "--packages", "fx_flat")
    assert json.loads((out / "build-info.json").read_text())["packages"] == [
        "fx_core", "fx_dup", "fx_flat", "fx_util"
    ]  # fmt: skip
    proc = run_uros_here(*args, "--packages", "fx_flatt", check=False)  # refused before any process
    assert proc.returncode == 2 and "--packages fx_flatt: no package fx_flatt" in proc.stderr
    assert "closest: fx_flat" in proc.stderr


# --- nothing changed, nothing done; any single input changed, its steps redone -----------------


@pytest.fixture(scope="module")
def _board_built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The fixture workspace with a profile of the user's (target 'board') in <root>/board, built
    once, kept as <root>/snapshot: the root. A copy restored from the snapshot is checked once to
    be up to date: every case's baseline is that same copy."""
    need("arm-none-eabi-gcc", "cmake")
    import shutil

    import yaml
    from uros_helpers import REPO

    root = tmp_path_factory.mktemp("daily")
    ws = make_fixture_workspace(root / "board" / "ws")
    data = yaml.safe_load((REPO / "toolchains" / "cortex-m7.yaml").read_text())
    data.update(name="board")
    (ws.parent / "board.yaml").write_text(yaml.safe_dump(data))
    run_uros(*_board_args(ws))
    shutil.copytree(root / "board", root / "snapshot", symlinks=True)
    restored = once_then_restored(root / "snapshot", root / "board") / "ws"
    assert "up to date" in run_uros(*_board_args(restored)).stderr  # each case's baseline
    return root


@pytest.fixture
def board_ws(_board_built: Path) -> Path:
    """The built 'board' workspace, a fresh copy for this test restored where it was built
    (copytree keeps every mtime: the next build of the same command is up to date)."""
    return once_then_restored(_board_built / "snapshot", _board_built / "board") / "ws"


def _board_args(ws: Path, *more: str) -> list[str]:
    profile = ws.parent / "board.yaml"
    return [
        "build",
        "--profile",
        str(profile),
        "--workspace",
        str(ws),
        "--meta",
        str(ws / "fixture.meta"),
        *more,
    ]


def _edit(path: Path, old: str, new: str) -> None:
    path.write_text(path.read_text().replace(old, new) if old else path.read_text() + new)


# case -> (change the input, extra arguments, undo it, the merge runs (True) or the library is reused)
def _source(ws: Path) -> None:
    _edit(ws / "mcu_ws/src/fx_util/src/scale.c", "1.5", "2.5")


def _unsource(ws: Path) -> None:
    _edit(ws / "mcu_ws/src/fx_util/src/scale.c", "2.5", "1.5")


def _header(ws: Path) -> None:
    _edit(ws / "mcu_ws/src/fx_core/include/fx_core/detail/version.h", "", "/* no object changes */\n")


def _unheader(ws: Path) -> None:
    _edit(ws / "mcu_ws/src/fx_core/include/fx_core/detail/version.h", "/* no object changes */\n", "")


def _flags(ws: Path, change: str) -> None:
    import yaml

    path = ws.parent / "board.yaml"
    data = yaml.safe_load(path.read_text())
    flags = [f for f in data["c_flags"] if f != "-DFX_BOARD=2"]
    data["c_flags"] = [*flags, "-DFX_BOARD=2"] if change == "add" else flags
    path.write_text(yaml.safe_dump(data))


def _profile(ws: Path) -> None:
    _flags(ws, "add")


def _unprofile(ws: Path) -> None:
    _flags(ws, "remove")


def _remove(ws: Path) -> None:
    (ws / "mcu_ws/src/fx_flat").rename(ws / "fx_flat.away")


def _restore(ws: Path) -> None:
    (ws / "fx_flat.away").rename(ws / "mcu_ws/src/fx_flat")


def _tamper(ws: Path) -> None:
    (ws / "build/board/include/fx_core/core.h").write_text("/* edited by hand */\n")


def _nothing(ws: Path) -> None:
    pass


def _compiler(ws: Path) -> None:
    import shutil

    shim = ws.parent / "shim"
    shim.mkdir(exist_ok=True)
    for tool in ("gcc", "g++", "ar", "ranlib", "nm", "size", "objcopy"):
        link = shim / f"arm-none-eabi-{tool}"
        if not link.exists():
            link.symlink_to(shutil.which(f"arm-none-eabi-{tool}") or tool)


CASES = {
    "a source file": (_source, (), _unsource, True),
    "a header no object includes": (_header, (), _unheader, False),
    "colcon.meta (--set)": (_nothing, ("--set", "fx_core.FX_UNUSED=1"), _nothing, False),
    "the profile's flags (toolchain file)": (_profile, (), _unprofile, True),
    "the package set (--packages-up-to)": (_nothing, ("--packages-up-to", "fx_util"), _nothing, True),
    "a package removed": (_remove, (), _restore, True),
    "the output edited by hand": (_tamper, (), _nothing, False),
    "the output folder (--output)": (_nothing, ("--output", "OUT"), _nothing, True),
    # a compiler elsewhere may be another compiler: every object is made again (issue 16, item 2)
    "the compiler (another path)": (_compiler, (), _nothing, True),
}


@pytest.mark.parametrize("case", list(CASES))
def test_each_input_change_redoes_its_steps_and_nothing_else(board_ws: Path, case: str) -> None:
    import os

    change, more, undo, merges = CASES[case]
    ws = board_ws
    env = None
    if case.startswith("the compiler"):
        env = {**os.environ, "PATH": f"{ws.parent / 'shim'}{os.pathsep}{os.environ['PATH']}"}
    # an output inside a plain workspace: its files are not sources (or nothing would be up to date)
    more = tuple(str(ws / "fw-out") if m == "OUT" else m for m in more)
    base = _board_args(ws)  # the restored build, up to date (checked once in _board_built)
    change(ws)
    try:
        proc = run_uros(*base, *more, env=env)
        assert "up to date" not in proc.stderr and "colcon built" in proc.stderr, proc.stderr
        if merges:
            assert "merging" in proc.stderr and "no archive changed" not in proc.stderr, proc.stderr
        else:
            assert "no archive changed: reusing libmicroros.a" in proc.stderr and "merging" not in proc.stderr
        again = run_uros(*base, *more, env=env)
        assert "up to date" in again.stderr and "+ " not in again.stderr, again.stderr
    finally:
        undo(ws)
    out = ws / "fw-out" if "--output" in more else ws / "build" / "board"
    info = json.loads((out / "build-info.json").read_text())
    timings = json.loads((ws / ".uros/targets/board/timings.json").read_text())
    assert set(timings["package_seconds"]) == set(info["packages"]) and "package_seconds" not in info
    if case == "a header no object includes":  # the reused library, the new header
        assert "no object changes" in (out / "include/fx_core/detail/version.h").read_text()
    if case == "the output edited by hand":
        assert "edited by hand" not in (out / "include/fx_core/core.h").read_text()


def test_progress_is_one_line_per_package_and_the_slowest_at_the_end(board_ws: Path) -> None:
    # build-info.json says what was built, the same for the same inputs (round 3, issue 34, 7:
    # package_seconds made it differ at every build): the restored first build's, then --rebuild's;
    # the times are the target's timings.json
    info = board_ws / "build" / "board" / "build-info.json"
    first = info.read_bytes()
    proc = run_uros(*_board_args(board_ws, "--rebuild"))
    lines = [line for line in proc.stderr.splitlines() if line.startswith("[")]
    assert len(lines) == 5 and all(" built fx_" in line for line in lines) and lines[-1].startswith("[5/5]")
    assert all(re.match(r"\[\d/5\] ", line) for line in lines), lines  # the total known from the start
    assert "colcon built 5 packages in" in proc.stderr and "slowest: " in proc.stderr
    assert "+ " not in proc.stderr.split("==> colcon build")[1].split("colcon built")[0]  # no argv wall
    assert info.read_bytes() == first
    timings = json.loads((board_ws / ".uros/targets/board/timings.json").read_text())
    assert sorted(timings["package_seconds"]) == sorted(json.loads(first)["packages"])
