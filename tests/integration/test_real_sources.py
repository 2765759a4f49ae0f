"""Real micro-ROS Humble from a local mirror of the upstream repositories, end to end.

Runs when UROS_MIRROR names a folder of clones laid out as <owner>+<repo>/repo (what the project's
fetch tool produces); skipped otherwise (CI has no mirror). Takes about five minutes on 2 cores.
The overrides are the substitutions such a mirror needs for humble (docs/real-humble.md).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from uros_helpers import STM32H7_EXAMPLE as EXAMPLE
from uros_helpers import build_firmware_project, humble_mirror_args, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.realsources]

MIRROR = os.environ.get("UROS_MIRROR")


@pytest.mark.skipif(not MIRROR, reason="set UROS_MIRROR to a folder of upstream clones (<owner>+<repo>/repo)")
def test_real_humble_library_links_the_stm32h7_example(tmp_path: Path) -> None:
    assert MIRROR
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("arm-none-eabi-gcc is not installed")
    pkg = tmp_path / "eic_demo_interface"
    run_uros(
        "interface",
        "new",
        "eic_demo_interface",
        "--msg",
        str(EXAMPLE / "interfaces" / "CmdVel.msg"),
        "--srv",
        str(EXAMPLE / "interfaces" / "GetTime.srv"),
        "--output",
        str(pkg),
    )
    fw = tmp_path / "firmware"
    run_uros(
        "create-firmware",
        "generate_lib",
        "--distro",
        "humble",
        "--workspace",
        str(fw),
        "--extra-package",
        str(pkg),
        *humble_mirror_args(MIRROR),
    )
    run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw))

    out = fw / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text())
    assert info["transport"] == "custom"
    assert info["library"]["members"] > 1000
    for pkg_name in (
        "rcl",
        "rclc",
        "rmw_microxrcedds",
        "microxrcedds_client",
        "microcdr",
        "eic_demo_interface",
    ):
        assert pkg_name in info["packages"]
    for header in (
        "rcl/rcl.h",
        "rclc/rclc.h",
        "uxr/client/client.h",
        "ucdr/microcdr.h",
        "eic_demo_interface/msg/cmd_vel.h",
        "eic_demo_interface/srv/get_time.h",
    ):
        assert (out / "include" / header).is_file(), header

    build = tmp_path / "fw-build"
    elf = build_firmware_project(EXAMPLE, out, build)
    attrs = subprocess.run(["readelf", "-A", str(elf)], check=True, capture_output=True, text=True).stdout
    assert "Tag_ABI_VFP_args: VFP registers" in attrs
    commands = " ".join(e["command"] for e in json.loads((build / "compile_commands.json").read_text()))
    assert "CLOCK_MONOTONIC" not in commands
    syms = subprocess.run(["arm-none-eabi-nm", str(elf)], check=True, capture_output=True, text=True).stdout
    assert " rclc_publisher_init_default\n" in syms and " uxr_create_session\n" in syms

    # the same command again: nothing changed, nothing done
    again = run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw))
    assert "up to date" in again.stderr

    # the workspace moved to another folder builds with no hand work (libyaml_vendor's nested
    # ExternalProject cache, the host stage), the same library byte for byte (issue 34, item 1)
    library = (out / "libmicroros.a").read_bytes()
    moved = tmp_path / "moved-firmware"
    fw.rename(moved)
    run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(moved))
    again_lib = (moved / "build" / "cortex-m7" / "libmicroros.a").read_bytes()
    assert hashlib.sha256(again_lib).digest() == hashlib.sha256(library).digest()
    assert str(fw).encode() not in again_lib
    fw = moved

    # only what the example uses (its interfaces) and the core: a smaller library that still links
    pruned = tmp_path / "pruned"
    run_uros(
        "build", "--toolchain", "cortex-m7", "--workspace", str(fw), "--for-firmware", str(EXAMPLE),
        "--output", str(pruned),
    )  # fmt: skip
    small = json.loads((pruned / "build-info.json").read_text())
    assert "eic_demo_interface" in small["packages"] and "sensor_msgs" not in small["packages"]
    assert small["library"]["members"] < info["library"]["members"]
    build_firmware_project(EXAMPLE, pruned, tmp_path / "fw-pruned")
