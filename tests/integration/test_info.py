"""`uros info` through the real CLI on the fixture build (and, with a uros.lock, in
test_create_firmware's end-to-end test)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from uros_helpers import run_uros, run_uros_here

pytestmark = pytest.mark.integration


def test_info_on_the_fixture_build(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    out = ws / "build" / "cortex-m7"
    # an interface package's headers, as rosidl generates them into the include tree
    msg = out / "include" / "fx_msgs" / "msg"
    (msg / "detail").mkdir(parents=True)
    (msg / "u_int8.h").write_text('#include "fx_msgs/msg/detail/u_int8__struct.h"\n')
    (msg / "detail" / "u_int8__struct.h").write_text(
        "typedef struct fx_msgs__msg__UInt8 { int data; } fx_msgs__msg__UInt8;\n"
    )

    data = json.loads(run_uros("info", "--json", "--toolchain", "cortex-m7", "-w", str(ws)).stdout)
    built = json.loads((out / "build-info.json").read_text())
    assert data["types"] == ["fx_msgs/msg/UInt8"]
    assert [p["name"] for p in data["packages"]] == built["packages"]
    assert data["library"]["size"] == built["library"]["size"] and data["transport"] == "custom"
    assert data["options"]["rmw_microxrcedds"]["RMW_UXRCE_MAX_NODES"] == "1"  # the target's colcon.meta
    assert data["options"]["fx_time"] == {"FX_TIME_ENABLE": "ON"}

    text = run_uros("info", str(out)).stdout  # OUTPUT named directly, as text
    assert "rmw_microxrcedds: " in text and "RMW_UXRCE_MAX_NODES=1," in text and "  fx_msgs/msg/UInt8" in text
    assert "types (1):" in text and "packages (5):" in text

    none = run_uros_here("info", str(ws / "mcu_ws"), check=False)  # refused before any process starts
    assert none.returncode == 2 and "not a uros build output" in none.stderr


def test_info_says_what_the_output_was_built_with(m7_build: Path, tmp_path: Path) -> None:
    """Issue 16, item 6: a build into another --output, or a failed one, with other options
    leaves this output's info as it was built (it used to read the target's trees)."""
    ws = m7_build
    base = ["build", "--toolchain", "cortex-m7", "--workspace", str(ws)]
    out = ws / "build" / "cortex-m7"
    meta = ["--meta", str(ws / "fixture.meta")]
    eight = [*meta, "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=8"]
    run_uros(*base, *eight, "--output", str(tmp_path / "other"))
    (ws / "mcu_ws/src/fx_util/src/scale.c").write_text("double fx_util_scale(double x) { return x * ; }\n")
    assert run_uros(*base, *eight, check=False).returncode == 4
    data = json.loads(run_uros("info", "--json", str(out)).stdout)
    assert data["options"]["rmw_microxrcedds"]["RMW_UXRCE_MAX_NODES"] == "1"
    other = json.loads(run_uros("info", "--json", str(tmp_path / "other")).stdout)
    assert other["options"]["rmw_microxrcedds"]["RMW_UXRCE_MAX_NODES"] == "8"
    # the same, with the workspace gone: everything comes from the output itself
    shutil.rmtree(ws / ".uros")
    assert json.loads(run_uros("info", "--json", str(out)).stdout) == data


def test_the_build_key_is_the_same_for_the_same_build_anywhere(m7_snapshot: Path, tmp_path: Path) -> None:
    """Issue 19, item 2: the key is made of content alone: a copy of the workspace elsewhere (another
    path, other inodes and times) builds with the same key; another colcon.meta with another. (The
    fixture build is only read and copied from: its snapshot itself, no restored copy.)"""
    m7_build = m7_snapshot
    here = json.loads((m7_build / "build" / "cortex-m7" / "build-info.json").read_text())["build_key"]
    assert len(here) == 64
    elsewhere = tmp_path / "somewhere else"
    shutil.copytree(m7_build / "mcu_ws", elsewhere / "mcu_ws")
    shutil.copy(m7_build / "fixture.meta", elsewhere / "fixture.meta")
    base = ["build", "--toolchain", "cortex-m7", "--workspace", str(elsewhere)]
    run_uros(*base, "--meta", str(elsewhere / "fixture.meta"))
    out = elsewhere / "build" / "cortex-m7"
    assert json.loads((out / "build-info.json").read_text())["build_key"] == here
    assert f"build key  {here}" in run_uros("info", str(out)).stdout
    run_uros(
        *base, "--meta", str(elsewhere / "fixture.meta"), "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2"
    )
    assert json.loads((out / "build-info.json").read_text())["build_key"] != here


DEAD = 2**22 + 1000  # above the largest pid_max Linux allows: a run that is gone


def test_info_after_a_killed_swap_reads_the_output_the_next_build_would_keep(
    m7_build: Path, tmp_path: Path
) -> None:
    """Issue 34, item 7: a swap cut by SIGKILL between its two renames (the journal in place) left
    the output in `.cortex-m7.old-PID`; `uros info` then said there was no output. It finishes or
    undoes the swap as the next build would (here: undoes it, the new output never got in place)."""
    ws = m7_build
    build = ws / "build"
    out = build / "cortex-m7"
    old, staging = build / f".cortex-m7.old-{DEAD}", build / f".cortex-m7.staging-{DEAD}"
    for given in (True, False):  # OUTPUT named, or found through the workspace
        out.rename(old)
        staging.mkdir()
        (staging / "libmicroros.a").write_text("the new output, never put in place")
        moves = [{"dest": "cortex-m7", "new": staging.name, "old": old.name}]
        (build / ".cortex-m7.swap").write_text(json.dumps({"pid": DEAD, "moves": moves, "cleanup": []}))
        args = (
            ("info", str(out), "--json")
            if given
            else ("info", "-w", str(ws), "--toolchain", "cortex-m7", "--json")
        )
        proc = run_uros(*args, check=False)
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["target"] == "cortex-m7"
        assert "rolled back the swap of a uros run" in proc.stderr
        assert sorted(p.name for p in build.iterdir()) == ["COLCON_IGNORE", "cortex-m7"]
