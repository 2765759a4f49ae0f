"""A static library's global symbols by member, from ``nm -g --format=posix`` text (LC_ALL=C): the
ones two members define, and the ones the firmware's link must provide.

**Defined twice.** A link that takes a library with ``--whole-archive`` (the precompiled-library
builders of Arduino's cores, some vendor IDEs) pulls in every member, so two members defining one
global symbol fail it with "multiple definition" (micro_ros_arduino#910, #1300, #847: introspection
functions of std_msgs and example_interfaces). A normal link pulls in only the members it needs and
may never notice. Counted as definitions: the strong kinds, ``T`` (code), ``D`` (data), ``B`` (bss),
``R`` (read-only data) and ``G``/``S`` (the same in small-data sections, where a target has them).
Not counted: ``C`` (common: a tentative definition ``int x;`` built with -fcommon, GCC < 10's default;
the linker merges commons with each other and with one strong definition, so they never collide;
from GCC 10 on, -fno-common makes them ``B``, which are counted), ``W``/``V`` (weak: the linker keeps
one), ``u`` (unique globals, merged), ``A`` and ``i`` (absolute and indirect: none in micro-ROS).

**Left undefined.** ``U`` symbols that no member defines: what the firmware's link must resolve,
named with who provides each and what it is from ``meta/firmware-symbols.yaml``. Weak references
(``w``/``v``) are left out: the link succeeds without them.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, loader, resources
from uros_build.errors import ConfigError
from uros_build.proc import Runner

STRONG = frozenset("TDBRGS")
UNDEFINED = "U"
DEFINED_ANY = frozenset("TDBRGSCWVuAi")
NM_HINT = "install GNU binutils (Debian/Ubuntu: apt install binutils)"
SHOWN = 3  # duplicates a one-line message names before "and N more"


@dataclass(frozen=True)
class NmSymbol:
    member: str  # the archive member (the file itself for a single object)
    name: str
    kind: str  # nm's type letter


@dataclass(frozen=True)
class Duplicate:
    """A global symbol more than one member defines, and those members in archive order."""

    name: str
    members: tuple[str, ...]


def _member(header: str, default: str) -> str:
    """``lib.a[member.o]`` (GNU nm) or ``member.o`` (llvm-nm) -> the member's name."""
    # a member's name has no '/', a path may have '[': the bracket after the last '/' opens it
    if header.endswith("]"):
        start = header.find("[", header.rfind("/") + 1)
        if start >= 0:
            return header[start + 1 : -1]
    return header or default


def parse_nm(nm_posix_text: str, default_member: str) -> tuple[NmSymbol, ...]:
    """``nm -g --format=posix`` text over one archive or object -> its symbols, member by member
    (pure). A header is the only line ending in ':' (a symbol line ends with its type letter or a
    hex number), as :func:`uros_build.output.archive.parse_defined_globals` reads it; an object
    alone has no header, so its symbols belong to ``default_member``."""
    member = default_member
    out: list[NmSymbol] = []
    for line in nm_posix_text.splitlines():
        text = line.rstrip()
        if not text:
            continue
        if text.endswith(":"):
            member = _member(text[:-1], default_member)
            continue
        parts = text.split()
        if 2 <= len(parts) <= 4 and len(parts[1]) == 1:
            out.append(NmSymbol(member, parts[0], parts[1]))
    return tuple(out)


def duplicate_globals(symbols: Sequence[NmSymbol]) -> tuple[Duplicate, ...]:
    """Global symbols with a strong definition (:data:`STRONG`) in more than one member, by name
    (pure). A member that defines a name twice is one member (the assembler refuses that anyway)."""
    by_name: dict[str, list[str]] = {}
    for sym in symbols:
        if sym.kind in STRONG:
            members = by_name.setdefault(sym.name, [])
            if sym.member not in members:
                members.append(sym.member)
    return tuple(Duplicate(name, tuple(m)) for name, m in sorted(by_name.items()) if len(m) > 1)


def undefined_globals(symbols: Sequence[NmSymbol]) -> tuple[str, ...]:
    """Strong undefined references no member defines (in any way), sorted (pure)."""
    defined = {s.name for s in symbols if s.kind in DEFINED_ANY}
    return tuple(sorted({s.name for s in symbols if s.kind == UNDEFINED} - defined))


def describe_duplicates(duplicates: Sequence[Duplicate], library: str) -> str:
    """One line: how many, and the first :data:`SHOWN` with their members."""
    shown = "; ".join(f"{d.name} ({', '.join(d.members)})" for d in duplicates[:SHOWN])
    more = f"; and {len(duplicates) - SHOWN} more" if len(duplicates) > SHOWN else ""
    many = "s are" if len(duplicates) != 1 else " is"
    return (
        f"{library}: {len(duplicates)} global symbol{many} defined in more than one member, which a "
        f"--whole-archive link (Arduino's precompiled libraries) refuses as 'multiple definition': "
        f"{shown}{more}"
    )


def duplicate_lines(duplicates: Sequence[Duplicate]) -> list[str]:
    """The full list, a line a symbol."""
    return [f"  {d.name}: defined in {', '.join(d.members)}" for d in duplicates]


DUPLICATE_HINT = (
    "leave one of the packages that define it out of the build (the members name their archives) "
    "and build again"
)


# --- what the firmware provides ---------------------------------------------------------------


@dataclass(frozen=True)
class KnownSymbol:
    """A symbol (or every symbol starting with ``pattern`` without its trailing '*') a library may
    leave undefined: who provides it and what it is."""

    pattern: str
    provider: str
    meaning: str

    def matches(self, name: str) -> bool:
        if self.pattern.endswith("*"):
            return name.startswith(self.pattern[:-1])
        return name == self.pattern


@dataclass(frozen=True)
class FirmwareSymbols:
    providers: dict[str, str]  # provider key -> who that is, as shown
    symbols: tuple[KnownSymbol, ...]

    def lookup(self, name: str) -> KnownSymbol | None:
        """The exact name, else the longest pattern that matches."""
        found = [s for s in self.symbols if s.matches(name)]
        ranked = sorted(found, key=lambda s: (s.pattern != name, -len(s.pattern)))
        return ranked[0] if ranked else None


def parse_firmware_symbols(data: object, source: str) -> FirmwareSymbols:
    top = loader.mapping(data, source, {"providers", "symbols"}, required=("providers", "symbols"))
    providers = dict(loader.string_map(top, "providers", source))
    symbols = []
    seen: set[str] = set()
    for i, item in enumerate(
        loader.mapping_list(
            top, "symbols", source, {"name", "provider", "meaning"}, ("name", "provider", "meaning")
        )
    ):
        where = f"{source}: symbols[{i}]"
        name = loader.string(item, "name", where)
        provider = loader.one_of(item, "provider", where, tuple(providers))
        if name in seen or not name.strip("*") or "*" in name[:-1]:
            raise ConfigError(f"{where}: name {name!r}: a new name, or a prefix ending in one '*'")
        seen.add(name)
        symbols.append(KnownSymbol(name, provider, loader.string(item, "meaning", where)))
    return FirmwareSymbols(providers, tuple(symbols))


@functools.lru_cache(maxsize=1)
def firmware_symbols() -> FirmwareSymbols:
    path = resources.meta_dir() / "firmware-symbols.yaml"
    return parse_firmware_symbols(loader.load_yaml(path), str(path))


def needed_lines(undefined: Sequence[str], known: FirmwareSymbols) -> list[str]:
    """A line an undefined symbol, by provider (in the file's order of providers) then name."""
    order = {key: i for i, key in enumerate(known.providers)}
    rows = []
    for name in undefined:
        entry = known.lookup(name)
        if entry is None:
            rows.append((len(order), name, f"  {name}: not in uros's list (meta/firmware-symbols.yaml)"))
        else:
            meaning = f": {entry.meaning}" if entry.meaning else ""
            rows.append(
                (order[entry.provider], name, f"  {name} ({known.providers[entry.provider]}){meaning}")
            )
    return [line for _, _, line in sorted(rows)]


def needed_json(undefined: Sequence[str], known: FirmwareSymbols) -> dict[str, dict[str, str]]:
    out = {}
    for name in undefined:
        entry = known.lookup(name)
        out[name] = {"provider": entry.provider, "meaning": entry.meaning} if entry else {"provider": ""}
    return out


def read_nm(runner: Runner, nm: str, library: Path) -> str:
    """Every global symbol of ``library``, defined and undefined, in one ``nm`` run (``query``:
    stdout alone, LC_ALL=C). GNU nm reads any ELF machine's objects, as readelf does."""
    return runner.query(
        [nm, "-g", "--format=posix", str(library)], step=f"read the symbols of {library.name}"
    )


def warn_duplicates(duplicates: Mapping[str, Sequence[str]], library: str = "libmicroros.a") -> None:
    """Every build says it (one warning line; the full list in the run log), built, reused or taken
    from a cache: the record in build-info.json comes from the merge's own nm run."""
    found = [Duplicate(name, tuple(members)) for name, members in sorted(duplicates.items())]
    if found:
        console.warn(describe_duplicates(found, library) + " (all of them: the run log, `uros check`)")
        console.logged("\n".join(duplicate_lines(found)))
