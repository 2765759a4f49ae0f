"""`uros doctor` through the real CLI: on the fixture build, without a tool, and on a stale output."""

from __future__ import annotations

import json
import shutil
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE, add_plain_package, make_fixture_workspace
from uros_helpers import env_without, run_uros

from uros_build.sources.wsfiles import Lock, LockedRepo

pytestmark = pytest.mark.integration


def _lines(text: str) -> dict[str, str]:
    """check name -> status, from doctor's table."""
    out = {}
    for line in text.splitlines():
        status, rest = line[:4].strip(), line[6:]
        out[rest.split("  ")[0].strip()] = status
    return out


def test_doctor_on_a_built_workspace(m7_build: Path) -> None:
    proc = run_uros("doctor", "--toolchain", "cortex-m7", "-w", str(m7_build))
    lines = _lines(proc.stdout)
    for name in ("cmake", "git", "colcon", "empy", "disk", "cortex-m7 compiler", "cortex-m7 C library"):
        assert lines[name] == "ok", proc.stdout
    assert lines["cortex-m7 C++ headers"] == "ok" and lines["target cortex-m7"] == "ok", proc.stdout
    data = json.loads(run_uros("doctor", "--toolchain", "cortex-m7", "-w", str(m7_build), "--json").stdout)
    assert data["ok"] is True and {c["name"] for c in data["checks"]} >= {"cmake", "target cortex-m7"}


def test_doctor_fails_when_a_build_would(m7_build: Path, tmp_path: Path) -> None:
    env = env_without(("cmake", "arm-none-eabi-gcc"), tmp_path / "shadow")
    proc = run_uros("doctor", "--toolchain", "cortex-m7", "-w", str(m7_build), env=env, check=False)
    assert proc.returncode == 5, proc.stdout + proc.stderr
    cmake = next(line for line in proc.stdout.splitlines() if " cmake " in f" {line} ")
    assert cmake.startswith("FAIL") and "-> apt-get install cmake" in cmake
    compiler = next(line for line in proc.stdout.splitlines() if "cortex-m7 compiler" in line)
    assert compiler.startswith("FAIL") and "gcc-arm-none-eabi" in compiler
    assert "a build would fail" in proc.stderr


def test_doctor_sees_a_stale_output_and_a_moved_checkout(m7_snapshot: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shutil.copytree(m7_snapshot, ws, symlinks=True)  # the built fixture moved (copied from its snapshot)
    time.sleep(0.05)
    (ws / "mcu_ws" / "src" / "fx_core" / "src" / "core.c").write_text(
        "int fx_core_add(int a, int b) { return b + a; }\n"
    )
    proc = run_uros("doctor", "-w", str(ws))
    assert "stale: inputs changed" in proc.stdout and "-> uros build --toolchain cortex-m7" in proc.stdout
    assert _lines(proc.stdout)["target"] == "skip"  # no target named: the toolchain checks are skipped


def test_doctor_sees_an_extra_package_that_changed_in_its_own_folder(
    built: Callable[[str], Path], tmp_path: Path
) -> None:
    """Issue 34, item 7: an extra package (uros.yaml's extra_packages, in its own folder outside
    mcu_ws) is copied into mcu_ws/extra_packages by each build; doctor judged the copy and said
    "up to date" after the package changed. It judges the sources as the next build will see them,
    and touches neither the copy nor anything else. The fx_core build (restored), built again with
    the extra package: the package count is not the subject."""
    ws = built("core")
    extra = add_plain_package(
        tmp_path / "mine" / "fx_extra", "fx_extra", "int fx_extra(void) { return 1; }\n"
    )
    (ws / "uros.yaml").write_text(f"distro: humble\nextra_packages:\n- {extra}\n")
    run_uros(
        "build", "--toolchain", "cortex-m7", "-w", str(ws), "--meta", str(ws / "fixture.meta"), *UP_TO_CORE
    )
    assert _lines(run_uros("doctor", "-w", str(ws)).stdout)["target cortex-m7"] == "ok"

    (extra / "fx_extra.c").write_text("int fx_extra(void) { return 2; }\n")
    copy = ws / "mcu_ws" / "extra_packages" / "fx_extra" / "fx_extra.c"
    before = copy.stat()
    proc = run_uros("doctor", "-w", str(ws))
    line = next(x for x in proc.stdout.splitlines() if "target cortex-m7" in x)
    assert line.startswith("warn") and "stale: inputs changed since the last build: sources" in line, line
    assert f"extra package fx_extra ({extra})" in line, line
    assert (
        copy.read_text() == "int fx_extra(void) { return 1; }\n"
        and copy.stat().st_mtime_ns == before.st_mtime_ns
    )
    (extra / "fx_extra.c").write_text("int fx_extra(void) { return 1; }\n")  # as built: up to date again
    assert _lines(run_uros("doctor", "-w", str(ws)).stdout)["target cortex-m7"] == "ok"


def test_a_clone_off_its_locked_commit_gets_a_hint_that_works(tmp_path: Path) -> None:
    """Round 3 (issue 34, 7): the hint was `uros create-firmware --locked --force`, which refuses
    such a clone (it may hold the user's work); the git command it names now puts it back."""
    ws = make_fixture_workspace(tmp_path / "ws")
    clone = ws / "mcu_ws" / "uros" / "rclc"
    clone.mkdir(parents=True)

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-C", str(clone), "-c", "user.name=t", "-c", "user.email=t@t", *args],
            check=True, capture_output=True, text=True,
        ).stdout.strip()  # fmt: skip

    git("init", "-q")
    git("commit", "-q", "--allow-empty", "-m", "locked")
    locked = git("rev-parse", "HEAD")
    git("commit", "-q", "--allow-empty", "-m", "the user's")
    lock = Lock("humble", {"mcu_ws/uros/rclc": LockedRepo("u", "humble", "s", locked)})
    (ws / "uros.lock").write_text(lock.to_json(), encoding="utf-8")
    proc = run_uros("doctor", "-w", str(ws))
    line = next(line for line in proc.stdout.splitlines() if " checkouts " in f" {line} ")
    assert line.startswith("warn") and "not at the locked commit: mcu_ws/uros/rclc" in line, proc.stdout
    assert f"-> in the workspace, git -C mcu_ws/uros/rclc checkout {locked} puts it back" in line, line
    assert "--force" not in line
    subprocess.run(f"git -C mcu_ws/uros/rclc checkout -q {locked}", shell=True, cwd=ws, check=True)
    again = run_uros("doctor", "-w", str(ws))
    assert "1 repositories at their locked commits" in again.stdout, again.stdout
