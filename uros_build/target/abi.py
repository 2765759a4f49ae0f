"""The ABI check: every object in a library must show the ELF facts of the target profile.

GNU ld links objects built for the wrong core or FPU without a word: an M4F firmware with a
library built for a double-precision FPU (vmul.f64 faults on the M4F), an M0+ firmware with
ARMv7E-M code, an M4F firmware with a Cortex-M7 library; only a VFP-argument mismatch is an
error. Tools that ship libmicroros.a did exactly that (a Cortex-M4 library with -mfpu=vfpv3-d16,
a stale Xtensa library linked into a RISC-V build). So uros reads each object's ELF header,
build attributes and, for Xtensa, the .xtensa.info ABI line, and compares them with the profile.

The host's GNU readelf decodes ARM, RISC-V and Xtensa objects alike and walks a whole archive in
one run (``File: lib.a(member)`` per object), so one process reads the whole library. Parsing and
comparing are pure functions over readelf's text; only :func:`check_library` runs a command.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uros_build.errors import VerifyError
from uros_build.proc import Runner
from uros_build.target.profiles import (
    RISCV_FLOAT_ABI,
    ElfFacts,
    TargetProfile,
    riscv_float_abi,
    shipped_profiles,
)

READELF = "readelf"
READELF_HINT = "install GNU binutils (it reads every target's objects): apt-get install binutils"

# What rcutils' atomic_64bits.c defines (RCUTILS_NO_64_ATOMIC=ON). Where the platform defines
# them too (ESP-IDF's newlib), the firmware link fails with "multiple definition".
ATOMIC_64_SYMBOLS = re.compile(r"__atomic_(load|store|exchange|fetch_add|compare_exchange)_8")
# The library routines GCC calls for atomics it does not inline (__atomic_* and the legacy __sync_*),
# by operand size. ESP-IDF defines the 1/2/4-byte ones only for chips without S32C1I
# (components/newlib/stdatomic.c: `#if !HAS_ATOMICS_32`): on an ESP32 or ESP32-S3 it expects the
# compiler to inline them, so an undefined one fails the firmware link.
ATOMIC_ROUTINE = re.compile(r"__(?:atomic|sync)_\w+_(?P<size>1|2|4|8|16)")

_FILE_LINE = re.compile(r"^File: (?P<archive>.*)\((?P<member>[^()]*)\)$")
_HEADER_LINE = re.compile(r"^\s+(Class|Machine|Flags):\s+(.*)$")
_ATTRIBUTE_LINE = re.compile(r"^\s+(Tag_\w+): (.*)$")
_XTENSA_ABI = re.compile(r"\bABI=(\d+)")
# .xtensa.info's lines as readelf --string-dump shows them: "USE_ABSOLUTE_LITERALS=0\n", "ABI=0\n"
_XTENSA_INFO_ITEM = re.compile(r"\b([A-Z_]+)=(\w+)\\n")
# readelf -s --wide: "  12: 00000000    40 FUNC    GLOBAL DEFAULT    5 name"
_SYMBOL_LINE = re.compile(r"^\s*\d+:\s+\S+\s+\d+\s+\S+\s+(GLOBAL|WEAK)\s+\S+\s+(\S+)\s+(\S+)")


@dataclass(frozen=True)
class ObjectFacts:
    """What readelf says about one object."""

    member: str
    elf_class: str = ""
    machine: str = ""
    flags: str = ""
    attributes: tuple[tuple[str, str], ...] = ()
    xtensa_abi: str | None = None
    defined_symbols: tuple[str, ...] = ()  # only the defined globals the check looks for
    undefined_atomics: tuple[str, ...] = ()  # undefined __atomic_*/__sync_* routines
    xtensa_info: tuple[tuple[str, str], ...] = ()  # every KEY=VALUE of .xtensa.info


@dataclass
class _Collector:
    member: str
    values: dict[str, str] = field(default_factory=dict)
    attributes: dict[str, str] = field(default_factory=dict)
    xtensa_abi: str | None = None
    symbols: list[str] = field(default_factory=list)
    undefined: list[str] = field(default_factory=list)
    xtensa_info: dict[str, str] = field(default_factory=dict)
    in_xtensa_info: bool = False

    def done(self) -> ObjectFacts:
        return ObjectFacts(
            member=self.member,
            elf_class=self.values.get("Class", ""),
            machine=self.values.get("Machine", ""),
            flags=self.values.get("Flags", ""),
            attributes=tuple(self.attributes.items()),
            xtensa_abi=self.xtensa_abi,
            defined_symbols=tuple(self.symbols),
            undefined_atomics=tuple(self.undefined),
            xtensa_info=tuple(self.xtensa_info.items()),
        )


def reads_symbols(profile: TargetProfile) -> bool:
    """The symbol tables are read where the check looks at symbols (atomics)."""
    return profile.native_64bit_atomics or bool(profile.missing_atomics)


def readelf_argv(library: Path, facts: ElfFacts, symbols: bool) -> list[str]:
    """One readelf run over the whole archive; the .xtensa.info dump and the symbol tables only
    where the profile asks (readelf warns on stderr for every object lacking the section)."""
    argv = [READELF, "--file-header", "--arch-specific"]
    if facts.xtensa_abi:
        argv += ["--string-dump=.xtensa.info"]
    if symbols:
        argv += ["--syms", "--wide"]
    return [*argv, str(library)]


def _unquote(value: str) -> str:
    value = value.strip()
    return value[1:-1] if len(value) >= 2 and value[0] == value[-1] == '"' else value


def parse_readelf(lines: Sequence[str], name: str) -> list[ObjectFacts]:
    """readelf output for an archive (or one object, which has no ``File:`` line) -> facts."""
    objects: list[ObjectFacts] = []
    current: _Collector | None = None
    for line in lines:
        file_match = _FILE_LINE.match(line)
        if file_match:
            if current is not None:
                objects.append(current.done())
            current = _Collector(file_match["member"])
            continue
        if line.startswith("readelf: Warning:") or not line.strip():
            continue
        if current is None:
            current = _Collector(name)
        header = _HEADER_LINE.match(line)
        attribute = _ATTRIBUTE_LINE.match(line)
        if not line.startswith(" "):  # a new part of readelf's output ends the string dump
            current.in_xtensa_info = False
        if line.startswith("String dump of section '.xtensa.info'"):
            current.in_xtensa_info = True
        elif current.in_xtensa_info and _XTENSA_INFO_ITEM.search(line):
            current.xtensa_info.update(_XTENSA_INFO_ITEM.findall(line))
            abi = _XTENSA_ABI.search(line)
            if abi:
                current.xtensa_abi = abi[1]
        elif header and header[1] not in current.values:
            current.values[header[1]] = header[2].strip()
        elif attribute:
            current.attributes[attribute[1]] = _unquote(attribute[2])
        else:
            symbol = _SYMBOL_LINE.match(line)
            if symbol and symbol[2] != "UND" and ATOMIC_64_SYMBOLS.fullmatch(symbol[3]):
                current.symbols.append(symbol[3])
            elif symbol and symbol[2] == "UND" and ATOMIC_ROUTINE.fullmatch(symbol[3]):
                current.undefined.append(symbol[3])
    if current is not None:
        objects.append(current.done())
    return objects


def differences(obj: ObjectFacts, profile: TargetProfile) -> list[str]:
    """What about ``obj`` differs from ``profile``'s ELF facts, as readable phrases (pure)."""
    want, target = profile.elf, profile.name
    if want.machine not in obj.machine:
        # Another architecture altogether: its attributes say nothing about this target.
        return [f"Machine is {obj.machine or '(not an ELF object)'}, {target} expects {want.machine}"]
    found: list[str] = []
    if obj.elf_class != want.elf_class:
        found.append(f"Class is {obj.elf_class}, {target} expects {want.elf_class}")
    for flag in want.header_flags:
        if flag not in obj.flags:
            found.append(f"Flags are '{obj.flags}', {target} expects '{flag}'{_mabi_note(obj.flags, flag)}")
    attrs = dict(obj.attributes)
    for tag, value in want.attributes:
        if attrs.get(tag) != value:
            found.append(f"{tag} is {attrs.get(tag, 'absent')}, {target} expects {value}")
    for tag, pattern in want.attribute_patterns:
        if not re.fullmatch(pattern, attrs.get(tag, "")):
            found.append(f"{tag} is {attrs.get(tag, 'absent')}, {target} expects one matching {pattern}")
    for tag in want.attributes_absent:
        if tag in attrs:
            found.append(f"{tag} is {attrs[tag]}, {target} expects none")
    if want.xtensa_abi and obj.xtensa_abi != want.xtensa_abi:
        names = {"0": "windowed", "1": "call0"}
        have = f"ABI={obj.xtensa_abi} ({names.get(obj.xtensa_abi, '?')})" if obj.xtensa_abi else "absent"
        found.append(
            f".xtensa.info {have}, {target} expects ABI={want.xtensa_abi} ({names[want.xtensa_abi]})"
        )
    if profile.native_64bit_atomics:
        for symbol in obj.defined_symbols:
            found.append(
                f"defines {symbol}, which {target}'s platform defines too "
                "(multiple definition at the firmware link: set rcutils' RCUTILS_NO_64_ATOMIC=OFF)"
            )
    return found


def _mabi_note(flags: str, wanted: str) -> str:
    """Where a RISC-V float ABI differs: which -mabi gives the objects' and which the target's
    (ilp32 vs ilp32f: floats in integer or in f registers; GNU ld refuses to link them together)."""
    mabis = {abi: name for name, abi in reversed(RISCV_FLOAT_ABI.items()) if name.startswith("ilp32")}
    have, want = riscv_float_abi(flags), riscv_float_abi(wanted)
    if have not in mabis or want not in mabis or have == want:
        return ""
    return f" (objects built with -mabi={mabis[have]}, {mabis[want]} expected)"


def expected_summary(facts: ElfFacts) -> dict[str, Any]:
    summary: dict[str, Any] = {"machine": facts.machine, "class": facts.elf_class}
    if facts.header_flags:
        summary["flags"] = list(facts.header_flags)
    if facts.attributes:
        summary["attributes"] = dict(facts.attributes)
    if facts.attribute_patterns:
        summary["attribute_patterns"] = dict(facts.attribute_patterns)
    if facts.attributes_absent:
        summary["attributes_absent"] = list(facts.attributes_absent)
    if facts.xtensa_abi:
        summary["xtensa_abi"] = facts.xtensa_abi
    return summary


def look_alikes(profile: TargetProfile, profiles: Sequence[TargetProfile]) -> list[str]:
    """The other targets whose ELF facts are the same as ``profile``'s: objects that pass the check
    for one of them pass it for all, so the check cannot say which one they were built for.
    ESP32, ESP32-S2 and ESP32-S3 objects are such a set: built from the same source with each
    chip's Xtensa core description (binutils' XTENSA_GNU_CONFIG plugin), they are byte-identical,
    .xtensa.info included; only instructions a chip lacks could tell them apart (docs/esp32.md)."""
    return sorted(p.name for p in profiles if p.name != profile.name and p.elf == profile.elf)


def undefined_atomics(objects: Sequence[ObjectFacts], profile: TargetProfile) -> dict[str, list[str]]:
    """Undefined __atomic_*/__sync_* routines of the sizes the platform defines none of ->
    the objects that need them (pure)."""
    missing = set(profile.missing_atomics)
    needs: dict[str, list[str]] = {}
    for obj in objects:
        for symbol in obj.undefined_atomics:
            match = ATOMIC_ROUTINE.fullmatch(symbol)
            if match and match["size"] in missing:
                needs.setdefault(symbol, []).append(obj.member)
    return dict(sorted(needs.items()))


def _atomic_warnings(needs: dict[str, list[str]], profile: TargetProfile, library: str) -> list[str]:
    out = []
    for symbol, members in needs.items():
        shown = ", ".join(members[:3]) + (f" and {len(members) - 3} more" if len(members) > 3 else "")
        out.append(
            f"{library} needs {symbol} ({shown}), which {profile.name}'s platform does not define "
            f"({'/'.join(profile.missing_atomics)}-byte atomics are expected inline): the firmware must "
            "define it, or build with a compiler that inlines atomics for this chip (docs/esp32.md)"
        )
    return out


def verify(
    objects: Sequence[ObjectFacts],
    profile: TargetProfile,
    library: str,
    profiles: Sequence[TargetProfile] | None = None,
) -> dict[str, Any]:
    """Raise VerifyError naming the first object that does not match; else a summary (pure).
    ``profiles``: the targets to compare the ELF facts with (default: the shipped ones)."""
    if not objects:
        raise VerifyError(f"{library}: holds no objects to check", "is it an empty or a non-ELF archive?")
    for obj in objects:
        found = differences(obj, profile)
        if found:
            where = library if obj.member == library else f"{library}({obj.member})"
            raise VerifyError(
                f"{where}: {'; '.join(found)}",
                f"the library does not fit {profile.name}: rebuild it for this target "
                "(uros build --toolchain NAME), or check it for another (uros check --toolchain NAME)",
            )
    summary: dict[str, Any] = {
        "checked": True,
        "target": profile.name,
        "objects": len(objects),
        "expects": expected_summary(profile.elf),
        "result": "pass",
    }
    alike = look_alikes(profile, list(shipped_profiles().values()) if profiles is None else profiles)
    if alike:
        summary["same_elf_facts_as"] = alike
    needs = undefined_atomics(objects, profile)
    if needs:
        summary["undefined_atomics"] = needs
        summary["warnings"] = _atomic_warnings(needs, profile, library)
    return summary


# What a windowed-ABI Xtensa compiler makes of plain C tells an Espressif core's code from lx106's: the
# ESP32/ESP32-S3 have an FPU (madd.s, wfr), DIV32 (quos) and S32C1I; Debian 12's lx106 cc1 (the stand-in
# of tests/esp32s3-compat-env.sh) calls library routines for all three. `uros doctor` compiles this
# (for the RISC-V chips too: riscv_code below).
XTENSA_CODE_PROBE = """float uros_fma(float a, float b, float c) { return a * b + c; }
int uros_div(int a, int b) { return a / b; }
unsigned uros_word;
unsigned uros_swap(unsigned v) { return __atomic_exchange_n(&uros_word, v, __ATOMIC_SEQ_CST); }
"""
# objdump -d's instruction lines: "   1b:\td22230        \tquos\ta2, a2, a3" (literals have no mnemonic);
# RISC-V's have the same layout ("   0:\t60b57543          \tfmadd.s\tfa0,fa0,fa1,fa2")
XTENSA_MNEMONIC = re.compile(r"^[ \t]*[0-9a-f]+:[ \t]+[0-9a-f]+[ \t]+([a-z][a-z0-9.]*)", re.M)
# core option -> (an instruction that uses it, the routine called without it)
XTENSA_OPTIONS = (
    ("FPU", "madd.s", "__mulsf3"),
    ("DIV32", "quos", "__divsi3"),
    ("S32C1I", "s32c1i", "__atomic_exchange_4"),
)


def xtensa_code(disassembly: str) -> str:
    """What ``objdump -dr`` of XTENSA_CODE_PROBE's object shows, in words (pure)."""
    mnemonics = set(XTENSA_MNEMONIC.findall(disassembly))
    has = [f"{option} ({insn})" for option, insn, _ in XTENSA_OPTIONS if insn in mnemonics]
    calls = [r for _, insn, r in XTENSA_OPTIONS if insn not in mnemonics and r in disassembly]
    windowed = "entry" in mnemonics
    abi = "windowed ABI" if windowed else "call0 ABI"
    if has and not calls:
        return f"makes Espressif-core code: {abi}, {', '.join(has)} inline"
    if not has:
        return (
            f"makes lx106-class code ({abi}): float, divide and atomics are calls ({', '.join(calls)}), "
            "a stand-in, not Espressif's code generation (docs/esp32.md)"
        )
    return f"makes code with {', '.join(has)} ({abi}), calls {', '.join(calls)} (a core without them)"


# The same probe (XTENSA_CODE_PROBE) tells what a RISC-V compiler makes for an ESP32 chip's -march/-mabi: the
# P4's F extension (fmadd.s), M (div) and the C6/H2/P4's A (amoswap.w); without them, library calls
# (ESP-IDF's newlib defines the 1/2/4-byte __atomic_* routines on a chip without "A", the C3).
RISCV_OPTIONS = (
    ("F", "fmadd.s", "__mulsf3"),
    ("M", "div", "__divsi3"),
    ("A", "amoswap.w", "__atomic_exchange_4"),
)


def riscv_code(disassembly: str, header: str) -> str:
    """What ``objdump -dr`` and ``readelf -h`` of XTENSA_CODE_PROBE's object show, in words (pure)."""
    mnemonics = set(XTENSA_MNEMONIC.findall(disassembly))
    found = {
        insn for _, insn, _ in RISCV_OPTIONS if any(m == insn or m.startswith(insn + ".") for m in mnemonics)
    }
    has = [f"{option} ({insn})" for option, insn, _ in RISCV_OPTIONS if insn in found]
    calls = [r for _, insn, r in RISCV_OPTIONS if insn not in found and r in disassembly]
    found_abi = riscv_float_abi(header)
    # the RV32 -mabi that writes it (ilp32, ilp32f, ilp32d)
    mabi = next((m for m in ("ilp32", "ilp32f", "ilp32d") if RISCV_FLOAT_ABI[m] == found_abi), None)
    float_abi = f"{found_abi} ({mabi})" if found_abi else "float ABI unknown"
    words = f"makes RV32 code: {', '.join(has) or 'no F, M or A instruction'} inline"
    if calls:
        words += f"; calls {', '.join(calls)}"
    return f"{words}; {float_abi}"


def check_library(runner: Runner, library: Path, profile: TargetProfile) -> dict[str, Any]:
    """Read every object of ``library`` in one readelf run and verify it against ``profile``."""
    argv = readelf_argv(library, profile.elf, symbols=reads_symbols(profile))
    argv[0] = runner.which(READELF, READELF_HINT)
    lines = runner.query(argv, step=f"read the ELF facts of {library.name}").splitlines()
    return verify(parse_readelf(lines, library.name), profile, library.name)


def describe(summary: dict[str, Any]) -> str:
    """One line for the console: what was checked and what every object showed."""
    expects = summary["expects"]
    facts = [f"{expects['machine']} {expects['class']}"]
    facts += [f"{k}: {v}" for k, v in expects.get("attributes", {}).items()]
    facts += [f"{k} ~ {v}" for k, v in expects.get("attribute_patterns", {}).items()]
    facts += [f"no {k}" for k in expects.get("attributes_absent", [])]
    facts += [f"flags {f}" for f in expects.get("flags", [])]
    if "xtensa_abi" in expects:
        names = {"0": "windowed", "1": "call0"}
        facts.append(f".xtensa.info ABI={expects['xtensa_abi']} ({names.get(expects['xtensa_abi'], '?')})")
    alike = summary.get("same_elf_facts_as")
    if not alike:
        return f"all {summary['objects']} objects match {summary['target']} ({', '.join(facts)})"
    *rest, last = sorted([summary["target"], *alike])
    return (
        f"all {summary['objects']} objects show the ELF facts of {summary['target']} ({', '.join(facts)}); "
        f"the ELF facts of {', '.join(rest)} and {last} are identical, so this does not tell which of "
        "them the objects were built for"
    )
