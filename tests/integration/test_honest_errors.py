"""Internal errors and hints that lie (issue 16, items 10 and 11): each case ends in one line that
names the file or flag and a fix that works, with the exit code of its kind, never a traceback.
Real CLI, git, colcon, CMake and arm-none-eabi-gcc."""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from uros_helpers import default_sigint, need, run_uros, run_uros_here, upstream_mirror

pytestmark = pytest.mark.integration


def _error_line(stderr: str) -> str:
    lines = [x for x in stderr.splitlines() if x.startswith("error:")]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr, stderr
    return lines[0]


@pytest.mark.parametrize("missing", ["libmicroros.a", "include"])
def test_export_from_an_incomplete_output(m7_snapshot: Path, tmp_path: Path, missing: str) -> None:
    out = tmp_path / "out"
    shutil.copytree(m7_snapshot / "build" / "cortex-m7", out)  # the built output, copied from the snapshot
    victim = out / missing
    shutil.rmtree(victim) if victim.is_dir() else victim.unlink()
    proc = run_uros_here(
        "export", "cmake", "--from", str(out), "--output", str(tmp_path / "pkg"), check=False
    )
    assert proc.returncode == 2
    line = _error_line(proc.stderr)
    assert f"--from {out}: its build-info.json names {missing}" in line
    assert "uros build --toolchain cortex-m7" in proc.stderr and not (tmp_path / "pkg").exists()


def test_export_never_suggests_a_force_it_lacks(m7_snapshot: Path, tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine\n")
    built = m7_snapshot / "build" / "cortex-m7"  # refused before anything is written: the snapshot itself
    proc = run_uros_here("export", "cmake", "--from", str(built), "--output", str(mine), check=False)
    assert proc.returncode == 2 and "holds files uros did not write" in _error_line(proc.stderr)
    assert "--force" not in proc.stderr
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


def test_a_lock_that_is_a_folder(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    from fixture_ws import make_fixture_workspace

    ws = make_fixture_workspace(tmp_path / "ws")
    (ws / ".uros/targets/cortex-m7/.lock").mkdir(parents=True)
    proc = run_uros("build", "--toolchain", "cortex-m7", "-w", str(ws), check=False)
    assert proc.returncode == 2
    assert ".uros/targets/cortex-m7/.lock: is a folder" in _error_line(proc.stderr)
    assert (ws / ".uros/targets/cortex-m7/.lock").is_dir()
    # the run log says what uros said, the final error included, between the tools' output
    log = (ws / ".uros" / "log" / "latest.log").read_text()
    assert "uros: ==> uros build: target cortex-m7" in log
    assert "uros: error: " in log and ".lock: is a folder" in log.split("uros: error: ")[1]


@pytest.mark.serial
def test_ctrl_c_while_starting_up_is_no_traceback() -> None:
    for delay in (0.02, 0.05, 0.1, 0.15, 0.25):
        proc = subprocess.Popen(
            [sys.executable, "-m", "uros_build", "targets"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=default_sigint,
        )
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        # Python's own start-up (runpy importing the package, before any uros code runs) can still
        # be interrupted with Python's traceback; no KeyboardInterrupt may escape uros's code
        assert "Traceback" not in err or "uros_build" not in err, (delay, err)
        # ("Could not import runpy module", exit 1: the interrupt hit Python's own imports)
        pythons_own = "KeyboardInterrupt" in err and "uros_build" not in err
        assert proc.returncode in (0, 130, -signal.SIGINT) or pythons_own, (delay, proc.returncode, err)


@pytest.mark.serial
def test_a_killed_create_firmware_is_finished_by_force(upstream_to_read: Path, tmp_path: Path) -> None:
    upstream = upstream_to_read  # only cloned from: the worker's fake upstream itself, not a copy
    fw = tmp_path / "fw"
    args = [
        sys.executable,
        "-m",
        "uros_build",
        "create-firmware",
        "-w",
        str(fw),
        "--no-dev-build",
        "--git-jobs",
        "1",
    ]
    for delay in (0.6, 0.9, 1.2, 0.4):
        shutil.rmtree(fw, ignore_errors=True)
        proc = subprocess.Popen([*args, *upstream_mirror(upstream)], stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        proc.kill()  # SIGKILL: nothing of uros's cleanup runs
        proc.communicate()
        if fw.exists() and not (fw / "uros.lock").exists() and any(fw.rglob("README")):
            break  # killed while cloning
    else:
        pytest.skip("could not stop create-firmware while it was cloning")
    rerun = run_uros(*args[3:], *upstream_mirror(upstream), check=False)
    assert rerun.returncode == 2 and "stopped before it finished" in _error_line(rerun.stderr)
    assert "--force" in rerun.stderr
    run_uros(*args[3:], *upstream_mirror(upstream), "--force")
    assert len(json.loads((fw / "uros.lock").read_text())["repositories"]) == 32
    assert not (fw / ".uros/create-firmware.pending").exists()


def test_a_failed_clone_names_a_log_that_exists(upstream_to_read: Path, tmp_path: Path) -> None:
    upstream = upstream_to_read  # only cloned from: the worker's fake upstream itself, not a copy
    fw = tmp_path / "fw"
    proc = run_uros(
        "create-firmware", "-w", str(fw), "--no-dev-build", *upstream_mirror(upstream),
        "--mirror-override", "uros/rclc=@no-such-branch", check=False,
    )  # fmt: skip
    assert proc.returncode == 4 and not fw.exists()
    logs = re.findall(r"log: (\S+\.log)", proc.stderr)
    assert logs and all(Path(log).is_file() for log in logs), proc.stderr


@pytest.mark.parametrize("case", ["another distro", "no repositories"])
def test_a_lock_file_that_does_not_pin_this_distro(upstream_to_read: Path, tmp_path: Path, case: str) -> None:
    upstream = upstream_to_read  # refused before anything reads it: the worker's fake upstream itself
    lock = tmp_path / "other.lock"
    if case == "another distro":
        lock.write_text(json.dumps({"distro": "iron", "repositories": {}}))
        expected = f"--lock-file {lock}: locks micro-ROS iron, not humble"
    else:
        lock.write_text(json.dumps({"distro": "humble", "repositories": {}}))
        expected = f"--lock-file {lock}: has no commit for 32 of the 32 repositories of humble"
    fw = tmp_path / "fw"
    proc = run_uros_here(
        "create-firmware", "-w", str(fw), "--no-dev-build", "--lock-file", str(lock), *upstream_mirror(upstream),
        check=False,
    )  # fmt: skip
    assert proc.returncode == 2 and expected in _error_line(proc.stderr)
    assert not fw.exists()
