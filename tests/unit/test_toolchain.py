from __future__ import annotations

from dataclasses import replace

from golden import check_golden

from uros_build.profiles import find_profile
from uros_build.templating import cmake_flags
from uros_build.toolchain import ToolchainRequest, microros_flags, render_toolchain


def test_cortex_m7_micro_ros_toolchain_golden() -> None:
    req = ToolchainRequest(find_profile("cortex-m7"), micro_ros=True, gcc_major=12, clock_header="/ws/h.h")
    check_golden("cortex-m7.micro-ros.cmake", render_toolchain(req))


def test_cortex_m7_firmware_toolchain_golden() -> None:
    text = render_toolchain(ToolchainRequest(find_profile("cortex-m7"), micro_ros=False))
    check_golden("cortex-m7.firmware.cmake", text)
    # the firmware's toolchain never carries micro-ROS-only flags
    assert "CLOCK_MONOTONIC" not in text
    assert "__attribute__" not in text
    assert "uros_clock_gettime" not in text


def test_attribute_stripping_only_for_old_gcc() -> None:
    profile = find_profile("cortex-m7")
    assert "-D__attribute__(x)=" not in microros_flags(ToolchainRequest(profile, True, gcc_major=12))
    assert "-D__attribute__(x)=" in microros_flags(ToolchainRequest(profile, True, gcc_major=5))
    assert "-D__attribute__(x)=" not in microros_flags(ToolchainRequest(profile, True, gcc_major=None))


def test_profile_optimisation_is_the_one_that_applies() -> None:
    profile = replace(find_profile("cortex-m7"), optimization="-O2")
    text = render_toolchain(ToolchainRequest(profile, micro_ros=True))
    assert 'CMAKE_${_uros_lang}_FLAGS_RELEASE "-O2 -DNDEBUG"' in text
    assert "-O3" not in text.replace("appends -O3", "")


def test_flags_with_spaces_quotes_and_semicolons_stay_one_word() -> None:
    assert cmake_flags(["-DA=1", "-include", "/a b/h.h"]) == "-DA=1 -include '/a b/h.h'"
    assert cmake_flags(['-DNAME="x;y"']) == "'-DNAME=\\\"x;y\\\"'"
    assert cmake_flags(["-DP=$HOME"]) == "'-DP=\\$\\$HOME'"  # CMake, then ninja/make


def test_esp32s3_micro_ros_toolchain_golden() -> None:
    # Rendered only: Espressif's compiler is not packaged (the integration test builds where it is
    # on PATH). The tool folder is what the ESP-IDF search found.
    req = ToolchainRequest(
        find_profile("esp32s3"),
        micro_ros=True,
        gcc_major=14,
        tool_dir="/home/me/.espressif/tools/xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin",
    )
    text = render_toolchain(req)
    check_golden("esp32s3.micro-ros.cmake", text)
    assert "-DESP_PLATFORM -DLWIP_IPV4 -DLWIP_IPV6 -DPLATFORM_NAME_FREERTOS" in text
    assert "CLOCK_MONOTONIC" not in text and "-include" not in text  # ESP-IDF's newlib has both
    assert (
        'set(CMAKE_C_COMPILER "/home/me/.espressif/tools/xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin/xtensa-esp32s3-elf-gcc")'
        in text
    )
    assert "set(CMAKE_C_STANDARD 17)" in text


def test_rv32imc_selects_picolibc_for_compiles_and_links() -> None:
    req = ToolchainRequest(find_profile("rv32imc"), micro_ros=True, gcc_major=12, clock_header="/ws/h.h")
    text = render_toolchain(req)
    check_golden("rv32imc.micro-ros.cmake", text)
    for var in ("CMAKE_C_FLAGS_INIT", "CMAKE_CXX_FLAGS_INIT", "CMAKE_EXE_LINKER_FLAGS_INIT"):
        line = next(line for line in text.splitlines() if line.startswith(f"set({var} "))
        assert "-march=rv32imc -mabi=ilp32 --specs=picolibc.specs" in line, var
