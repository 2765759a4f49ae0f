"""`uros doctor` through the real CLI: on the fixture build, without a tool, and on a stale output."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import pytest
from fixture_ws import add_plain_package
from uros_helpers import env_without, run_uros

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


def test_doctor_sees_a_stale_output_and_a_moved_checkout(m7_build: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shutil.copytree(m7_build, ws, symlinks=True)
    time.sleep(0.05)
    (ws / "mcu_ws" / "src" / "fx_core" / "src" / "core.c").write_text(
        "int fx_core_add(int a, int b) { return b + a; }\n"
    )
    proc = run_uros("doctor", "-w", str(ws))
    assert "stale: inputs changed" in proc.stdout and "-> uros build --toolchain cortex-m7" in proc.stdout
    assert _lines(proc.stdout)["target"] == "skip"  # no target named: the toolchain checks are skipped


def test_doctor_sees_an_extra_package_that_changed_in_its_own_folder(m7_build: Path, tmp_path: Path) -> None:
    """Issue 34, item 7: an extra package (uros.yaml's extra_packages, in its own folder outside
    mcu_ws) is copied into mcu_ws/extra_packages by each build; doctor judged the copy and said
    "up to date" after the package changed. It judges the sources as the next build will see them,
    and touches neither the copy nor anything else."""
    ws = tmp_path / "ws"
    shutil.copytree(m7_build, ws, symlinks=True)
    extra = add_plain_package(
        tmp_path / "mine" / "fx_extra", "fx_extra", "int fx_extra(void) { return 1; }\n"
    )
    (ws / "uros.yaml").write_text(f"distro: humble\nextra_packages:\n- {extra}\n")
    run_uros("build", "--toolchain", "cortex-m7", "-w", str(ws), "--meta", str(ws / "fixture.meta"))
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
