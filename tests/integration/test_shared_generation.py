"""Issue 19, item 1, on real micro-ROS Humble: a second target takes the interface code the first
generated (rosidl's generators do not run again) and its configures' Python answers, and its library
is byte for byte the one a workspace makes that never built another target and shares nothing
(UROS_GEN_CACHE=off, UROS_COMPILER_SEED=off, UROS_HOST_STAGE=off: every generator, configure call
and compiler check runs as CMake asks, every package is configured for the target). The cache is the user's: another checkout of the same sources at another
path takes it all too. Needs UROS_MIRROR (see test_real_sources.py);
about six minutes on 2 cores (three builds of std_msgs' closure)."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest
from uros_helpers import humble_mirror_args, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.realsources]

MIRROR = os.environ.get("UROS_MIRROR")


def _generation(stderr: str) -> tuple[int, int]:
    found = re.search(
        r"interface code: (\d+) generator runs, (\d+) taken from the generation cache, (\d+) generated",
        stderr,
    )
    assert found, stderr
    return int(found[2]), int(found[3])


@pytest.mark.skipif(not MIRROR, reason="set UROS_MIRROR to a folder of upstream clones (<owner>+<repo>/repo)")
def test_a_second_target_reuses_the_generated_code_and_builds_the_same_bytes(tmp_path: Path) -> None:
    assert MIRROR
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("arm-none-eabi-gcc is not installed")
    shared = tmp_path / "shared"
    run_uros("create-firmware", "generate_lib", "--distro", "humble", "--workspace", str(shared),
             *humble_mirror_args(MIRROR))  # fmt: skip
    alone = tmp_path / "alone"
    alone.mkdir()
    checkout = tmp_path / "checkout two"
    checkout.mkdir()
    for name in ("mcu_ws", "dev_ws", "uros.yaml", "uros.lock", "colcon.meta"):
        for copy in (alone, checkout):
            if (shared / name).is_dir():
                shutil.copytree(shared / name, copy / name, symlinks=True)
            elif (shared / name).exists():
                shutil.copy2(shared / name, copy / name)

    user_cache = {"UROS_GEN_CACHE_DIR": str(tmp_path / "user-cache")}  # this test's own, empty at first

    def build(ws: Path, target: str, env: dict[str, str] | None = None) -> tuple[int, int]:
        done = run_uros(
            "build", "--toolchain", target, "--packages", "std_msgs", "--workspace", str(ws), "--no-ccache",
            env={**os.environ, **user_cache, **(env or {})},
        )  # fmt: skip
        if env is not None:
            assert "interface code:" not in done.stderr and "configure:" not in done.stderr
            return 0, 0
        calls = re.search(
            r"configure: (\d+) Python calls, (\d+) answered from the generation cache", done.stderr
        )
        assert calls and int(calls[2]) > 0, (
            done.stderr
        )  # ament's templates: the same answer for every package
        return _generation(done.stderr)

    taken, generated = build(shared, "cortex-m7")
    assert taken == 0 and generated > 0
    taken, generated = build(shared, "cortex-m4f")
    assert generated == 0 and taken > 0  # every generator run of the second target was a hit
    build(
        alone, "cortex-m4f", {"UROS_GEN_CACHE": "off", "UROS_COMPILER_SEED": "off", "UROS_HOST_STAGE": "off"}
    )
    # another checkout of the same sources at another path: the user's cache answers it all
    taken, generated = build(checkout, "cortex-m4f")
    assert generated == 0 and taken > 0
    lib = Path("build") / "cortex-m4f" / "libmicroros.a"
    assert (shared / lib).read_bytes() == (alone / lib).read_bytes() == (checkout / lib).read_bytes()
    # the packages that compile nothing came from the host stage, built once for both targets
    info = json.loads((shared / "build" / "cortex-m4f" / "build-info.json").read_text())
    assert {"rosidl_cli", "rosidl_parser", "rosidl_typesupport_interface"} <= set(info["host_stage_packages"])
    assert "host_stage_packages" not in json.loads(
        (alone / "build" / "cortex-m4f" / "build-info.json").read_text()
    )
    assert len(list((shared / ".uros" / "shared").iterdir())) == 1
    # and the include tree is the same, file for file
    inc = [
        p.relative_to(shared / "build" / "cortex-m4f")
        for p in (shared / "build" / "cortex-m4f" / "include").rglob("*")
    ]
    assert inc and all(
        (shared / "build" / "cortex-m4f" / p).read_bytes()
        == (alone / "build" / "cortex-m4f" / p).read_bytes()
        for p in inc
        if (shared / "build" / "cortex-m4f" / p).is_file()
    )
