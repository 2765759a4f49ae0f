"""Real micro-ROS humble for the ESP32-S3, compiled against a real ESP-IDF project, end to end.

Inputs (skipped cleanly without any of them; CI has none):
- UROS_MIRROR: a folder of upstream clones, <owner>+<repo>/repo (as test_real_sources.py);
- IDF_PATH: an ESP-IDF tree, version 5 or later (its Python packages importable: kconfgen);
- xtensa-esp32s3-elf-gcc (and its binutils) on PATH: ESP-IDF's own toolchain, or any compiler
  that emits the ESP32-S3's windowed ABI. Without Espressif's compiler, tests/esp32s3-compat-env.sh
  builds all three from the mirror into a scratch folder (Debian's lx106 GCC with -mabi=windowed and
  the ESP32-S3 core plugin for binutils, newlib 4.3 headers, ESP-IDF v5.3.1); docs/esp32.md says what
  that proves and what it does not.

What it does, as a user would: configures examples/esp32s3-idf with ESP-IDF's CMake (a copy in a
tmp folder), creates a firmware workspace with the example's demo_interfaces/Hsb message, runs
`uros build --toolchain esp32s3 --idf-build <project>/build`, exports the ESP-IDF component into the
project, configures again and compiles the example's main.c and app/app.c with the compile commands
ESP-IDF wrote.
It checks: every object of libmicroros.a has the windowed ABI (ABI=0, no call0 object), and
`ld -r main.c.obj app.c.obj libmicroros.a` leaves only symbols ESP-IDF provides undefined (declared by its
headers or its C library's; libgcc's, in the compiler's libgcc.a or the S3 ROM; the __atomic_*_8 of
its newlib) plus the 1/2/4-byte atomics uros's check reported (what the firmware must then define,
docs/esp32.md).
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
PREFIX = "xtensa-esp32s3-elf-"


def _missing() -> str | None:
    if not MIRROR:
        return "set UROS_MIRROR to a folder of upstream clones (<owner>+<repo>/repo)"
    if not IDF_PATH or not (Path(IDF_PATH) / "tools" / "cmake" / "project.cmake").is_file():
        return "set IDF_PATH to an ESP-IDF tree"
    for tool in ("gcc", "ld", "nm"):
        if shutil.which(PREFIX + tool) is None:
            return f"{PREFIX}{tool} is not on PATH (tests/esp32s3-compat-env.sh builds a stand-in)"
    if shutil.which("cmake") is None or shutil.which("ninja") is None:
        return "cmake and ninja are needed to configure an ESP-IDF project"
    return None


def _xtensa_abi_by_member(lib: Path) -> dict[str, str | None]:
    out = run(["readelf", "--string-dump=.xtensa.info", str(lib)])
    members: dict[str, str | None] = {}
    for chunk in out.split("\nFile: ")[1:]:
        head, _, body = chunk.partition("\n")
        found = re.search(r"\bABI=(\d+)", body)
        members[head] = found[1] if found else None
    return members


def _libgcc_symbols() -> set[str]:
    """libgcc's routines: the compiler's libgcc.a, and the ones the ESP32-S3 ROM holds, which ESP-IDF
    links by address (esp32s3.rom.libgcc.ld). Debian's lx106 libgcc.a leaves out __divsi3, __udivdi3,
    __floatsisf and others (the ESP8266 ROM has them), so its archive alone would not do."""
    libgcc = run([PREFIX + "gcc", "-print-libgcc-file-name"]).strip()
    defined = set(run([PREFIX + "nm", "--defined-only", "--format=just-symbols", libgcc]).split())
    assert IDF_PATH
    rom = Path(IDF_PATH) / "components" / "esp_rom" / "esp32s3" / "ld" / "esp32s3.rom.libgcc.ld"
    return defined | set(re.findall(r"^\s*(\w+)\s*=\s*0x", rom.read_text(), re.MULTILINE))


@pytest.mark.skipif(_missing() is not None, reason=str(_missing()))
def test_real_humble_for_esp32s3_against_an_esp_idf_project(tmp_path: Path) -> None:
    assert MIRROR
    project = tmp_path / "microros_hsb"
    shutil.copytree(EXAMPLE, project, ignore=shutil.ignore_patterns("build", "sdkconfig", "micro_ros"))
    idf_build = configure(project, "esp32s3")

    fw = example_firmware(tmp_path, MIRROR)
    started = time.monotonic()
    proc = run_uros("build", "--toolchain", "esp32s3", "--workspace", str(fw), "--idf-build", str(idf_build))
    seconds = time.monotonic() - started

    out = fw / "build" / "esp32s3"
    lib = out / "libmicroros.a"
    info = json.loads((out / "build-info.json").read_text())
    assert info["abi_check"]["result"] == "pass" and info["transport"] == "udp"
    assert info["idf"]["target"] == "esp32s3" and int(info["idf"]["version"].split(".")[0]) >= 5
    for package in ("rcl", "rclc", "rmw_microxrcedds", "microxrcedds_client", "demo_interfaces"):
        assert package in info["packages"]
    assert (out / "include" / "demo_interfaces" / "msg" / "hsb.h").is_file()
    # the UDP transport over lwIP's sockets was compiled in (PLATFORM_NAME LwIP)
    members = _xtensa_abi_by_member(lib)
    assert any("udp_transport_posix_nopoll" in m for m in members)
    # every object is windowed-ABI, independently of uros's own check
    assert len(members) == info["library"]["members"] > 1000
    assert {abi for abi in members.values()} == {"0"}, {m: a for m, a in members.items() if a != "0"}

    # the ESP-IDF side: the exported component in the project, configured again, main.c compiled
    # with the compile command ESP-IDF wrote for it
    run_uros("export", "esp-idf", "--from", str(out), "--output", str(project / "components" / "micro_ros"))
    configure(project, "esp32s3")
    objects = []
    # main.c (Wi-Fi, the task) and app/app.c (the node's appMain, which `uros probe --app` also runs)
    for source in ("main/main.c", "app/app.c"):
        obj = compile_as_idf_does(idf_build, source)
        assert _xtensa_abi_by_member_single(obj) == "0"
        objects.append(str(obj))

    closure = tmp_path / "closure.o"
    run([PREFIX + "ld", "-r", "-o", str(closure), *objects, str(lib)])
    undefined = set(run([PREFIX + "nm", "-u", "--format=just-symbols", str(closure)]).split())
    idf_dirs = component_include_dirs(idf_build)
    declared = words([*idf_dirs, str(idf_build / "config"), *libc_include_dirs(PREFIX + "gcc")])
    libgcc = _libgcc_symbols()
    reported = set(info["abi_check"].get("undefined_atomics", {}))
    unexplained = sorted(
        s for s in undefined
        if s not in declared and s not in libgcc and s not in reported
        and not re.fullmatch(r"__atomic_\w+_8", s)  # ESP-IDF >= 5.3's newlib (stdatomic.c)
    )  # fmt: skip
    assert unexplained == []
    # what ESP-IDF does not provide on the S3 is exactly what uros's check warned about
    atomics_small = {s for s in undefined if re.fullmatch(r"__(atomic|sync)_\w+_[124]", s)}
    assert atomics_small <= reported
    for symbol in atomics_small:
        assert f"needs {symbol} (" in proc.stderr
    size = run([PREFIX + "size", "-t", str(lib)]).splitlines()[-1].split()
    print(
        f"\nesp32s3 proof: {seconds:.0f} s uros build, {len(members)} objects, {lib.stat().st_size} bytes, "
        f"size -t text/data/bss {size[0]}/{size[1]}/{size[2]}, {len(list((out / 'include').rglob('*.h')))} "
        f"headers; main.c + libmicroros.a: {len(undefined)} undefined, small atomics {sorted(atomics_small)}"
    )


def _xtensa_abi_by_member_single(obj: Path) -> str | None:
    found = re.search(r"\bABI=(\d+)", run(["readelf", "--string-dump=.xtensa.info", str(obj)]))
    return found[1] if found else None
