"""Issue 19, item 1: CMake finds the target compilers' facts once per target, not once per
package, and the library is byte for byte the one a build without that makes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import need
from fixture_ws import make_fixture_workspace
from uros_helpers import run_uros

pytestmark = pytest.mark.integration


def _configure_logs(ws: Path) -> str:
    logs = ws / ".uros" / "targets" / "cortex-m7" / "log"
    return "".join(p.read_text(errors="replace") for p in logs.rglob("stdout_stderr.log"))


def test_compilers_are_found_once_per_target_and_the_bytes_do_not_change(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    seeded = make_fixture_workspace(tmp_path / "seeded")
    plain = make_fixture_workspace(tmp_path / "plain")
    args = ["build", "--toolchain", "cortex-m7", "--meta"]
    run_uros(*args, str(seeded / "fixture.meta"), "-w", str(seeded))
    run_uros(
        *args, str(plain / "fixture.meta"), "-w", str(plain), env={**os.environ, "UROS_COMPILER_SEED": "off"}
    )

    seed = seeded / ".uros" / "targets" / "cortex-m7" / "toolchain-seeded.cmake"
    assert seed.read_text().startswith("# Written by uros ")
    assert 'include("' in seed.read_text() and "set(CMAKE_C_COMPILER_ID_RUN 1)" in seed.read_text()
    # every package configured without identifying the compiler; without the seed, each did
    packages = 5
    assert _configure_logs(seeded).count("The C compiler identification is") == 0
    assert _configure_logs(plain).count("The C compiler identification is") == packages
    lib = Path("build") / "cortex-m7" / "libmicroros.a"
    assert (seeded / lib).read_bytes() == (plain / lib).read_bytes()
