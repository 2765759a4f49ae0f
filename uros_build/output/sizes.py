"""What micro-ROS costs, per package: in libmicroros.a (``size`` per member) and, with the
firmware's GNU ld map file, after linking and --gc-sections (pure: text in, numbers out).

The library's members are named ``<archive stem>__<member>`` by uros's merge (archive.py), so each
member leads back to the archive it came from and, through the packages' install manifests, to its
package. The map file lists every input section the linker kept, with its size and the object it
came from (``libmicroros.a(member)``); sections --gc-sections dropped are listed apart, under
"Discarded input sections", and are not counted.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import PurePosixPath

KINDS = ("text", "data", "bss")


@dataclass(frozen=True)
class Sizes:
    text: int = 0
    data: int = 0
    bss: int = 0

    def __add__(self, other: Sizes) -> Sizes:
        return Sizes(self.text + other.text, self.data + other.data, self.bss + other.bss)

    @property
    def total(self) -> int:
        return self.text + self.data + self.bss

    def as_dict(self) -> dict[str, int]:
        return {"text": self.text, "data": self.data, "bss": self.bss}


# -- size (Berkeley format) of an archive --------------------------------------------------------


def parse_berkeley(text: str) -> dict[str, Sizes]:
    """member -> its sizes, from ``size <archive>`` (GNU size's default Berkeley format:
    ``text data bss dec hex filename``, where filename is ``member (ex archive)``)."""
    out: dict[str, Sizes] = {}
    for line in text.splitlines():
        parts = line.split(None, 5)
        if len(parts) < 6 or not all(p.isdigit() for p in parts[:4]):
            continue
        name = parts[5].rsplit(" (ex ", 1)[0]
        out[name] = out.get(name, Sizes()) + Sizes(int(parts[0]), int(parts[1]), int(parts[2]))
    return out


# -- a GNU ld map file ---------------------------------------------------------------------------

# Input sections by the name the compiler gave them (linker scripts name output sections as they
# like: .isr_vector, .ARM, ._user_heap_stack). Sections not listed (.comment, .ARM.attributes,
# .debug_*) take no room on the target.
_INPUT_KIND = (
    ("text", (".text", ".rodata", ".srodata", ".literal", ".ARM.extab", ".ARM.exidx", ".eh_frame",
              ".gcc_except_table", ".init", ".fini", ".glue_7", ".glue_7t", ".vfp11_veneer", ".v4_bx",
              ".iram1", ".flash.text", ".flash.rodata")),
    ("data", (".data", ".sdata", ".tdata", ".init_array", ".fini_array", ".preinit_array", ".ctors",
              ".dtors", ".got", ".dram1")),
    ("bss", (".bss", ".sbss", ".tbss", "COMMON", ".noinit")),
)  # fmt: skip
_SECTION_LINE = re.compile(
    r"^ (?P<name>\S+)?\s+0x(?P<addr>[0-9a-fA-F]+)\s+0x(?P<size>[0-9a-fA-F]+)\s+(?P<file>\S.*)$"
)
_NAME_ONLY = re.compile(r"^ (?P<name>[.\w][^\s]*)$")
_MEMBER = re.compile(r"^(?P<archive>.+)\((?P<member>[^()]+)\)$")


def section_kind(name: str) -> str | None:
    for kind, prefixes in _INPUT_KIND:
        for prefix in prefixes:
            if name == prefix or name.startswith(prefix + "."):
                return kind
    return None


@dataclass(frozen=True)
class MapEntry:
    section: str
    size: int
    file: str  # the object file, or ``archive(member)``


def parse_map(text: str) -> list[MapEntry]:
    """Every input section the linker kept (size > 0), from a GNU ld ``-Map`` file. Long section
    names stand on a line of their own, their address, size and file on the next."""
    entries = []
    lines = text.splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.startswith("Linker script and memory map"))
    except StopIteration:
        return []
    pending = None
    for line in lines[start + 1 :]:
        named = _NAME_ONLY.match(line)
        if named is not None:
            pending = named.group("name")
            continue
        match = _SECTION_LINE.match(line)
        if match is None:
            pending = None
            continue
        name = match.group("name") or pending
        pending = None
        size = int(match.group("size"), 16)
        if name is None or name == "*fill*" or size == 0:
            continue
        entries.append(MapEntry(name, size, match.group("file").strip()))
    return entries


def linked_members(entries: Iterable[MapEntry], library: str) -> tuple[dict[str, Sizes], Sizes]:
    """(member of ``library`` -> what the firmware keeps of it, everything else the firmware has)."""
    members: dict[str, Sizes] = {}
    rest = Sizes()
    for entry in entries:
        kind = section_kind(entry.section)
        if kind is None:
            continue
        size = Sizes(**{kind: entry.size})
        match = _MEMBER.match(entry.file)
        if match is not None and PurePosixPath(match.group("archive")).name == library:
            members[match.group("member")] = members.get(match.group("member"), Sizes()) + size
        else:
            rest = rest + size
    return members, rest


# -- members -> archives -> packages -------------------------------------------------------------


def member_archive(member: str, archives: Iterable[str]) -> str | None:
    """The input archive (``libfx_core.a``) a merged member (``libfx_core__core.c.obj``) came
    from: the longest archive stem it starts with, followed by ``__``."""
    best = None
    for archive in archives:
        stem = archive[: -len(".a")] if archive.endswith(".a") else archive
        if member.startswith(stem + "__") and (best is None or len(stem) > len(best[0])):
            best = (stem, archive)
    return best[1] if best else None


def archive_package(archive: str, packages: Iterable[str], installed_by: Mapping[str, str]) -> str:
    """The package that built ``archive``: from the packages' install manifests when known, else
    the longest package name its stem starts with (``libstd_msgs__rosidl_generator_c.a`` ->
    std_msgs), else the stem itself."""
    if archive in installed_by:
        return installed_by[archive]
    stem = archive.removeprefix("lib").removesuffix(".a")
    near = [p for p in packages if stem == p or stem.startswith(p + "_")]
    return max(near, key=len) if near else stem


def manifest_archives(manifests: Mapping[str, str]) -> dict[str, str]:
    """archive file name -> package, from each package's CMake install_manifest.txt text."""
    out = {}
    for package, text in sorted(manifests.items()):
        for line in text.splitlines():
            name = PurePosixPath(line.strip()).name
            if name.endswith(".a"):
                out[name] = package
    return out


def by_package(
    member_sizes: Mapping[str, Sizes],
    archives: Iterable[str],
    packages: Iterable[str],
    installed_by: Mapping[str, str],
) -> dict[str, tuple[Sizes, int]]:
    """package -> (summed sizes, number of members)."""
    archives, packages = list(archives), list(packages)
    out: dict[str, tuple[Sizes, int]] = {}
    for member, sizes in member_sizes.items():
        archive = member_archive(member, archives)
        package = archive_package(archive, packages, installed_by) if archive else member
        total, count = out.get(package, (Sizes(), 0))
        out[package] = (total + sizes, count + 1)
    return out


# e_machine of the ELF header (the System V ABI's EM_ numbers) by the name readelf prints, which a
# profile's elf.machine names
ELF_MACHINES = {40: "ARM", 243: "RISC-V", 94: "Tensilica Xtensa"}
_EF_ARM_ABI_FLOAT_SOFT, _EF_ARM_ABI_FLOAT_HARD = 0x200, 0x400
_EF_RISCV_FLOAT_ABI = 0x6


def elf_problem(
    head: bytes, machine: str | None = None, elf_class: str = "ELF32", float_abi: str | None = None
) -> str | None:
    """Why ``head`` (a file's first 64 bytes) is not a linked firmware for the target, or None:
    an ELF executable of ``machine`` (readelf's name; None: any) and ``elf_class``, with the float
    ABI ``float_abi`` ("hard", "soft"; None: either) where its header says one (pure)."""
    if head.startswith(b"!<arch>\n"):
        return "an archive (ar), not a linked firmware"
    if not head.startswith(b"\x7fELF") or len(head) < 52 or head[5] not in (1, 2):
        return "not an ELF file"
    little = head[5] == 1
    e_type = int.from_bytes(head[16:18], "little" if little else "big")
    if e_type == 1:
        return "a relocatable object (.o), not a linked firmware"
    if e_type not in (2, 3):
        return "not an executable ELF file"
    found_class = {1: "ELF32", 2: "ELF64"}.get(head[4], "ELF?")
    number = int.from_bytes(head[18:20], "little" if little else "big")
    found = ELF_MACHINES.get(number, f"machine {number}")
    if machine is not None and (found != machine or found_class != elf_class):
        return f"a firmware for {found} ({found_class}), not for the library's {machine} ({elf_class})"
    flags = int.from_bytes(head[36:40], "little" if little else "big") if found_class == "ELF32" else 0
    abi = None
    if found == "ARM" and flags & (_EF_ARM_ABI_FLOAT_SOFT | _EF_ARM_ABI_FLOAT_HARD):
        abi = "hard" if flags & _EF_ARM_ABI_FLOAT_HARD else "soft"
    elif found == "RISC-V":
        abi = "soft" if not flags & _EF_RISCV_FLOAT_ABI else "hard"
    if float_abi is not None and abi is not None and abi != float_abi:
        return f"its float ABI is {abi}-float, the library's is {float_abi}-float: another target's firmware"
    return None
