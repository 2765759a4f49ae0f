"""The daily loop (issue 9) through the real CLI, colcon, CMake and arm-none-eabi-gcc: build only
what the firmware needs."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from conftest import need
from fixture_ws import make_fixture_workspace
from uros_helpers import run_uros

pytestmark = pytest.mark.integration


def _members(lib: Path) -> list[str]:
    out = subprocess.run(["arm-none-eabi-ar", "t", str(lib)], capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_for_firmware_builds_what_its_sources_use(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
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
    proc = run_uros(*args, "--packages", "fx_flatt", check=False)
    assert proc.returncode == 2 and "--packages fx_flatt: no package fx_flatt" in proc.stderr
    assert "closest: fx_flat" in proc.stderr
