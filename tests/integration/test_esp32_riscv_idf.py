"""Real micro-ROS humble for the RISC-V ESP32 chips (C3, C6, H2, P4), compiled against a real ESP-IDF
project: what tests/integration/test_esp32s3_proof.py does for the ESP32-S3 (issue 42, item 2).

Inputs (skipped cleanly without any of them; CI has none):
- UROS_MIRROR: a folder of upstream clones, <owner>+<repo>/repo (as test_real_sources.py);
- IDF_PATH: an ESP-IDF tree, 5.3 or later (the P4's first), its Python packages importable (kconfgen);
- riscv32-esp-elf-gcc (and its binutils) on PATH: ESP-IDF's own toolchain, or
  tests/esp32-riscv-idf-env.sh's wrappers around Debian's riscv64-unknown-elf-gcc 12.2 with Espressif's
  newlib 4.3 headers (the same script writes the ESP-IDF v5.3.1 tree); docs/esp32.md says what that
  proves and what it does not.

What it does, per chip, as a user moving the ESP32-S3 example to the chip would: configures a copy of
examples/esp32s3-idf with ESP-IDF's CMake and IDF_TARGET=<chip> (on the C3 and C6 unchanged, Wi-Fi and
all; the H2 and P4 have no Wi-Fi, so their main.c starts the same node task without it), runs
`uros build --toolchain <chip> --idf-build <project>/build` over one firmware workspace (the example's
demo_interfaces/Hsb message), exports the component, configures again and compiles main.c and
app/app.c with the compile commands ESP-IDF wrote, and ESP-IDF's own components/newlib/stdatomic.c
(what ESP-IDF defines of the __atomic_* routines on this chip).
It checks, independently of uros: readelf's float ABI in every member (ilp32f, "single-float ABI", on
the P4 only) and the ISA string; objdump's instructions (single-precision FPU only on the P4; amo*/lr/sc
only on the chips with "A"); `ld -r main.c.obj app.c.obj libmicroros.a` links (GNU ld refuses mixed
float ABIs); every __atomic_* routine left undefined is one ESP-IDF's stdatomic.c, compiled for the
chip, defines; linking that stdatomic.o in defines nothing twice; and what stays undefined is what
ESP-IDF provides on this chip: declared by its headers or newlib's, libgcc's (the compiler's libgcc.a
for the chip's multilib, or the chip's ROM). With UROS_ESP_NEWLIB (Espressif's newlib 4.3 built for the
ISA: tests/esp32-riscv-idf-env.sh DIR rv32imc ...), ESP-IDF's newlib component (every source ESP-IDF
compiles in components/newlib) and newlib's libc.a, libm.a and libgcc.a are linked in too: nothing is
defined twice, nothing newlib defines stays undefined, and what does is ESP-IDF's (declared by its
headers, or named in its sources: heap.c's calls of heap_caps_*_default).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path

import pytest
from idf_project import (
    EXAMPLE,
    compile_as_idf_does,
    component_include_dirs,
    configure,
    example_firmware,
    libc_include_dirs,
    run,
    words,
)
from uros_helpers import run_uros

pytestmark = [pytest.mark.integration, pytest.mark.realsources]

MIRROR = os.environ.get("UROS_MIRROR")
IDF_PATH = os.environ.get("IDF_PATH")
# optional: a folder of Espressif's newlib libc.a per ISA (<isa>/libc.a, tests/esp32-riscv-idf-env.sh)
NEWLIB = os.environ.get("UROS_ESP_NEWLIB")
PREFIX = "riscv32-esp-elf-"
# chip -> (ESP-IDF's -march for it, float ABI in e_flags, ISA letters in Tag_RISCV_arch, has Wi-Fi)
CHIPS = {  # the P4 first: the chip a user moves an S3 node to
    "esp32p4": ("rv32imafc", "single-float ABI", "_m2p0_a2p1_f2p2_c2p0", False),
    "esp32c3": ("rv32imc", "soft-float ABI", "_m2p0_c2p0", True),
    "esp32c6": ("rv32imac", "soft-float ABI", "_m2p0_a2p1_c2p0", True),
    "esp32h2": ("rv32imac", "soft-float ABI", "_m2p0_a2p1_c2p0", False),
}
# single-precision FPU instructions (objdump -d mnemonics) and atomic ones ("A")
FPU = re.compile(
    r"\tf(?:madd|msub|nmadd|nmsub|add|sub|mul|div|sqrt|mv|cvt|lw|sw|eq|lt|le|sgnj\w*|min|max)\.?[sw]?"
)
ATOMIC = re.compile(r"\t(?:amo\w+\.w|lr\.w|sc\.w)")
NO_WIFI_MAIN = """\
/* The node of examples/esp32s3-idf on a chip without Wi-Fi (ESP32-H2, ESP32-P4: Ethernet, Thread or a
 * companion chip bring the network): the same app/app.c as a FreeRTOS task. Written by
 * tests/integration/test_esp32_riscv_idf.py. */
#include "esp_event.h"
#include "esp_netif.h"
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"

void appMain(void *arg);

void app_main(void)
{
    ESP_ERROR_CHECK(esp_netif_init());
    ESP_ERROR_CHECK(esp_event_loop_create_default());
    xTaskCreate(appMain, "micro_ros", 16000, NULL, 5, NULL);
}
"""


def _missing() -> str | None:
    if not MIRROR:
        return "set UROS_MIRROR to a folder of upstream clones (<owner>+<repo>/repo)"
    if not IDF_PATH or not (Path(IDF_PATH) / "components" / "soc" / "esp32p4").is_dir():
        return "set IDF_PATH to an ESP-IDF tree, 5.3 or later (tests/esp32-riscv-idf-env.sh writes one)"
    for tool in ("gcc", "ld", "nm", "objdump", "readelf"):
        if shutil.which(PREFIX + tool) is None:
            return f"{PREFIX}{tool} is not on PATH (tests/esp32-riscv-idf-env.sh makes one over Debian's GCC)"
    if shutil.which("cmake") is None or shutil.which("ninja") is None:
        return "cmake and ninja are needed to configure an ESP-IDF project"
    return None


def _project(root: Path, chip: str) -> Path:
    """examples/esp32s3-idf for ``chip``: unchanged where the chip has Wi-Fi, else main.c without it."""
    project = root / "microros_hsb"
    shutil.copytree(EXAMPLE, project, ignore=shutil.ignore_patterns("build", "sdkconfig", "micro_ros"))
    defaults = project / "sdkconfig.defaults"
    defaults.write_text(
        defaults.read_text().replace('CONFIG_IDF_TARGET="esp32s3"', f'CONFIG_IDF_TARGET="{chip}"')
    )
    if not CHIPS[chip][3]:
        (project / "main" / "main.c").write_text(NO_WIFI_MAIN)
        cmake = project / "main" / "CMakeLists.txt"
        cmake.write_text(cmake.read_text().replace("set(requires esp_wifi esp_netif esp_event nvs_flash lwip)",
                                                   "set(requires esp_netif esp_event lwip)"))  # fmt: skip
    return project


def _members(readelf: str) -> dict[str, str]:
    """readelf -h -A over an archive: member -> its text."""
    return {
        chunk.partition("\n")[0].split("(")[-1].rstrip("):"): chunk for chunk in readelf.split("\nFile: ")[1:]
    }


def _undefined(obj: Path) -> set[str]:
    return set(run([PREFIX + "nm", "-u", "--format=just-symbols", str(obj)]).split())


def _sources(build: Path, folder: str) -> list[str]:
    """The sources under ``folder`` (a path part) that ESP-IDF compiles for the project but stdatomic.c."""
    entries = json.loads((build / "compile_commands.json").read_text())
    return sorted(e["file"] for e in entries if folder in e["file"] and not e["file"].endswith("stdatomic.c"))


def _defined(obj_or_lib: str) -> set[str]:
    return set(run([PREFIX + "nm", "--defined-only", "--format=just-symbols", obj_or_lib]).split())


def _rom_symbols(chip: str) -> set[str]:
    """What the chip's ROM holds and ESP-IDF links by address (components/esp_rom/<chip>/ld/*.ld)."""
    assert IDF_PATH
    found: set[str] = set()
    for script in (Path(IDF_PATH) / "components" / "esp_rom" / chip / "ld").glob("*.ld"):
        found.update(re.findall(r"^\s*(?:PROVIDE\s*\(\s*)?(\w+)\s*=\s*0x", script.read_text(), re.MULTILINE))
    return found


@pytest.fixture(scope="module")
def firmware(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One firmware workspace (humble, with the example's demo_interfaces) for every chip."""
    assert MIRROR
    return example_firmware(tmp_path_factory.mktemp("esp32-riscv-idf"), MIRROR)


@pytest.mark.skipif(_missing() is not None, reason=str(_missing()))
@pytest.mark.parametrize("chip", list(CHIPS))
def test_real_humble_for_a_riscv_esp32_against_an_esp_idf_project(
    tmp_path: Path, firmware: Path, chip: str
) -> None:
    march, float_abi, letters, _wifi = CHIPS[chip]
    project = _project(tmp_path, chip)
    idf_build = configure(project, chip)
    started = time.monotonic()
    proc = run_uros("build", "--toolchain", chip, "--workspace", str(firmware), "--idf-build", str(idf_build))
    seconds = time.monotonic() - started

    out = firmware / "build" / chip
    lib = out / "libmicroros.a"
    info = json.loads((out / "build-info.json").read_text())
    assert info["abi_check"]["result"] == "pass" and info["transport"] == "udp"
    assert info["idf"]["target"] == chip and tuple(map(int, info["idf"]["version"].split(".")[:2])) >= (5, 3)
    for package in ("rcl", "rclc", "rmw_microxrcedds", "microxrcedds_client", "demo_interfaces"):
        assert package in info["packages"]
    # ESP-IDF's own -march for the chip reached the compiler (the P4's with _xesppie, ESP-IDF >= 5.3)
    cache = (idf_build / "CMakeCache.txt").read_text()
    assert f"-march={march}_zicsr_zifencei" in cache

    # independently of uros: every member's float ABI and ISA string, the instructions
    members = _members(run([PREFIX + "readelf", "-h", "-A", str(lib)]))
    assert len(members) == info["library"]["members"] > 1000
    assert all(f"RVC, {float_abi}" in text for text in members.values()), [
        m for m, text in members.items() if f"RVC, {float_abi}" not in text
    ][:5]
    assert all(f'Tag_RISCV_arch: "rv32i2p1{letters}_zicsr2p0' in t for t in members.values() if "Tag_" in t)
    assert any("udp_transport_posix_nopoll" in m for m in members)
    disassembly = run([PREFIX + "objdump", "-d", str(lib)])
    fpu = len(FPU.findall(disassembly))
    atomic = len(ATOMIC.findall(disassembly))
    assert (fpu > 0) == ("f" in march[4:]), fpu
    assert (atomic > 0) == ("a" in march[4:]), atomic

    # the ESP-IDF side: the component exported into the project, configured again, main.c and app.c
    # compiled as ESP-IDF compiles them, and ESP-IDF's stdatomic.c for this chip
    run_uros("export", "esp-idf", "--from", str(out), "--output", str(project / "components" / "micro_ros"))
    configure(project, chip)
    objects = [str(compile_as_idf_does(idf_build, source)) for source in ("main/main.c", "app/app.c")]
    for obj in objects:
        assert f"RVC, {float_abi}" in run([PREFIX + "readelf", "-h", obj])
    stdatomic = compile_as_idf_does(idf_build, "components/newlib/stdatomic.c")
    idf_atomics = {
        s for s in _defined(str(stdatomic)) if s.startswith("__atomic_") or s.startswith("__sync_")
    }

    closure = tmp_path / "closure.o"
    run([PREFIX + "ld", "-r", "-o", str(closure), *objects, str(lib)])  # fails on mixed float ABIs
    before = _undefined(closure)
    atomics = {s for s in before if re.fullmatch(r"__(atomic|sync)_\w+", s)}
    # every atomic routine the library and the app need, ESP-IDF's newlib defines on this chip
    assert atomics <= idf_atomics, sorted(atomics - idf_atomics)
    # with ESP-IDF's stdatomic.o: no "multiple definition" (rcutils' own __atomic_*_8 would be one)
    # and, where Espressif's newlib was built for the ISA, its libc.a and libgcc.a: nothing the
    # library needs of the C library is missing from it, nothing is defined twice
    mabi = "ilp32f" if "f" in march[4:] else "ilp32"
    libgcc = run([PREFIX + "gcc", f"-march={march}", f"-mabi={mabi}", "-print-libgcc-file-name"])
    newlib = Path(NEWLIB) / march if NEWLIB else None
    linked = tmp_path / "linked.o"
    run([PREFIX + "ld", "-r", "-o", str(linked), str(closure), str(stdatomic)])
    if newlib and (newlib / "libc.a").is_file():
        # ESP-IDF's newlib component (syscalls.c's _read_r.., locks, time.c's usleep..) comes first in
        # the link, as in a firmware: newlib's own reent/ stand-ins are then not pulled in
        component = [
            str(compile_as_idf_does(idf_build, s)) for s in _sources(idf_build, "components/newlib/")
        ]
        libs = [str(newlib / "libc.a"), str(newlib / "libm.a"), libgcc.strip()]
        with_newlib = tmp_path / "with-newlib.o"
        run([PREFIX + "ld", "-r", "-o", str(with_newlib), str(linked), *component,
             "--start-group", *libs, "--end-group"])  # fmt: skip
        linked = with_newlib
    undefined = _undefined(linked)
    idf_dirs = component_include_dirs(idf_build)
    declared = words([*idf_dirs, str(idf_build / "config"), *libc_include_dirs(PREFIX + "gcc")])
    provided = _defined(libgcc.strip()) | _rom_symbols(chip)
    unexplained = sorted(s for s in undefined if s not in declared and s not in provided)
    newlib_linked = linked.name == "with-newlib.o"
    if not newlib_linked:
        assert unexplained == []
    else:
        assert newlib is not None
        # nothing that newlib defines stays undefined; what does is ESP-IDF's: declared by its headers
        # (esp_vfs_*, FreeRTOS, lwIP) or, what its newlib component calls of private ones (heap.c's
        # heap_caps_*_default), named in its sources (checked below, after the figures)
        assert not undefined & (_defined(str(newlib / "libc.a")) | _defined(str(newlib / "libm.a")))
    with_libc = (
        f"; with newlib {len(undefined)} undefined, not in ESP-IDF's headers {unexplained}"
        if newlib_linked
        else ""
    )
    print(
        f"\n{chip} idf proof: {seconds:.0f} s uros build, {len(members)} objects, {lib.stat().st_size} bytes, "
        f"{fpu} FPU and {atomic} A instructions, float ABI {float_abi}; main.c + app.c + libmicroros.a: "
        f"{len(before)} undefined, atomics {sorted(atomics)}{with_libc}; ESP-IDF's stdatomic.c defines "
        f"{len(idf_atomics)} (sizes {sorted({a.rsplit('_', 1)[-1] for a in idf_atomics})}); "
        f"uros warned: {'needs __atomic' in proc.stderr}"
    )
    if unexplained:  # each one named in ESP-IDF's sources (components/heap, freertos, esp_system, ...)
        components = [str(Path(IDF_PATH or "") / "components")]
        sources = words(components, "*.c") | words(components, "*.S")
        assert [s for s in unexplained if s not in sources] == []
