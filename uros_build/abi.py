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
from uros_build.profiles import ElfFacts, TargetProfile

READELF = "readelf"
READELF_HINT = "install GNU binutils (it reads every target's objects): apt-get install binutils"

# What rcutils' atomic_64bits.c defines (RCUTILS_NO_64_ATOMIC=ON). Where the platform defines
# them too (ESP-IDF's newlib), the firmware link fails with "multiple definition".
ATOMIC_64_SYMBOLS = re.compile(r"__atomic_(load|store|exchange|fetch_add|compare_exchange)_8")

_FILE_LINE = re.compile(r"^File: (?P<archive>.*)\((?P<member>[^()]*)\)$")
_HEADER_LINE = re.compile(r"^\s+(Class|Machine|Flags):\s+(.*)$")
_ATTRIBUTE_LINE = re.compile(r"^\s+(Tag_\w+): (.*)$")
_XTENSA_ABI = re.compile(r"\bABI=(\d+)")
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


@dataclass
class _Collector:
    member: str
    values: dict[str, str] = field(default_factory=dict)
    attributes: dict[str, str] = field(default_factory=dict)
    xtensa_abi: str | None = None
    symbols: list[str] = field(default_factory=list)
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
        )


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
        if line.startswith("String dump of section '.xtensa.info'"):
            current.in_xtensa_info = True
        elif current.in_xtensa_info and _XTENSA_ABI.search(line):
            current.xtensa_abi = _XTENSA_ABI.search(line)[1]  # type: ignore[index]
            current.in_xtensa_info = False
        elif header and header[1] not in current.values:
            current.values[header[1]] = header[2].strip()
        elif attribute:
            current.attributes[attribute[1]] = _unquote(attribute[2])
        else:
            symbol = _SYMBOL_LINE.match(line)
            if symbol and symbol[2] != "UND" and ATOMIC_64_SYMBOLS.fullmatch(symbol[3]):
                current.symbols.append(symbol[3])
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
            found.append(f"Flags are '{obj.flags}', {target} expects '{flag}'")
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


def verify(objects: Sequence[ObjectFacts], profile: TargetProfile, library: str) -> dict[str, Any]:
    """Raise VerifyError naming the first object that does not match; else a summary (pure)."""
    if not objects:
        raise VerifyError(f"{library}: holds no objects to check", "is it an empty or a non-ELF archive?")
    for obj in objects:
        found = differences(obj, profile)
        if found:
            where = library if obj.member == library else f"{library}({obj.member})"
            raise VerifyError(
                f"{where}: {'; '.join(found)}",
                f"the library does not fit {profile.name}: rebuild it for this target "
                "(uros build --toolchain NAME), or check it against another one (uros check --target)",
            )
    return {
        "checked": True,
        "target": profile.name,
        "objects": len(objects),
        "expects": expected_summary(profile.elf),
        "result": "pass",
    }


def check_library(runner: Runner, library: Path, profile: TargetProfile) -> dict[str, Any]:
    """Read every object of ``library`` in one readelf run and verify it against ``profile``."""
    argv = readelf_argv(library, profile.elf, symbols=profile.native_64bit_atomics)
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
        facts.append(f".xtensa.info ABI={expects['xtensa_abi']}")
    return f"all {summary['objects']} objects match {summary['target']} ({', '.join(facts)})"
