"""A Spanish-speaking user's locale (issue 8, item 8): readelf prints "Máquina:", git "Rama remota",
yet every parsed output is read in the C locale and every error line uros picks is in English."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from uros_helpers import run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _error_line(stderr: str) -> str:
    return next(line for line in stderr.splitlines() if line.startswith("error:"))


def test_check_reads_readelf_in_the_c_locale(m7_snapshot: Path, spanish_env: dict[str, str]) -> None:
    lib = m7_snapshot / "build" / "cortex-m7" / "libmicroros.a"  # read in place: check writes nothing
    proc = run_uros("check", str(lib), "--toolchain", "cortex-m7", env=spanish_env)
    assert "all 8 objects match cortex-m7" in proc.stderr
    proc = run_uros("check", str(lib), "--toolchain", "cortex-m4f", check=False, env=spanish_env)
    assert proc.returncode == 5
    assert "Tag_FP_arch is FPv5/FP-D16 for ARMv8, cortex-m4f expects VFPv4-D16" in _error_line(proc.stderr)


def test_build_in_a_spanish_locale(m7_build: Path, spanish_env: dict[str, str]) -> None:
    # the built fixture (restored, configured and compiled in the C locale) without its output: the
    # build in Spanish runs colcon again and makes the library, reads ar, nm, readelf and size and
    # checks every object; the failed compile below is gcc's in Spanish
    ws = m7_build
    shutil.rmtree(ws / "build" / "cortex-m7")
    args = ["build", "--toolchain", "cortex-m7", "--workspace", str(ws), "--meta", str(ws / "fixture.meta")]
    run_uros(*args, env=spanish_env)
    info = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())
    assert info["abi_check"]["result"] == "pass" and info["library"]["size"]["text"] > 0
    assert info["library"]["members"] == 8
    # a failed compile: the error line is the compiler's, in English
    (ws / "mcu_ws/src/fx_util/src/scale.c").write_text("double fx_util_scale(double x) { return x * ; }\n")
    proc = run_uros(*args, check=False, env=spanish_env)
    assert proc.returncode == 4
    line = _error_line(proc.stderr)
    assert "scale.c:1:" in line and "error: expected expression" in line
