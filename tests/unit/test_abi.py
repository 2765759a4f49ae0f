"""The ABI check's pure parts, over real readelf output (tests/unit/data, Debian binutils 2.40).

readelf-mixed.txt: `readelf --file-header --arch-specific --string-dump=.xtensa.info --syms --wide`
of an archive holding an M4F object (fpv4-sp-d16 hard), an rv32imc one, an lx106 one and an lx106
object that defines __atomic_load_8; stderr merged, as the runner does.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from uros_build.errors import VerifyError
from uros_build.target import abi
from uros_build.target.profiles import ElfFacts, find_profile, shipped_profiles

DATA = Path(__file__).parent / "data"


def _objects(name: str) -> list[abi.ObjectFacts]:
    return abi.parse_readelf(
        (DATA / name).read_text(encoding="utf-8").splitlines(), name.replace(".txt", ".a")
    )


def test_parse_archive_of_three_architectures() -> None:
    arm, rv, xt, at = _objects("readelf-mixed.txt")
    assert [o.member for o in (arm, rv, xt, at)] == ["arm.o", "rv.o", "x.o", "at.o"]
    assert (arm.machine, arm.elf_class, arm.flags) == ("ARM", "ELF32", "0x5000000, Version5 EABI")
    attrs = dict(arm.attributes)
    assert attrs["Tag_FP_arch"] == "VFPv4-D16" and attrs["Tag_ABI_HardFP_use"] == "SP only"
    assert attrs["Tag_CPU_name"] == "7E-M"  # quotes stripped
    assert arm.xtensa_abi is None and arm.defined_symbols == ()  # U __atomic_load_8 is not defined
    assert rv.machine == "RISC-V" and rv.flags == "0x1, RVC, soft-float ABI"
    assert dict(rv.attributes)["Tag_RISCV_arch"] == "rv32i2p1_m2p0_c2p0_zmmul1p0"
    assert xt.machine == "Tensilica Xtensa Processor" and xt.attributes == () and xt.xtensa_abi == "1"
    assert at.defined_symbols == ("__atomic_load_8",)


def test_single_object_has_no_file_line() -> None:
    (obj,) = _objects("readelf-single-object.txt")
    assert obj.member == "readelf-single-object.a" and obj.machine == "ARM"
    assert abi.differences(obj, find_profile("cortex-m4f")) == []


def test_m4f_object_against_cortex_m7_names_fpu_and_sp_only() -> None:
    arm = _objects("readelf-mixed.txt")[0]
    assert abi.differences(arm, find_profile("cortex-m4f")) == []
    assert abi.differences(arm, find_profile("cortex-m7")) == [
        "Tag_FP_arch is VFPv4-D16, cortex-m7 expects FPv5/FP-D16 for ARMv8",
        "Tag_ABI_HardFP_use is SP only, cortex-m7 expects none",
    ]
    assert "Tag_FP_arch is VFPv4-D16, cortex-m4 expects none" in abi.differences(
        arm, find_profile("cortex-m4")
    )


def test_double_precision_fpu_object_fails_cortex_m4f() -> None:
    # -mfpu=vfpv3-d16 -mfloat-abi=hard (micro_ros_arduino's cortex_m4 recipe): no "SP only" tag
    arm = _objects("readelf-mixed.txt")[0]
    attrs = {**dict(arm.attributes), "Tag_FP_arch": "VFPv3-D16"}
    del attrs["Tag_ABI_HardFP_use"]
    dp = replace(arm, attributes=tuple(attrs.items()))
    assert abi.differences(dp, find_profile("cortex-m4f")) == [
        "Tag_ABI_HardFP_use is absent, cortex-m4f expects SP only",
        "Tag_FP_arch is VFPv3-D16, cortex-m4f expects VFPv4-D16",
    ]


def test_other_architectures_are_named_by_machine() -> None:
    _, rv, xt, _ = _objects("readelf-mixed.txt")
    assert abi.differences(rv, find_profile("cortex-m4f")) == ["Machine is RISC-V, cortex-m4f expects ARM"]
    assert abi.differences(xt, find_profile("rv32imc")) == [
        "Machine is Tensilica Xtensa Processor, rv32imc expects RISC-V"
    ]
    assert abi.differences(rv, find_profile("rv32imc")) == []
    assert abi.differences(rv, find_profile("esp32c3")) == []
    assert abi.differences(xt, find_profile("esp8266")) == []


def test_riscv_arch_pattern_and_float_abi() -> None:
    rv = _objects("readelf-mixed.txt")[1]
    with_a = replace(rv, attributes=(("Tag_RISCV_arch", "rv32i2p1_m2p0_a2p1_c2p0_zmmul1p0"),))
    assert (
        "Tag_RISCV_arch is rv32i2p1_m2p0_a2p1_c2p0_zmmul1p0"
        in abi.differences(with_a, find_profile("rv32imc"))[0]
    )
    single = replace(rv, flags="0x3, RVC, single-float ABI")
    assert abi.differences(single, find_profile("rv32imc")) == [
        "Flags are '0x3, RVC, single-float ABI', rv32imc expects 'soft-float ABI' "
        "(objects built with -mabi=ilp32f, ilp32 expected)"
    ]


def test_ilp32f_objects_for_the_p4_and_ilp32_ones_are_told_apart() -> None:
    rv = _objects("readelf-mixed.txt")[1]
    # what Debian's riscv64-unknown-elf-gcc 12.2 writes with -march=rv32imafc -mabi=ilp32f
    p4 = replace(
        rv,
        flags="0x3, RVC, single-float ABI",
        attributes=(("Tag_RISCV_arch", "rv32i2p1_m2p0_a2p1_f2p2_c2p0_zicsr2p0_zifencei2p0_zmmul1p0"),),
    )
    assert abi.differences(p4, find_profile("esp32p4")) == []
    assert abi.differences(p4, find_profile("rv32imafc")) == []
    # the same ISA with the soft-float ABI (-mabi=ilp32): floats in integer registers
    soft = replace(p4, flags="0x1, RVC, soft-float ABI")
    assert abi.differences(soft, find_profile("esp32p4")) == [
        "Flags are '0x1, RVC, soft-float ABI', esp32p4 expects 'single-float ABI' "
        "(objects built with -mabi=ilp32, ilp32f expected)"
    ]
    # an ESP32-C6 (rv32imac) library is not a P4 one, nor the other way round
    c6 = replace(soft, attributes=(("Tag_RISCV_arch", "rv32i2p1_m2p0_a2p1_c2p0_zicsr2p0_zmmul1p0"),))
    assert abi.differences(c6, find_profile("esp32c6")) == []
    assert len(abi.differences(c6, find_profile("esp32p4"))) == 2
    assert "Tag_RISCV_arch is rv32i2p1_m2p0_a2p1_f2p2" in abi.differences(p4, find_profile("esp32c6"))[1]
    # the C6, the H2 and the bare-metal rv32imac show the same ELF facts: the check says so
    names = sorted(shipped_profiles())
    alike = abi.look_alikes(find_profile("esp32c6"), [find_profile(n) for n in names])
    assert alike == ["esp32h2", "rv32imac"]


def test_xtensa_call0_object_fails_windowed_esp32s3() -> None:
    xt = _objects("readelf-mixed.txt")[2]
    assert abi.differences(xt, find_profile("esp32s3")) == [
        ".xtensa.info ABI=1 (call0), esp32s3 expects ABI=0 (windowed)"
    ]


def test_esp_targets_refuse_their_own_64bit_atomics() -> None:
    at = _objects("readelf-mixed.txt")[3]
    esp = replace(find_profile("esp32s3"), elf=ElfFacts(machine="Tensilica Xtensa", xtensa_abi="1"))
    (found,) = abi.differences(at, esp)
    assert found.startswith("defines __atomic_load_8, which esp32s3's platform defines too")
    assert abi.differences(at, find_profile("esp8266")) == []  # bare metal needs rcutils' copies
    assert abi.readelf_argv(Path("l.a"), esp.elf, symbols=True)[-3:] == ["--syms", "--wide", "l.a"]


def test_verify_names_the_first_object_and_summarises() -> None:
    objects = _objects("readelf-mixed.txt")
    with pytest.raises(VerifyError, match=r"^readelf-mixed.a\(rv.o\): Machine is RISC-V, cortex-m4f"):
        abi.verify(objects, find_profile("cortex-m4f"), "readelf-mixed.a")
    summary = abi.verify(objects[:1], find_profile("cortex-m4f"), "l.a")
    assert summary["result"] == "pass" and summary["objects"] == 1
    assert summary["expects"]["attributes"]["Tag_FP_arch"] == "VFPv4-D16"
    assert abi.describe(summary).startswith("all 1 objects match cortex-m4f (ARM ELF32, ")
    with pytest.raises(VerifyError, match="holds no objects"):
        abi.verify([], find_profile("cortex-m4f"), "empty.a")


def test_readelf_argv_reads_xtensa_info_only_where_expected() -> None:
    assert abi.readelf_argv(Path("l.a"), find_profile("cortex-m7").elf, symbols=False) == [
        "readelf",
        "--file-header",
        "--arch-specific",
        "l.a",
    ]
    assert "--string-dump=.xtensa.info" in abi.readelf_argv(Path("l.a"), find_profile("esp8266").elf, False)


# readelf-esp-chips.txt: the same C file (a 4-byte __atomic_exchange_n and a 1-byte
# __atomic_fetch_add) compiled with Debian's xtensa-lx106-elf-gcc 12.2 -mabi=windowed and binutils
# 2.40 with each chip's core plugin (XTENSA_GNU_CONFIG=xtensa_esp32.so / _esp32s2 / _esp32s3, built
# from espressif/xtensa-dynconfig + xtensa-overlays), archived as esp32.o, esp32s2.o, esp32s3.o:
# `readelf --file-header --arch-specific --string-dump=.xtensa.info --syms --wide chips.a`. The three
# objects were byte-identical (same md5); lx106's cc1 emits libcalls for the atomics.


def test_esp32_family_objects_are_identical_in_every_elf_fact() -> None:
    objects = _objects("readelf-esp-chips.txt")
    assert [o.member for o in objects] == ["esp32.o", "esp32s2.o", "esp32s3.o"]
    facts = {replace(o, member="") for o in objects}
    assert len(facts) == 1
    (one,) = facts
    assert one.xtensa_abi == "0" and one.flags == "0x300"
    assert one.xtensa_info == (("USE_ABSOLUTE_LITERALS", "0"), ("ABI", "0"))
    assert one.undefined_atomics == ("__atomic_exchange_4", "__atomic_fetch_add_1")
    for chip in ("esp32", "esp32s2", "esp32s3"):
        assert all(abi.differences(o, find_profile(chip)) == [] for o in objects)


def test_check_says_when_targets_cannot_be_told_apart() -> None:
    objects = _objects("readelf-esp-chips.txt")
    summary = abi.verify(objects, find_profile("esp32s3"), "chips.a")
    # esp32s3-bare: the same core without ESP-IDF (the probe's bare-metal twin)
    assert summary["same_elf_facts_as"] == ["esp32", "esp32s2", "esp32s3-bare"]
    assert abi.describe(summary) == (
        "all 3 objects show the ELF facts of esp32s3 (Tensilica Xtensa ELF32, .xtensa.info ABI=0 (windowed)); "
        "the ELF facts of esp32, esp32s2, esp32s3 and esp32s3-bare are identical, so this does not tell which of them "
        "the objects were built for"
    )
    # a target with facts of its own still says "match"
    assert abi.describe(
        abi.verify(_objects("readelf-single-object.txt"), find_profile("cortex-m4f"), "l.a")
    ).startswith("all 1 objects match cortex-m4f")


def test_look_alikes_among_the_shipped_targets() -> None:
    from uros_build.target.profiles import shipped_profiles

    profiles = list(shipped_profiles().values())
    assert abi.look_alikes(find_profile("esp32"), profiles) == ["esp32s2", "esp32s3", "esp32s3-bare"]
    assert abi.look_alikes(find_profile("esp8266"), profiles) == []
    assert abi.look_alikes(find_profile("cortex-m7"), profiles) == []


def test_esp32s3_names_undefined_small_atomics_as_a_warning() -> None:
    objects = _objects("readelf-esp-chips.txt")
    summary = abi.verify(objects, find_profile("esp32s3"), "chips.a")
    assert summary["result"] == "pass"  # a warning: Espressif's compiler inlines them, another may not
    assert summary["undefined_atomics"] == {
        "__atomic_exchange_4": ["esp32.o", "esp32s2.o", "esp32s3.o"],
        "__atomic_fetch_add_1": ["esp32.o", "esp32s2.o", "esp32s3.o"],
    }
    first = summary["warnings"][0]
    assert first.startswith(
        "chips.a needs __atomic_exchange_4 (esp32.o, esp32s2.o, esp32s3.o), which esp32s3's platform does not define"
    )
    assert "the firmware must define it" in first
    # ESP-IDF defines them for the ESP32-S2 (no S32C1I): nothing to say
    assert "warnings" not in abi.verify(objects, find_profile("esp32s2"), "chips.a")
    assert abi.reads_symbols(find_profile("esp32s3")) and not abi.reads_symbols(find_profile("esp8266"))


def test_many_objects_are_shortened_in_the_warning() -> None:
    (obj,) = _objects("readelf-esp-chips.txt")[:1]
    objects = [replace(obj, member=f"o{i}.o") for i in range(5)]
    warning = abi.verify(objects, find_profile("esp32"), "l.a")["warnings"][0]
    assert "(o0.o, o1.o, o2.o and 2 more)" in warning


def test_xtensa_code_tells_espressif_core_code_from_the_lx106_stand_in() -> None:
    # objdump -dr of abi.XTENSA_CODE_PROBE compiled -O2 -mlongcalls with the ESP32-S3 core plugin by
    # Debian 13's gcc-xtensa-lx106 13.3 (reads XTENSA_GNU_CONFIG) and by Debian 12's 12.2 (-mabi=windowed)
    real = (DATA / "objdump-esp32s3-debian13.txt").read_text(encoding="utf-8")
    assert abi.xtensa_code(real) == (
        "makes Espressif-core code: windowed ABI, FPU (madd.s), DIV32 (quos), S32C1I (s32c1i) inline"
    )
    stand_in = (DATA / "objdump-esp32s3-lx106-gcc12.txt").read_text(encoding="utf-8")
    assert abi.xtensa_code(stand_in).startswith(
        "makes lx106-class code (windowed ABI): float, divide and atomics are calls "
        "(__mulsf3, __divsi3, __atomic_exchange_4), a stand-in"
    )
    # an ESP32-S2-like core: no FPU, the rest inline
    no_fpu = real.replace("madd.s", "nop").replace("wfr", "nop") + "\n\tR_XTENSA_32\t__mulsf3\n"
    assert abi.xtensa_code(no_fpu) == (
        "makes code with DIV32 (quos), S32C1I (s32c1i) (windowed ABI), calls __mulsf3 (a core without them)"
    )


@pytest.mark.parametrize(
    ("chip", "words"),
    [
        # the ESP32-C3: no "A" and no F: ESP-IDF's newlib defines __atomic_exchange_4 there (stdatomic.c)
        (
            "esp32c3",
            "makes RV32 code: M (div) inline; calls __mulsf3, __atomic_exchange_4; soft-float ABI (ilp32)",
        ),
        ("esp32c6", "makes RV32 code: M (div), A (amoswap.w) inline; calls __mulsf3; soft-float ABI (ilp32)"),
        ("esp32p4", "makes RV32 code: F (fmadd.s), M (div), A (amoswap.w) inline; single-float ABI (ilp32f)"),
    ],
)
def test_riscv_code_says_what_the_compiler_makes_for_each_chip(chip: str, words: str) -> None:
    # objdump -dr + readelf -h of abi.XTENSA_CODE_PROBE compiled -O2 with the chip's cpu_flags by Debian's
    # riscv64-unknown-elf-gcc 12.2 (what `uros doctor --toolchain <chip>` prints)
    text = (DATA / f"code-{chip}-riscv64-gcc12.txt").read_text(encoding="utf-8")
    assert abi.riscv_code(text, text) == words
    assert abi.riscv_code("", "").endswith("float ABI unknown")
