from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml
from profile_data import minimal_profile

from uros_build import resources
from uros_build.errors import ConfigError
from uros_build.target.profiles import (
    RISCV_FLOAT_ABI,
    derive_profile,
    find_profile,
    load_profile_file,
    riscv_float_abi,
    riscv_mabi,
    shipped_profiles,
)


def _write(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "board.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_shipped_profiles_load() -> None:
    profiles = shipped_profiles()
    assert "cortex-m7" in profiles
    m7 = find_profile("cortex-m7")
    assert m7.cpu_flags == ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard")
    assert m7.tool("gcc") == "arm-none-eabi-gcc"
    assert dict(m7.elf.attributes)["Tag_ABI_VFP_args"] == "VFP registers"


def test_minimal_profile(tmp_path: Path) -> None:
    p = load_profile_file(_write(tmp_path, minimal_profile()))
    assert p.name == "board" and p.transport == "custom" and p.optimization == "-Os"


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"cpu_flag": ["x"]}, r"board.yaml:\d+: cpu_flag: unknown key"),
        ({"cpu_flags": "-mcpu=cortex-m4"}, r"board.yaml: cpu_flags: must be a list of strings"),
        ({"transport": "can"}, r"board.yaml: transport: 'can' is not one of"),
        ({"elf": {"machine": "ARM", "flags": []}}, r"board.yaml:\d+: elf.flags: unknown key"),
        ({"optimization": "fast"}, r"board.yaml: optimization: 'fast' is not one of GCC's levels: -O, -O0"),
        # round 3 (issue 34, 7): these reached CMake or GCC unchecked
        ({"optimization": "-O4"}, r"board.yaml: optimization: '-O4' is not one of GCC's levels"),
        ({"optimization": "-Os -g"}, r"board.yaml: optimization: '-Os -g' is not one of GCC's levels"),
        ({"c_standard": 12}, r"board.yaml: c_standard: 12 is not one of CMake's: 90, 99, 11, 17, 23"),
        ({"cxx_standard": 15}, r"board.yaml: cxx_standard: 15 is not one of CMake's: 98, 11"),
        ({"c_standard": "11"}, r"board.yaml: c_standard: must be a whole number"),
        ({"defines": ["FOO BAR"]}, r"board.yaml: defines: 'FOO BAR' is not a define: NAME or NAME=VALUE"),
        ({"defines": ["-DFOO"]}, r"board.yaml: defines: '-DFOO' is not a define"),
        ({"defines": ["A=1\nB"]}, r"board.yaml: defines: 'A=1\\nB' is not a define"),
        ({"defines": [""]}, r"board.yaml: defines: '' is not a define"),
        ({"defines": "FOO"}, r"board.yaml: defines: must be a list of strings"),
        ({"micro_ros": {"defines": ["1X=2"]}}, r"board.yaml: micro_ros.defines: '1X=2' is not a define"),
        ({"native_64bit_atomics": "yes"}, r"native_64bit_atomics: must be true or false"),
        ({"elf": {"machine": "ARM", "xtensa_abi": "2"}}, r"elf.xtensa_abi: '2' is not 0"),
        (
            {"elf": {"machine": "ARM", "attribute_patterns": {"Tag_X": "("}}},
            r"elf.attribute_patterns.Tag_X: not a",
        ),
        ({"compiler_search": ["{HOME}/bin"]}, r"compiler_search: unknown placeholder \{HOME\}"),
        ({"compiler_prefix": "arm-none-eabi"}, r"compiler_prefix: 'arm-none-eabi' is not a prefix"),
        ({"c_flags": ["-DA=1\n-DB"]}, r"c_flags: '-DA=1\\n-DB' is not a single compiler flag"),
        ({"libc_flags": [""]}, r"libc_flags: '' is not a single compiler flag"),
        # a name is a folder name under .uros/targets/ and build/: never a path (issue 8, item 1)
        ({"name": ".."}, r"board.yaml: name: '\.\.' is not a target name"),
        ({"name": "."}, r"board.yaml: name: '\.' is not a target name"),
        ({"name": ""}, r"board.yaml: name: must be a non-empty string"),
        ({"name": "a/b"}, r"board.yaml: name: 'a/b' is not a target name"),
        ({"name": "../../x"}, r"board.yaml: name: '\.\./\.\./x' is not a target name"),
        ({"name": ".hidden"}, r"board.yaml: name: '\.hidden' is not a target name"),
        ({"name": "My Board"}, r"board.yaml: name: 'My Board' is not a target name"),
        ({"name": "x" * 101}, r"board.yaml: name: 'x+' is not a target name"),
    ],
)
def test_bad_profiles_name_file_and_key(tmp_path: Path, change: dict[str, object], expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        load_profile_file(_write(tmp_path, {**minimal_profile(), **change}))


def test_missing_field(tmp_path: Path) -> None:
    data = minimal_profile()
    del data["compiler_prefix"]
    with pytest.raises(ConfigError, match="compiler_prefix: is required but missing"):
        load_profile_file(_write(tmp_path, data))


def test_nested_keys_are_named_with_dots(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"board.yaml: elf.machine: is required but missing") as info:
        load_profile_file(_write(tmp_path, {**minimal_profile(), "elf": {"elf_class": "ELF32"}}))
    assert info.value.hint is not None and "uros targets show cortex-m7" in info.value.hint
    with pytest.raises(
        ConfigError, match=r"board.yaml: micro_ros.strip_attributes_below_gcc: must be a whole"
    ):
        load_profile_file(
            _write(tmp_path, {**minimal_profile(), "micro_ros": {"strip_attributes_below_gcc": "6"}})
        )
    with pytest.raises(ConfigError, match=r"board.yaml: elf: expected a mapping"):
        load_profile_file(_write(tmp_path, {**minimal_profile(), "elf": "ARM"}))
    with pytest.raises(
        ConfigError, match=r"board.yaml: elf.attributes: must be a mapping of names to strings"
    ):
        load_profile_file(
            _write(tmp_path, {**minimal_profile(), "elf": {"machine": "ARM", "attributes": ["x"]}})
        )


def test_key_without_value(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"board.yaml: idf_target: has no value"):
        load_profile_file(_write(tmp_path, {**minimal_profile(), "idf_target": None}))


def test_profile_file_problems_are_one_line(tmp_path: Path) -> None:
    path = tmp_path / "board.yaml"
    path.write_bytes(b"name: caf\xe9\n")
    with pytest.raises(ConfigError, match=r"board.yaml: not UTF-8 text \(byte 9\)$"):
        load_profile_file(path)
    path.write_text("name: board\ncpu_flags: [-mthumb\nelf: {}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"board.yaml:3:4: not valid YAML"):
        load_profile_file(path)
    with pytest.raises(ConfigError, match=r"nope.yaml: no such file"):
        load_profile_file(tmp_path / "nope.yaml")
    path.write_text("- name: board\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"board.yaml: expected a mapping \(key: value lines\), got list"):
        load_profile_file(path)


def test_unknown_target_lists_known() -> None:
    with pytest.raises(ConfigError) as info:
        find_profile("cortex-m99")
    assert info.value.hint is not None and "cortex-m7" in info.value.hint


# Every shipped target, with what it must have (the research record's measured facts).
SHIPPED = {
    "cortex-m0plus": ("arm-none-eabi-", "-mcpu=cortex-m0plus", "Tag_CPU_arch", "v6S-M"),
    "rp2040": ("arm-none-eabi-", "-mcpu=cortex-m0plus", "Tag_CPU_arch", "v6S-M"),
    "cortex-m3": ("arm-none-eabi-", "-mcpu=cortex-m3", "Tag_CPU_arch", "v7"),
    "cortex-m4": ("arm-none-eabi-", "-mfloat-abi=soft", "Tag_CPU_arch", "v7E-M"),
    "cortex-m4f": ("arm-none-eabi-", "-mfpu=fpv4-sp-d16", "Tag_FP_arch", "VFPv4-D16"),
    "cortex-m7": ("arm-none-eabi-", "-mfpu=fpv5-d16", "Tag_FP_arch", "FPv5/FP-D16 for ARMv8"),
    "cortex-m7-sp": ("arm-none-eabi-", "-mfpu=fpv5-sp-d16", "Tag_ABI_HardFP_use", "SP only"),
    "cortex-m33": ("arm-none-eabi-", "-mcpu=cortex-m33", "Tag_CPU_arch", "v8-M.mainline"),
    "cortex-m55": ("arm-none-eabi-", "-mcpu=cortex-m55", "Tag_MVE_arch", "MVE Integer and FP"),
    "rv32imc": ("riscv64-unknown-elf-", "-march=rv32imc", None, None),
    "rv32imac": ("riscv64-unknown-elf-", "-march=rv32imac", None, None),
    "rv32imafc": ("riscv64-unknown-elf-", "-march=rv32imafc", None, None),
    "esp8266": ("xtensa-lx106-elf-", "-mlongcalls", None, None),
    "esp32": ("xtensa-esp32-elf-", "-mlongcalls", None, None),
    "esp32s2": ("xtensa-esp32s2-elf-", "-mlongcalls", None, None),
    "esp32s3": ("xtensa-esp32s3-elf-", "-mlongcalls", None, None),
    "esp32s3-bare": ("xtensa-esp32s3-elf-", "-mlongcalls", None, None),
    "esp32c3": ("riscv32-esp-elf-", "-march=rv32imc_zicsr_zifencei", None, None),
    "esp32c6": ("riscv32-esp-elf-", "-march=rv32imac_zicsr_zifencei", None, None),
    "esp32h2": ("riscv32-esp-elf-", "-march=rv32imac_zicsr_zifencei", None, None),
    "esp32p4": ("riscv32-esp-elf-", "-march=rv32imafc_zicsr_zifencei", None, None),
}


def test_every_shipped_target_loads() -> None:
    profiles = shipped_profiles()
    assert sorted(profiles) == sorted(SHIPPED)
    for name, (prefix, flag, tag, value) in SHIPPED.items():
        p = profiles[name]
        assert p.compiler_prefix == prefix and flag in p.cpu_flags, name
        if tag is not None:
            assert dict(p.elf.attributes)[tag] == value, name
        esp = name.startswith("esp32") and not name.endswith("-bare")  # esp32s3-bare: no ESP-IDF
        # bare metal: newlib/picolibc need the clock workaround, custom transport, rcutils' atomics;
        # ESP-IDF: its newlib declares the clock, UDP is the default, IDF defines __atomic_*_8
        assert p.micro_ros.declare_clock_gettime is not esp, name
        assert ("CLOCK_MONOTONIC=0" in p.micro_ros.defines) is not esp, name
        assert p.transport == ("udp" if esp else "custom"), name
        assert p.native_64bit_atomics is esp, name
        assert bool(p.idf_target) is esp and bool(p.compiler_search) is esp, name


def test_soft_float_and_single_precision_facts() -> None:
    for name in ("cortex-m0plus", "rp2040", "cortex-m3", "cortex-m4"):
        assert "Tag_FP_arch" in find_profile(name).elf.attributes_absent
    assert find_profile("cortex-m7").elf.attributes_absent == ("Tag_ABI_HardFP_use",)
    assert find_profile("esp8266").elf.xtensa_abi == "1"
    assert find_profile("esp32s3").elf.xtensa_abi == "0"
    assert find_profile("rv32imc").elf.header_flags == ("RVC", "soft-float ABI")
    assert find_profile("rv32imc").libc_flags == ("--specs=picolibc.specs",)


# The RISC-V chips' ISA facts: (-mabi, float ABI in e_flags, ISA letters Tag_RISCV_arch must hold,
# and must not), from the ESP-IDF toolchain files and readelf over Debian's GCC 12.2 objects.
RISCV_FACTS = {
    "rv32imc": ("ilp32", "soft-float ABI", "imc", "af"),
    "esp32c3": ("ilp32", "soft-float ABI", "imc", "af"),
    "rv32imac": ("ilp32", "soft-float ABI", "imac", "f"),
    "esp32c6": ("ilp32", "soft-float ABI", "imac", "f"),
    "esp32h2": ("ilp32", "soft-float ABI", "imac", "f"),
    "rv32imafc": ("ilp32f", "single-float ABI", "imafc", "d"),
    "esp32p4": ("ilp32f", "single-float ABI", "imafc", "d"),
}


def _arch_tag(letters: str, extra: str = "_zicsr2p0_zifencei2p0_zmmul1p0") -> str:
    versions = {"i": "2p1", "m": "2p0", "a": "2p1", "f": "2p2", "d": "2p2", "c": "2p0"}
    return "rv32" + "_".join(f"{c}{versions[c]}" for c in letters) + extra


@pytest.mark.parametrize("name", sorted(RISCV_FACTS))
def test_riscv_chips_abi_facts(name: str) -> None:
    mabi, float_abi, has, lacks = RISCV_FACTS[name]
    p = find_profile(name)
    assert riscv_mabi(p.cpu_flags) == mabi and RISCV_FLOAT_ABI[mabi] == float_abi
    assert p.elf.header_flags == ("RVC", float_abi)
    pattern = dict(p.elf.attribute_patterns)["Tag_RISCV_arch"]
    # what Debian's riscv64-unknown-elf-gcc 12.2 writes for the ISA passes; one letter more or less fails
    assert re.fullmatch(pattern, _arch_tag(has)), name
    for extra in lacks:
        more = "".join(sorted(has + extra, key="imafdc".index))
        assert not re.fullmatch(pattern, _arch_tag(more)), (name, more)
    assert not re.fullmatch(pattern, _arch_tag(has.replace("c", ""))), name
    # the ESP-IDF chips: UDP over lwIP, IDF's own atomics (none of 1/2/4 bytes where "A" inlines them)
    if p.idf_target:
        assert p.idf_target == name and p.transport == "udp"
        assert p.missing_atomics == (() if "a" not in has else ("1", "2", "4"))


def test_the_p4_pattern_lets_espressifs_pie_extension_through() -> None:
    # ESP-IDF >= 5.3 compiles the P4 with -march=rv32imafc_zicsr_zifencei_xesppie
    pattern = dict(find_profile("esp32p4").elf.attribute_patterns)["Tag_RISCV_arch"]
    assert re.fullmatch(pattern, _arch_tag("imafc", "_zicsr2p0_zifencei2p0_zmmul1p0_xesppie1p0"))


def test_a_riscv_profile_whose_mabi_and_float_abi_disagree_is_refused(tmp_path: Path) -> None:
    text = (resources.toolchains_dir() / "esp32p4.yaml").read_text(encoding="utf-8")
    path = tmp_path / "p4.yaml"
    path.write_text(text.replace("-mabi=ilp32f]", "-mabi=ilp32]"), encoding="utf-8")
    with pytest.raises(
        ConfigError,
        match=r"p4.yaml: elf.header_flags: says 'single-float ABI', but cpu_flags' -mabi=ilp32 makes "
        r"objects with 'soft-float ABI'",
    ) as info:
        load_profile_file(path)
    assert info.value.hint == "write header_flags: [RVC, soft-float ABI] (or change -mabi)"
    path.write_text(text.replace("-mabi=ilp32f]", "-mabi=ilp32x]"), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"cpu_flags: -mabi=ilp32x is not a RISC-V ABI GCC knows"):
        load_profile_file(path)


def test_riscv_float_abi_from_readelf_flags() -> None:
    assert riscv_float_abi("0x3, RVC, single-float ABI") == "single-float ABI"
    assert riscv_float_abi("0x1, RVC, soft-float ABI") == "soft-float ABI"
    assert riscv_float_abi("0x5, RVC, double-float ABI") == "double-float ABI"
    assert riscv_float_abi("0x300") is None
    assert riscv_mabi(("-march=rv32imafc", "-mabi=ilp32", "-mabi=ilp32f")) == "ilp32f"
    assert riscv_mabi(("-mlongcalls",)) is None


def test_derive_from_a_target_keeps_flags_as_words() -> None:
    flag = '-DBOARD_NAME="my board;1"'
    p = derive_profile(find_profile("cortex-m4f"), None, (flag, "-DX=1"))
    assert p.name == "cortex-m4f-custom" and p.compiler_prefix == "arm-none-eabi-"
    assert p.c_flags[-2:] == (flag, "-DX=1") and p.cxx_flags[-2:] == (flag, "-DX=1")
    assert p.elf == find_profile("cortex-m4f").elf and p.source == "command line"
    other = derive_profile(find_profile("cortex-m4f"), "/opt/gcc-arm/bin/arm-none-eabi-", ())
    assert other.tool("gcc") == "/opt/gcc-arm/bin/arm-none-eabi-gcc"


def test_derive_standalone_from_the_prefix() -> None:
    p = derive_profile(None, "riscv64-unknown-elf-", ("-march=rv32imac", "-mabi=ilp32"))
    assert p.name == "custom-riscv64-unknown-elf" and p.system_processor == "riscv"
    # the derived name is an identifier too
    assert derive_profile(None, "/opt/x/arm-Vendor+x-eabi-", ()).name == "custom-arm-vendor-x-eabi"
    assert p.cpu_flags == ("-march=rv32imac", "-mabi=ilp32") and p.elf.machine == "RISC-V"
    with pytest.raises(ConfigError, match="cannot tell the architecture"):
        derive_profile(None, "avr-", ())
    with pytest.raises(ConfigError, match="--cflags without a target"):
        derive_profile(None, None, ("-O2",))
    with pytest.raises(ConfigError, match="command line: c_flags: '' is not a single compiler flag"):
        derive_profile(find_profile("cortex-m7"), None, ("",))


def test_defines_that_are_defines_load(tmp_path: Path) -> None:
    good = ["USE_FOO", "FOO_SIZE=4", 'NAME="a b"', "__attribute__(x)=", "EMPTY=", "F(a, b)=a+b"]
    p = load_profile_file(
        _write(tmp_path, {**minimal_profile(), "defines": good, "c_standard": 17, "optimization": "-O2"})
    )
    assert p.defines == tuple(good) and p.c_standard == 17 and p.optimization == "-O2"
