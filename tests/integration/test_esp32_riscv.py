"""The RISC-V ESP32 chips built for real (issue 42, item 2): ESP32-C3 (rv32imc), C6 and H2 (rv32imac) and
P4 (rv32imafc, ilp32f) through `uros build --idf-build`, with Debian's riscv64-unknown-elf-gcc 12.2 in
place of Espressif's riscv32-esp-elf-gcc (`--compiler-prefix`, picolibc for the C library: the same ISA
and ABI, another C library). Through the real CLI, colcon, CMake and the real compiler; the ESP-IDF build
folder is generated (tests/fake_idf.py), the workspace is a fixture package standing in for the XRCE-DDS
client (so the client's colcon.meta and PLATFORM_NAME reach it).

Each chip's library is then checked independently of uros (readelf's float ABI and ISA string, objdump's
instructions: the P4's single-precision FPU, the "A" chips' inline amoswap.w) and linked into a minimal
ESP-IDF-style app (main/main.c's app_main(), started by a stand-in for ESP-IDF's start-up), which runs in
QEMU's RISC-V virt where qemu-system-riscv32 is installed and exits with what the library computed.
What it does not prove (docs/esp32.md): ESP-IDF's own headers, newlib and link (none are here), nor
Espressif's compiler.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import textwrap
from pathlib import Path

import pytest
from fake_idf import make_idf_build, xrce_client_stand_in
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

GCC = "riscv64-unknown-elf-gcc"
# chip -> (-march of the multilib the app links with, -mabi, float ABI in e_flags, ISA letters)
CHIPS = {
    "esp32c3": ("rv32imc", "ilp32", "soft-float ABI", "_m2p0_c2p0"),
    "esp32c6": ("rv32imac", "ilp32", "soft-float ABI", "_m2p0_a2p1_c2p0"),
    "esp32h2": ("rv32imac", "ilp32", "soft-float ABI", "_m2p0_a2p1_c2p0"),
    "esp32p4": ("rv32imafc", "ilp32f", "single-float ABI", "_m2p0_a2p1_f2p2_c2p0"),
}


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")


def _workspace(root: Path, chip: str) -> Path:
    pkg = xrce_client_stand_in(root)
    _write(
        pkg / "CMakeLists.txt",
        """
        cmake_minimum_required(VERSION 3.16)
        project(fx_esp C)
        if(NOT PLATFORM_NAME STREQUAL "LwIP")
          message(FATAL_ERROR "PLATFORM_NAME=${PLATFORM_NAME}")
        endif()
        add_library(fx_esp STATIC src/esp.c)
        install(TARGETS fx_esp ARCHIVE DESTINATION lib)
        """,
    )
    _write(
        pkg / "src" / "esp.c",
        f"""
        #include <stdint.h>
        #include "sdkconfig.h"        /* <build>/config */
        #include "soc_probe.h"        /* <IDF_PATH>/components/soc/{chip}/include */
        #if !defined(ESP_PLATFORM) || !defined(PLATFORM_NAME_FREERTOS) || !defined(FROM_IDF_FLAGS)
        #error "the ESP-IDF defines or the project's flags are missing"
        #endif
        /* float arithmetic: the P4's FPU (fmadd.s) where the ABI is ilp32f, libcalls elsewhere */
        float fx_esp_scale(float x, float k, float c) {{ return x * k + c; }}
        /* a 4-byte atomic: inline amoswap.w with "A" (C6, H2, P4), __atomic_exchange_4 on the C3 */
        static uint32_t fx_esp_word;
        uint32_t fx_esp_swap(uint32_t v) {{ return __atomic_exchange_n(&fx_esp_word, v, __ATOMIC_SEQ_CST); }}
        int fx_esp_config(void) {{ return CONFIG_UROS_TEST_VALUE + SOC_PROBE; }}
        """,
    )
    return root


def _idf_build(tmp: Path, chip: str, march: str, mabi: str) -> Path:
    # ESP-IDF's CMAKE_C_FLAGS for a RISC-V chip start with its -march/-mabi (tools/cmake/toolchain-<chip>.cmake)
    flags = f"-march={march}_zicsr_zifencei -mabi={mabi} -fno-builtin-memcpy -DFROM_IDF_FLAGS=1"
    build = make_idf_build(
        tmp,
        target=chip,
        soc=chip,
        c_flags=flags,
        version=(5, 3, 1),
        sdkconfig="#define CONFIG_UROS_TEST_VALUE 7\n",
    )
    _write(tmp / "esp idf" / "components" / "soc" / chip / "include" / "soc_probe.h", "#define SOC_PROBE 2\n")
    return build


def _tool(name: str, *args: str) -> str:
    env = {"LC_ALL": "C", "PATH": "/usr/bin:/bin"}
    return subprocess.run([name, *args], capture_output=True, text=True, check=True, env=env).stdout


def _app(tmp: Path, lib: Path, march: str, mabi: str) -> Path:
    """A minimal ESP-IDF-style app: main/main.c's app_main(), and a stand-in for ESP-IDF's start-up that
    calls it (ESP-IDF's own start-up, FreeRTOS and newlib are not here): picolibc's hosted crt0 on
    QEMU virt's memory, semihosting for the exit status."""
    _write(
        tmp / "main" / "main.c",
        """
        #include <stdint.h>
        #include <stdio.h>
        float fx_esp_scale(float x, float k, float c);
        uint32_t fx_esp_swap(uint32_t v);
        int fx_esp_config(void);
        int app_status;
        void app_main(void) {
          volatile float x = 2.5f;
          uint32_t old = fx_esp_swap(5u);
          uint32_t now = fx_esp_swap(6u);
          int scaled = (int)fx_esp_scale(x, 4.0f, 0.5f); /* 10.5 -> 10 */
          printf("app_main: %d %u %u %d\\n", scaled, (unsigned)old, (unsigned)now, fx_esp_config());
          app_status = scaled + (int)old + (int)now + fx_esp_config(); /* 10 + 0 + 5 + 9 = 24 */
        }
        """,
    )
    _write(
        tmp / "start.c",
        """
        #include <stdint.h>
        extern int app_status;
        void app_main(void);
        int main(void) { app_main(); return app_status; }
        #ifndef __riscv_atomic
        /* no "A" (the C3): ESP-IDF's newlib defines the 1/2/4-byte atomics (stdatomic.c, interrupts
           off on the single core); one core and no interrupts here */
        uint32_t __atomic_exchange_4(volatile void *mem, uint32_t value, int order) {
          (void)order;
          uint32_t old = *(volatile uint32_t *)mem;
          *(volatile uint32_t *)mem = value;
          return old;
        }
        #endif
        """,
    )
    elf = tmp / "app.elf"
    subprocess.run(
        [
            GCC, "--specs=picolibc.specs", "--oslib=semihost", "--crt0=hosted", f"-march={march}",
            f"-mabi={mabi}", "-Os", "-Wl,--gc-sections", "-Wl,--defsym=__flash=0x80000000",
            "-Wl,--defsym=__flash_size=0x200000", "-Wl,--defsym=__ram=0x80200000",
            "-Wl,--defsym=__ram_size=0x200000", str(tmp / "main" / "main.c"), str(tmp / "start.c"),
            str(lib), "-o", str(elf),
        ],
        check=True,
    )  # fmt: skip
    return elf


@pytest.mark.parametrize("chip", sorted(CHIPS))
def test_the_chip_builds_through_idf_build_with_debians_riscv_gcc(tmp_path: Path, chip: str) -> None:
    need("cmake")
    need(GCC)
    march, mabi, float_abi, letters = CHIPS[chip]
    ws = _workspace(tmp_path / "ws", chip)
    build = _idf_build(tmp_path / "idf", chip, march, mabi)
    proc = run_uros(
        "build", "--toolchain", chip, "--compiler-prefix", "riscv64-unknown-elf-",
        "--cflags=--specs=picolibc.specs", "-w", str(ws), "--idf-build", str(build),
    )  # fmt: skip
    assert f"({chip}): 4 components" in proc.stderr
    out = ws / "build" / f"{chip}-custom"
    lib = out / "libmicroros.a"
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["abi_check"]["result"] == "pass" and info["idf"]["target"] == chip
    # nothing undefined that ESP-IDF would not define on this chip (4-byte atomics inline with "A")
    assert "undefined_atomics" not in info["abi_check"], info["abi_check"]
    # independently of uros: the float ABI in e_flags, the ISA string, the instructions
    readelf = _tool("readelf", "-h", "-A", str(lib))
    assert f"RVC, {float_abi}" in readelf
    assert f'Tag_RISCV_arch: "rv32i2p1{letters}_zicsr2p0' in readelf
    disassembly = _tool("riscv64-unknown-elf-objdump", "-d", str(lib))
    symbols = _tool("riscv64-unknown-elf-nm", str(lib))
    if "f" in march[4:]:
        assert "fmadd.s" in disassembly and "__mulsf3" not in symbols
    else:
        assert "fmadd.s" not in disassembly and "U __mulsf3" in symbols
    if "a" in march[4:]:
        assert "amoswap.w" in disassembly and "__atomic_exchange_4" not in symbols
    else:  # the C3: ESP-IDF's newlib defines it (stdatomic.c, no "A")
        assert "amoswap.w" not in disassembly and "U __atomic_exchange_4" in symbols
    # a uros check of the library for another chip of the family fails on the ISA or the float ABI
    other = "esp32c6" if chip == "esp32p4" else "esp32p4"
    check = run_uros("check", str(lib), "--toolchain", other, check=False)
    assert check.returncode == 5, check.stderr
    # linked into a minimal ESP-IDF-style app, and run where QEMU is
    elf = _app(tmp_path / "app", lib, march, mabi)
    assert "app_main" in _tool("riscv64-unknown-elf-nm", str(elf))
    qemu = shutil.which("qemu-system-riscv32")
    if qemu is None:
        return
    run = subprocess.run(
        [qemu, "-M", "virt", "-bios", "none", "-nographic", "-semihosting-config", "enable=on,target=native",
         "-kernel", str(elf)],
        capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL,
    )  # fmt: skip
    assert "app_main: 10 0 5 9" in run.stdout + run.stderr, run.stdout + run.stderr  # semihosting: stderr
    assert run.returncode == 24


@pytest.mark.parametrize(
    ("target", "code"),
    [
        ("rv32imc", "M (div) inline; calls __mulsf3, __atomic_exchange_4; soft-float ABI (ilp32)"),
        ("rv32imac", "M (div), A (amoswap.w) inline; calls __mulsf3; soft-float ABI (ilp32)"),
        ("rv32imafc", "F (fmadd.s), M (div), A (amoswap.w) inline; single-float ABI (ilp32f)"),
    ],
)
def test_doctor_says_what_debians_riscv_gcc_makes_for_each_isa(
    tmp_path: Path, target: str, code: str
) -> None:
    # the bare-metal twins of the C3, C6/H2 and P4 use Debian's compiler by name; the esp32* profiles
    # ask riscv32-esp-elf-gcc the same (docs/esp32.md)
    need(GCC)
    doctor = run_uros("doctor", "--toolchain", target, "-w", str(tmp_path), check=False)
    assert f"/{GCC}: makes RV32 code: {code}" in doctor.stdout, doctor.stdout
