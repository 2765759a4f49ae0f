"""Every target with a packaged compiler, end to end: the fixture workspace built through the real
CLI with arm-none-eabi-gcc, riscv64-unknown-elf-gcc + picolibc and xtensa-lx106-elf-gcc + picolibc,
checked by uros's ABI check and, independently, by readelf assertions written from measured
output. Then the check's failures, command-line targets, the ESP-IDF compiler search and export.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
from fixture_ws import FIXTURE_MEMBERS, TIME_MEMBERS, UP_TO_TIME, add_board_package, make_fixture_workspace
from uros_helpers import REPO, need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

COMPILERS = {"arm": "arm-none-eabi-gcc", "riscv": "riscv64-unknown-elf-gcc", "xtensa": "xtensa-lx106-elf-gcc"}

# target -> (compiler, strings every object's readelf output must hold, strings it must not)
ARM_SOFT = ("Tag_FP_arch", "Tag_ABI_VFP_args", "Tag_ABI_HardFP_use")
EXPECTED: dict[str, tuple[str, tuple[str, ...], tuple[str, ...]]] = {
    "cortex-m0plus": ("arm", ("Machine: ARM", "Tag_CPU_arch: v6S-M", "Tag_THUMB_ISA_use: Thumb-1"), ARM_SOFT),
    "rp2040": ("arm", ("Machine: ARM", "Tag_CPU_arch: v6S-M", "Tag_THUMB_ISA_use: Thumb-1"), ARM_SOFT),
    "cortex-m3": ("arm", ("Machine: ARM", "Tag_CPU_arch: v7", 'Tag_CPU_name: "7-M"'), ARM_SOFT),
    "cortex-m4": ("arm", ("Machine: ARM", "Tag_CPU_arch: v7E-M", "Tag_THUMB_ISA_use: Thumb-2"), ARM_SOFT),
    "cortex-m4f": (
        "arm",
        (
            "Tag_CPU_arch: v7E-M",
            "Tag_FP_arch: VFPv4-D16",
            "Tag_ABI_HardFP_use: SP only",
            "Tag_ABI_VFP_args: VFP registers",
        ),
        (),
    ),
    "cortex-m7": (
        "arm",
        ("Tag_CPU_arch: v7E-M", "Tag_FP_arch: FPv5/FP-D16 for ARMv8", "Tag_ABI_VFP_args: VFP registers"),
        ("Tag_ABI_HardFP_use",),
    ),
    "cortex-m7-sp": (
        "arm",
        ("Tag_CPU_arch: v7E-M", "Tag_FP_arch: FPv5/FP-D16 for ARMv8", "Tag_ABI_HardFP_use: SP only"),
        (),
    ),
    "cortex-m33": (
        "arm",
        (
            "Tag_CPU_arch: v8-M.mainline",
            "Tag_FP_arch: FPv5/FP-D16 for ARMv8",
            "Tag_ABI_HardFP_use: SP only",
            "Tag_DSP_extension: Allowed",
        ),
        (),
    ),
    "cortex-m55": (
        "arm",
        (
            "Tag_CPU_arch: v8.1-M.mainline",
            "Tag_FP_arch: FPv5/FP-D16 for ARMv8",
            "Tag_ABI_VFP_args: VFP registers",
            "Tag_MVE_arch: MVE Integer and FP",
        ),
        ("Tag_ABI_HardFP_use",),
    ),
    "rv32imc": (
        "riscv",
        ("Machine: RISC-V", "Flags: 0x1, RVC, soft-float ABI", 'Tag_RISCV_arch: "rv32i2p1_m2p0_c2p0'),
        ("_a2p",),
    ),
    "esp8266": ("xtensa", ("Machine: Tensilica Xtensa Processor", "Flags: 0x300", "ABI=1"), ("Tag_",)),
}

# Targets whose ELF facts equal another shipped target's.
LOOK_ALIKE = {
    "cortex-m0plus": "cortex-m0plus and rp2040",
    "rp2040": "cortex-m0plus and rp2040",
    "rv32imc": "esp32c3 and rv32imc",
}


def _readelf_members(lib: Path) -> dict[str, str]:
    """member -> its readelf text, whitespace runs squeezed ("Machine:   ARM" -> "Machine: ARM")."""
    out = subprocess.run(
        ["readelf", "--file-header", "--arch-specific", "--string-dump=.xtensa.info", str(lib)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    members = {}
    for chunk in out.split("\nFile: ")[1:]:
        head, _, body = chunk.partition("\n")
        members[head] = re.sub(r"[ \t]+", " ", body)
    return members


# What every target but cortex-m7 builds of the fixture: UP_TO_TIME, fx_time (clock_gettime(
# CLOCK_MONOTONIC) with -Werror=implicit-function-declaration: the C library's micro-ROS-only
# flags) and fx_core. A target's flags reach every object alike, so the other three packages added
# only their fixed cost (~0.14 s of CPU a package a target); the whole fixture's merge traps are
# test_build_fixture's subject. cortex-m7 is the whole fixture (the worker's built m7 one).


def _members(target: str) -> int:
    """The objects the library of ``target`` in :func:`target_builds` holds."""
    return FIXTURE_MEMBERS if target == "cortex-m7" else TIME_MEMBERS


@pytest.fixture(scope="session")
def target_builds(tmp_path_factory: pytest.TempPathFactory, fixture_builds: Any) -> Path:
    """The fixture workspace built for every installed target, all in one workspace (their trees
    and outputs are kept apart per target): two `uros build`s side by side, each of several targets
    (--toolchain repeated: one uros start, its host facts and data files, for every target it
    builds; each target still configured, compiled and checked on its own), of fx_time and what it
    needs (UP_TO_TIME). cortex-m7's is the tests' built fixture (integration/conftest.py, variant
    m7: the same command, the whole fixture), copied in: built once a worker."""
    need("cmake")
    ws = tmp_path_factory.mktemp("targets") / "ws"
    if shutil.which(COMPILERS["arm"]):
        shutil.copytree(fixture_builds.snapshot("m7"), ws, symlinks=True)
    else:
        make_fixture_workspace(ws)
    targets = [
        t for t, (arch, _, _) in EXPECTED.items() if shutil.which(COMPILERS[arch]) and t != "cortex-m7"
    ]

    def build(group: list[str]) -> None:
        toolchains = [arg for target in group for arg in ("--toolchain", target)]
        meta = ["--meta", str(ws / "fixture.meta")]
        run_uros("build", *toolchains, "--workspace", str(ws), *meta, *UP_TO_TIME, "-j", "1")

    with ThreadPoolExecutor(max_workers=2) as pool:
        list(pool.map(build, [group for group in (targets[0::2], targets[1::2]) if group]))
    return ws


@pytest.mark.parametrize("target", sorted(EXPECTED))
def test_target_builds_and_passes_the_abi_check(target_builds: Path, target: str) -> None:
    need(COMPILERS[EXPECTED[target][0]])
    out = target_builds / "build" / target
    info = json.loads((out / "build-info.json").read_text())
    members = _members(target)
    assert info["target"] == target and info["library"]["members"] == members
    check = info["abi_check"]
    assert check["checked"] and check["result"] == "pass" and check["objects"] == members
    # fx_time compiled clock_gettime(CLOCK_MONOTONIC) with -Werror=implicit-function-declaration:
    # newlib and picolibc got CLOCK_MONOTONIC=0 and the declaration header, as micro-ROS-only flags.
    assert info["flags"]["micro_ros_only"][:3] == ["-DCLOCK_MONOTONIC=0", "-include", "uros_clock_gettime.h"]
    # and `uros check` agrees on the finished library
    proc = run_uros("check", str(out / "libmicroros.a"), "--toolchain", target)
    if target in LOOK_ALIKE:  # no ELF fact tells these targets apart: the check says so
        assert f"all {members} objects show the ELF facts of {target} (" in proc.stderr
        assert f"the ELF facts of {LOOK_ALIKE[target]} are identical" in proc.stderr
    else:
        assert f"all {members} objects match {target}" in proc.stderr


@pytest.mark.parametrize("target", sorted(EXPECTED))
def test_every_object_shows_the_measured_elf_facts(target_builds: Path, target: str) -> None:
    arch, present, absent = EXPECTED[target]
    need(COMPILERS[arch])
    members = _readelf_members(target_builds / "build" / target / "libmicroros.a")
    assert len(members) == _members(target)
    for member, text in members.items():
        for fact in present:
            assert fact in text, (target, member, fact)
        for fact in absent:
            assert fact not in text, (target, member, fact)


def test_picolibc_is_selected_for_riscv(target_builds: Path) -> None:
    need("riscv64-unknown-elf-gcc")
    cc = target_builds / ".uros" / "targets" / "rv32imc" / "build" / "fx_time" / "compile_commands.json"
    (command,) = [e["command"] for e in json.loads(cc.read_text())]
    assert "-march=rv32imc -mabi=ilp32 --specs=picolibc.specs" in command


def _copy_with(lib: Path, extra_from: Path, dest: Path) -> Path:
    """A copy of ``lib`` with the first member of ``extra_from`` appended (host ar: any ELF)."""
    work = dest / "extra"
    work.mkdir(parents=True)
    member = subprocess.run(
        ["ar", "t", str(extra_from)], capture_output=True, text=True, check=True
    ).stdout.split()[0]
    subprocess.run(["ar", "x", str(extra_from), member], cwd=work, check=True)
    mixed = dest / "mixed.a"
    shutil.copy(lib, mixed)
    subprocess.run(["ar", "q", str(mixed), str(work / member)], check=True)
    return mixed


def _error_line(proc: subprocess.CompletedProcess[str]) -> str:
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in proc.stderr, proc.stderr
    return errors[0]


def test_cortex_m4f_library_fails_as_cortex_m7(target_builds: Path) -> None:
    need("arm-none-eabi-gcc")
    lib = target_builds / "build" / "cortex-m4f" / "libmicroros.a"
    proc = run_uros("check", str(lib), "--toolchain", "cortex-m7", check=False)
    assert proc.returncode == 5
    line = _error_line(proc)
    assert re.search(
        r"libmicroros\.a\(libfx_\w+__\w+\.c\.obj\): Tag_FP_arch is VFPv4-D16, cortex-m7 expects FPv5/FP-D16 for ARMv8",
        line,
    )


def test_riscv_object_in_an_arm_library_fails(target_builds: Path, tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "riscv64-unknown-elf-gcc")
    b = target_builds / "build"
    mixed = _copy_with(b / "cortex-m4f" / "libmicroros.a", b / "rv32imc" / "libmicroros.a", tmp_path)
    proc = run_uros("check", str(mixed), "--toolchain", "cortex-m4f", check=False)
    assert proc.returncode == 5
    assert re.search(
        r"mixed\.a\(libfx_\w+\.c\.obj\): Machine is RISC-V, cortex-m4f expects ARM", _error_line(proc)
    )


def test_stale_xtensa_object_in_a_riscv_library_fails(target_builds: Path, tmp_path: Path) -> None:
    need("riscv64-unknown-elf-gcc", "xtensa-lx106-elf-gcc")
    b = target_builds / "build"
    mixed = _copy_with(b / "rv32imc" / "libmicroros.a", b / "esp8266" / "libmicroros.a", tmp_path)
    proc = run_uros("check", str(mixed), "--profile", str(REPO / "toolchains" / "rv32imc.yaml"), check=False)
    assert proc.returncode == 5
    assert "Machine is Tensilica Xtensa Processor, rv32imc expects RISC-V" in _error_line(proc)


def test_double_precision_fpu_build_for_m4f_fails_and_keeps_the_previous_output(tmp_path: Path) -> None:
    """micro_ros_arduino's Cortex-M4 recipe (-mfpu=vfpv3-d16): the build's own check stops it.
    The second build also proves that changed flags reach an already configured tree. fx_core
    alone: -mfpu marks every object, and one package is the cheapest configured tree."""
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    base = ["build", "--toolchain", "cortex-m4f", "--workspace", str(ws), "--packages-up-to", "fx_core"]
    run_uros(*base, "--cflags", "-DFX_FIRST=1")
    lib = ws / "build" / "cortex-m4f-custom" / "libmicroros.a"
    good = lib.read_bytes()
    proc = run_uros(*base, "--cflags", "-mfpu=vfpv3-d16", check=False)
    assert proc.returncode == 5
    line = _error_line(proc)
    assert (
        "libmicroros.a(" in line and "Tag_FP_arch is VFPv3-D16, cortex-m4f-custom expects VFPv4-D16" in line
    )
    assert lib.read_bytes() == good
    assert not [p for p in (ws / "build").iterdir() if "staging" in p.name]


def test_cflags_with_space_quote_and_semicolon_reach_the_compiler(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    add_board_package(ws)
    flag = '-DBOARD_NAME="my board;1"'
    run_uros(
        "build",
        "--toolchain",
        "cortex-m33",
        "--compiler-prefix",
        "arm-none-eabi-",
        "--cflags",
        flag,
        "--cflags",
        "-DFX_OTHER=2",
        "--workspace",
        str(ws),
        "--packages-up-to",
        "fx_board",
    )
    out = ws / "build" / "cortex-m33-custom"
    assert b"my board;1\x00" in (out / "libmicroros.a").read_bytes()  # the string, quotes removed by C
    info = json.loads((out / "build-info.json").read_text())
    assert info["flags"]["c"][-2:] == [flag, "-DFX_OTHER=2"] and info["abi_check"]["result"] == "pass"


def test_standalone_target_from_prefix_and_flags(tmp_path: Path) -> None:
    need("riscv64-unknown-elf-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    run_uros(
        "build",
        "--compiler-prefix",
        "riscv64-unknown-elf-",
        "--cflags",
        "-march=rv32imac",
        "--cflags",
        "-mabi=ilp32",
        "--cflags=--specs=picolibc.specs",
        "--workspace",
        str(ws),
        "--packages-up-to",
        "fx_core",
    )
    info = json.loads((ws / "build" / "custom-riscv64-unknown-elf" / "build-info.json").read_text())
    assert info["flags"]["cpu"] == ["-march=rv32imac", "-mabi=ilp32", "--specs=picolibc.specs"]
    assert info["abi_check"]["expects"] == {"class": "ELF32", "machine": "RISC-V"}
    lib = ws / "build" / "custom-riscv64-unknown-elf" / "libmicroros.a"
    assert all('Tag_RISCV_arch: "rv32i2p1_m2p0_a2p1_c2p0' in t for t in _readelf_members(lib).values())
    proc = run_uros("check", str(lib), "--toolchain", "rv32imc", check=False)
    assert proc.returncode == 5 and "Tag_RISCV_arch is rv32i2p1_m2p0_a2p1" in _error_line(proc)


def _env_without_idf(tmp_path: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("IDF_PATH", "IDF_TOOLS_PATH")}
    env["HOME"] = str(tmp_path / "home")
    return env


def test_esp32s3_builds_or_renders_and_says_how_to_install(target_builds: Path, tmp_path: Path) -> None:
    if shutil.which("xtensa-esp32s3-elf-gcc"):
        # Espressif's compiler is there: the fixture (no lwIP headers needed) builds and passes.
        run_uros(
            "build",
            "--toolchain",
            "esp32s3",
            "--transport",
            "custom",
            "--workspace",
            str(target_builds),
            "--meta",
            str(target_builds / "fixture.meta"),
            "--packages-up-to",
            "fx_flat",
        )
        info = json.loads((target_builds / "build" / "esp32s3" / "build-info.json").read_text())
        assert info["abi_check"]["result"] == "pass" and info["idf_target"] == "esp32s3"
        return
    rendered = run_uros("toolchain", "render", "esp32s3", "--for", "micro-ros", "--gcc-major", "14").stdout
    golden = REPO / "tests" / "integration" / "golden" / "esp32s3.micro-ros.cmake"
    if os.environ.get("UROS_UPDATE_GOLDEN") == "1":
        golden.write_text(rendered)
    assert rendered == golden.read_text()
    proc = run_uros(
        "build",
        "--toolchain",
        "esp32s3",
        "--workspace",
        str(target_builds),
        check=False,
        env=_env_without_idf(tmp_path),
    )
    assert proc.returncode == 3
    line = _error_line(proc)
    assert "'xtensa-esp32s3-elf-gcc' was found neither on PATH nor in" in line
    assert "/home/.espressif/tools/xtensa-esp-elf/*/xtensa-esp-elf/bin" in line
    hint = proc.stderr.splitlines()[-1]
    assert hint.startswith("hint: install ESP-IDF's toolchain:") and "install.sh esp32s3" in hint


def test_compiler_found_in_an_idf_tools_folder_is_used(target_builds: Path, tmp_path: Path) -> None:
    """A fake ESP-IDF 5.2+ tools folder whose xtensa-esp32s3-elf-* are Debian's lx106 tools: the
    search finds them and the build uses them, and the ABI check notices the objects are call0
    (lx106) where an ESP32-S3 needs windowed ones. fx_core alone (its two objects are what the
    check reads; fx_time is left out: lx106's picolibc has no CLOCK_MONOTONIC, which an ESP32-S3
    profile rightly does not supply)."""
    need("xtensa-lx106-elf-gcc", "cmake")
    if shutil.which("xtensa-esp32s3-elf-gcc"):
        pytest.skip("the real xtensa-esp32s3-elf-gcc is on PATH")
    env = _env_without_idf(tmp_path)
    env["IDF_TOOLS_PATH"] = str(tmp_path / "idf tools")  # a space in the path, too
    bin_dir = (
        tmp_path / "idf tools" / "tools" / "xtensa-esp-elf" / "esp-14.2.0_20241119" / "xtensa-esp-elf" / "bin"
    )
    bin_dir.mkdir(parents=True)
    for tool in ("gcc", "g++", "ar", "ranlib", "nm", "size", "objcopy"):
        (bin_dir / f"xtensa-esp32s3-elf-{tool}").symlink_to(shutil.which(f"xtensa-lx106-elf-{tool}") or "")
    ws = make_fixture_workspace(tmp_path / "ws")
    proc = run_uros(
        "build",
        "--toolchain",
        "esp32s3",
        "--transport",
        "custom",
        "--workspace",
        str(ws),
        "--packages-up-to",
        "fx_core",
        check=False,
        env=env,
    )
    assert f"using {bin_dir / 'xtensa-esp32s3-elf-gcc'} (not on PATH)" in proc.stderr
    assert proc.returncode == 5, proc.stderr
    assert ".xtensa.info ABI=1 (call0), esp32s3 expects ABI=0 (windowed)" in _error_line(proc)
    toolchain = (ws / ".uros" / "targets" / "esp32s3" / "toolchain.cmake").read_text()
    assert f'set(CMAKE_C_COMPILER "{bin_dir}/xtensa-esp32s3-elf-gcc")' in toolchain
    assert not (ws / "build" / "esp32s3").exists()


def test_export_esp_idf_component(target_builds: Path, tmp_path: Path) -> None:
    need("riscv64-unknown-elf-gcc")
    m7 = target_builds / "build" / "cortex-m7"
    proc = run_uros("export", "esp-idf", "--from", str(m7), "--output", str(tmp_path / "no"), check=False)
    assert proc.returncode == 2 and "not an ESP-IDF target" in _error_line(proc)
    # No ESP32 compiler here: the component's shape is checked around the rv32imc output
    # relabelled as an ESP32-C3 build (the library inside is not what an ESP32-C3 needs).
    fake = tmp_path / "esp32c3-out"
    shutil.copytree(target_builds / "build" / "rv32imc", fake)
    info = json.loads((fake / "build-info.json").read_text())
    (fake / "build-info.json").write_text(json.dumps({**info, "idf_target": "esp32c3", "transport": "udp"}))
    dest = tmp_path / "project" / "components" / "micro_ros"
    run_uros("export", "esp-idf", "--from", str(fake), "--output", str(dest))
    assert (dest / "libmicroros.a").is_file() and (dest / "include" / "fx_core" / "core.h").is_file()
    cmake = (dest / "CMakeLists.txt").read_text()
    assert 'idf_component_register(INCLUDE_DIRS "include" REQUIRES lwip)' in cmake
    assert 'if(NOT IDF_TARGET STREQUAL "esp32c3")' in cmake
