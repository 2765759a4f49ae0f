"""`uros build --idf-build`: micro-ROS compiled against an ESP-IDF project's build folder, through
the real CLI, colcon, CMake and a real Xtensa compiler.

CI has no Espressif compiler, so the target is a profile of the test's own: esp32s3's settings
(idf_target esp32s3, LwIP, UDP) with Debian's xtensa-lx106-elf-gcc and its call0 ABI. The IDF build
folder is generated (tests/fake_idf.py: the files uros reads, in IDF 5.5's shape with its response
file). What is proven here is the wiring: the IDF include folders, sdkconfig.h and the project's
flags reach every compile, PLATFORM_NAME and UCLIENT_C_STANDARD reach CMake, a changed sdkconfig.h
rebuilds, and none of it reaches the firmware's toolchain file. tests/integration/test_esp32s3_proof.py
builds real micro-ROS where a windowed-ABI compiler and ESP-IDF are at hand.
"""

from __future__ import annotations

import json
import re
import subprocess
import textwrap
from pathlib import Path

import pytest
from fake_idf import make_idf_build, xrce_client_stand_in
from uros_helpers import REPO, need, run_uros, run_uros_here

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")


def _profile(tmp: Path) -> Path:
    text = (REPO / "toolchains" / "esp32s3.yaml").read_text(encoding="utf-8")
    text = text.replace("name: esp32s3", "name: esp32s3-lx106")
    text = text.replace("compiler_prefix: xtensa-esp32s3-elf-", "compiler_prefix: xtensa-lx106-elf-")
    text = re.sub(r"compiler_search:\n(  - .*\n)+", "", text)
    # Debian's lx106 compiler: picolibc, call0
    text = text.replace(
        "cpu_flags: [-mlongcalls]",
        "cpu_flags: [-mlongcalls]\nlibc_flags: [--specs=/usr/lib/xtensa-lx106-elf/picolibc.specs]",
    )
    text = text.replace('xtensa_abi: "0"', 'xtensa_abi: "1"')
    path = tmp / "esp32s3-lx106.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _workspace(root: Path) -> Path:
    pkg = xrce_client_stand_in(root)
    # What the XRCE-DDS client reads, where it reads it: its UCLIENT_C_STANDARD cache entry is
    # created before project() reads the toolchain file; PLATFORM_NAME is read after it.
    _write(
        pkg / "CMakeLists.txt",
        """
        cmake_minimum_required(VERSION 3.16)
        set(UCLIENT_C_STANDARD 99 CACHE STRING "as the XRCE-DDS client declares it")
        project(fx_idf C)
        if(NOT PLATFORM_NAME STREQUAL "LwIP" OR NOT UCLIENT_C_STANDARD EQUAL 17 OR NOT CMAKE_C_STANDARD EQUAL 17)
          message(FATAL_ERROR "PLATFORM_NAME=${PLATFORM_NAME} UCLIENT_C_STANDARD=${UCLIENT_C_STANDARD} C${CMAKE_C_STANDARD}")
        endif()
        add_library(fx_idf STATIC src/idf.c)
        set_target_properties(fx_idf PROPERTIES C_STANDARD ${UCLIENT_C_STANDARD})
        install(TARGETS fx_idf ARCHIVE DESTINATION lib)
        """,
    )
    _write(
        pkg / "src" / "idf.c",
        """
        #include "sdkconfig.h"        /* <build>/config */
        #include "lwip/uros_probe.h"  /* a component's public include folder */
        #include "soc_probe.h"        /* <IDF_PATH>/components/soc/esp32s3/include */
        #if !defined(ESP_PLATFORM) || !defined(PLATFORM_NAME_FREERTOS) || !defined(LWIP_IPV6)
        #error "the ESP-IDF defines are missing"
        #endif
        #ifndef FROM_RESPONSE_FILE
        #error "the IDF project's response-file flags did not reach the compiler"
        #endif
        _Static_assert(__STDC_VERSION__ >= 201710L, "C17");
        #define CAT(a, b) a##b
        #define NAME(v) CAT(fx_idf_config_, v)
        const char fx_idf_flag[] = FROM_RESPONSE_FILE;
        /* lx106 has no S32C1I: a call to __atomic_exchange_4, which ESP-IDF does not define on an S3 */
        unsigned fx_idf_word;
        unsigned fx_idf_swap(unsigned v) { return __atomic_exchange_n(&fx_idf_word, v, __ATOMIC_SEQ_CST); }
        int NAME(CONFIG_UROS_TEST_VALUE)(void) { return UROS_PROBE + SOC_PROBE; }
        """,
    )
    return root


def _idf_build(tmp: Path) -> Path:
    # IDF 5.5: CMAKE_C_FLAGS is a response file; a flag with a space and quotes must stay one word
    build = make_idf_build(
        tmp,
        c_flags='@"RSP/toolchain/cflags"',
        version=(5, 5, 4),
        sdkconfig="#define CONFIG_UROS_TEST_VALUE 7\n",
    )
    cache = build / "CMakeCache.txt"
    cache.write_text(cache.read_text(encoding="utf-8").replace("RSP", str(build)), encoding="utf-8")
    _write(build / "toolchain" / "cflags", """-mlongcalls\n-DFROM_RESPONSE_FILE="\\"a b\\""\n""")
    idf = tmp / "esp idf" / "components"
    _write(idf / "lwip" / "include" / "lwip" / "uros_probe.h", "#define UROS_PROBE 1\n")
    _write(idf / "soc" / "esp32s3" / "include" / "soc_probe.h", "#define SOC_PROBE 2\n")
    return build


def _symbols(lib: Path) -> str:
    return subprocess.run(["nm", str(lib)], capture_output=True, text=True, check=True).stdout


def test_micro_ros_compiles_against_the_idf_project_and_sdkconfig_changes_rebuild(tmp_path: Path) -> None:
    need("cmake")
    need("xtensa-lx106-elf-gcc")
    ws = _workspace(tmp_path / "ws")
    build = _idf_build(tmp_path / "idf")
    args = ("build", "--profile", str(_profile(tmp_path)), "-w", str(ws), "--idf-build", str(build))
    proc = run_uros(*args)
    assert "ESP-IDF 5.5.4 project" in proc.stderr and "(esp32s3): 4 components" in proc.stderr
    # the atomics warning names the object; the check says which targets look the same
    warning = next(line for line in proc.stderr.splitlines() if "needs __atomic_exchange_4" in line)
    assert "idf.c.obj" in warning and "esp32s3-lx106's platform does not define" in warning
    assert "the ELF facts of esp32s3-lx106 and esp8266 are identical" in proc.stderr
    out = ws / "build" / "esp32s3-lx106"
    assert "T fx_idf_config_7" in _symbols(out / "libmicroros.a")
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["idf"]["version"] == "5.5.4" and info["idf"]["target"] == "esp32s3"
    assert list(info["abi_check"]["undefined_atomics"]) == ["__atomic_exchange_4"]
    assert info["idf"]["c_flags"] == ["-mlongcalls", '-DFROM_RESPONSE_FILE="a b"']
    first_hash = info["idf"]["sdkconfig_sha256"]
    # micro-ROS only: the firmware's toolchain file knows nothing of the IDF project
    firmware_tc = (out / "toolchain.cmake").read_text(encoding="utf-8")
    assert "esp idf" not in firmware_tc and 'PLATFORM_NAME "' not in firmware_tc
    # a changed sdkconfig.h is a rebuild
    sdkconfig = build / "config" / "sdkconfig.h"
    sdkconfig.write_text(
        sdkconfig.read_text(encoding="utf-8").replace("VALUE 7", "VALUE 8"), encoding="utf-8"
    )
    run_uros(*args)
    symbols = _symbols(out / "libmicroros.a")
    assert "T fx_idf_config_8" in symbols and "fx_idf_config_7" not in symbols
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["idf"]["sdkconfig_sha256"] != first_hash


def test_idf_build_for_another_chip_is_refused_before_anything_runs(tmp_path: Path) -> None:
    """In process (run_uros_here): refused before any process starts."""
    ws = _workspace(tmp_path / "ws")
    build = make_idf_build(tmp_path / "idf", target="esp32")
    proc = run_uros_here(
        "build", "--toolchain", "esp32s3", "-w", str(ws), "--idf-build", str(build), check=False
    )
    assert proc.returncode == 2
    assert "the project builds for IDF_TARGET esp32, uros builds for esp32s3" in proc.stderr
    assert not (ws / ".uros").exists()
    proc = run_uros_here(
        "build", "--toolchain", "esp32s3", "-w", str(ws), "--idf-build", str(tmp_path), check=False
    )
    assert proc.returncode == 2 and "not an ESP-IDF build folder" in proc.stderr
