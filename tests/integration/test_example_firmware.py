"""examples/cmake-firmware consumes the package with find_package(microros) and links a Cortex-M7 ELF."""

from __future__ import annotations

import json
import subprocess
import textwrap
from pathlib import Path

import pytest
from uros_helpers import REPO, build_firmware_project

pytestmark = pytest.mark.integration

# The fixture libraries are not micro-ROS, so the example's CMake project is built with this app
# instead of its micro-ROS main.c (the real-sources test builds main.c itself).
FIXTURE_APP = textwrap.dedent("""
    #include <time.h>
    #include <fx_core/core.h>
    #include <fx_time/time_now.h>
    #include <fx_util/util.h>
    #include <fxflat/flat.h>
    int clock_gettime(clockid_t id, struct timespec *tp) { (void)id; tp->tv_sec = 0; tp->tv_nsec = 0; return 0; }
    volatile double sink;
    int main(void) {
      sink = fx_util_scale(2.0) + (double)fx_time_now_ns();
      return fx_flat_sum() + fx_core_add(1, 2) + fx_core_util();
    }
""")


def test_example_links_a_cortex_m7_hard_float_elf(m7_build: Path, tmp_path: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    app = tmp_path / "app.c"
    app.write_text(FIXTURE_APP)
    build = tmp_path / "fw"
    elf = build_firmware_project(REPO / "examples" / "cmake-firmware", out, build, f"-DAPP_SOURCES={app}")
    assert elf.is_file()

    header = subprocess.run(["readelf", "-h", str(elf)], capture_output=True, text=True, check=True).stdout
    assert "ARM" in header and "hard-float ABI" in header
    attrs = subprocess.run(["readelf", "-A", str(elf)], capture_output=True, text=True, check=True).stdout
    assert "Tag_CPU_arch: v7E-M" in attrs
    assert "Tag_ABI_VFP_args: VFP registers" in attrs
    assert "Tag_FP_arch: FPv5/FP-D16 for ARMv8" in attrs

    # none of the micro-ROS-only flags reached the firmware's compile commands
    commands = " ".join(e["command"] for e in json.loads((build / "compile_commands.json").read_text()))
    assert "-mcpu=cortex-m7" in commands and "-mfpu=fpv5-d16" in commands
    assert "CLOCK_MONOTONIC" not in commands
    assert "__attribute__" not in commands
    assert "uros_clock_gettime" not in commands
    assert f"{out / 'include'}" in commands  # the include dir came from microros::microros

    # the library's objects were linked in: symbols from every fixture package
    syms = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    for name in ("fx_flat_sum", "fx_dup_a", "fx_dup_b", "fx_util_scale", "fx_time_now_ns"):
        assert f" {name}\n" in syms


def test_plain_include_snippet(m7_build: Path, tmp_path: Path) -> None:
    """microros.cmake works with include() for projects that do not use find_package."""
    out = m7_build / "build" / "cortex-m7"
    proj = tmp_path / "proj"
    proj.mkdir()
    (proj / "main.c").write_text("#include <fx_core/core.h>\nint main(void) { return fx_core_add(1, 2); }\n")
    (proj / "CMakeLists.txt").write_text(
        textwrap.dedent(f"""
        cmake_minimum_required(VERSION 3.16)
        project(p C)
        include("{out / "microros.cmake"}")
        add_executable(app main.c)
        target_link_libraries(app PRIVATE microros::microros)
    """)
    )
    subprocess.run(
        [
            "cmake",
            "-S",
            str(proj),
            "-B",
            str(proj / "b"),
            "-G",
            "Ninja",
            f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}",
        ],
        check=True,
        capture_output=True,
    )
    subprocess.run(["cmake", "--build", str(proj / "b")], check=True, capture_output=True)
    assert (proj / "b" / "app.elf").is_file()
