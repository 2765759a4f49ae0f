"""The largest serialized size of the message types a firmware uses, against what the library's
XRCE-DDS streams carry (pure: reads the output's include tree).

Best-effort streams do not fragment: a sample must fit one transport MTU; reliable ones fragment
over the stream's history slots, so a sample fits only MTU x history (micro-ROS-Agent#143,
rmw_microxrcedds#247). Sizes come from rosidl's own generated C structs in the library's include
tree (``include/<pkg>/msg/detail/<type>__struct.h``): each field's C type, fixed arrays, and the
``__MAX_SIZE``/``__MAX_STRING_SIZE`` bounds rosidl_generator_c writes for bounded sequences and
strings; an unbounded string or sequence makes a type unbounded. The size is CDR's (XCDR1, as
Micro-CDR writes it): each primitive aligned to its size, a string a 4-byte length, its bytes and
a NUL, a sequence a 4-byte length and its elements.

The headers around a sample are XRCE-DDS's: a message header of 4 bytes (micro-ROS's session
ids carry no client key) and a submessage header of 4; WRITE_DATA adds its 4-byte request, and
each fragment of a reliable stream carries its own message and submessage headers.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.output.buildinfo import BuildInfo

BEST_EFFORT_HEADERS = 12  # message header 4 + submessage header 4 + WRITE_DATA request 4
FRAGMENT_HEADERS = 8  # each fragment: message header 4 + FRAGMENT submessage header 4
WRITE_DATA_HEADERS = 8  # the fragmented WRITE_DATA submessage's own header 4 + request 4

# rosidl_generator_c's C types for the IDL primitives, with their CDR size
_PRIMITIVES = {
    "bool": 1,
    "signed char": 1,
    "char": 1,
    "int8_t": 1,
    "uint8_t": 1,
    "int16_t": 2,
    "uint16_t": 2,
    "int32_t": 4,
    "uint32_t": 4,
    "float": 4,
    "int64_t": 8,
    "uint64_t": 8,
    "double": 8,
    "long double": 8,
}
# rosidl_runtime_c's sequence names (rosidl_runtime_c__<name>__Sequence)
_SEQUENCE_ELEMENTS = {
    "boolean": 1,
    "octet": 1,
    "char": 1,
    "int8": 1,
    "uint8": 1,
    "int16": 2,
    "uint16": 2,
    "wchar": 2,
    "int32": 4,
    "uint32": 4,
    "float": 4,
    "int64": 8,
    "uint64": 8,
    "double": 8,
    "long_double": 8,
}
_FIELD = re.compile(
    r"^\s*((?:signed |unsigned |long )?[A-Za-z_]\w*)\s+([A-Za-z_]\w*)(?:\[(\d+)\])?\s*;", re.M
)
_BOUND = re.compile(r"\b(\w+)__(MAX_SIZE|MAX_STRING_SIZE)\s*=\s*(\d+)")


@dataclass(frozen=True)
class Field:
    name: str
    ctype: str
    array: int | None  # a fixed array's length


@dataclass(frozen=True)
class Struct:
    name: str  # pkg__msg__Type
    fields: tuple[Field, ...]
    max_size: Mapping[str, int]  # field -> bounded sequence's upper bound
    max_string: Mapping[str, int]  # field -> bounded string's upper bound


def parse_struct_header(text: str) -> dict[str, Struct]:
    """Every ``typedef struct NAME { ... } NAME;`` of a rosidl ``__struct.h``, with its bounds."""
    bounds: dict[str, dict[str, dict[str, int]]] = {}
    for match in _BOUND.finditer(text):
        owner, _, field_name = match[1].rpartition("__")
        bounds.setdefault(owner, {}).setdefault(match[2], {})[field_name] = int(match[3])
    out = {}
    for match in re.finditer(r"typedef struct (\w+)\s*\{(.*?)\}\s*(\w+)\s*;", text, re.S):
        name, body = match[1], re.sub(r"//[^\n]*", "", match[2])
        fields = tuple(Field(f[2], f[1], int(f[3]) if f[3] else None) for f in _FIELD.finditer(body))
        mine = bounds.get(name, {})
        out[name] = Struct(name, fields, mine.get("MAX_SIZE", {}), mine.get("MAX_STRING_SIZE", {}))
    return out


class Unbounded(Exception):
    """A type holds an unbounded string or sequence (``where`` names the field)."""

    def __init__(self, where: str) -> None:
        super().__init__(where)
        self.where = where


def _align(offset: int, size: int) -> int:
    return offset + (-offset % size)


@dataclass
class Sizer:
    """Struct definitions found on demand in an include tree (``find``: C name -> Struct)."""

    include: Path
    known: dict[str, Struct]

    def find(self, cname: str) -> Struct | None:
        if cname not in self.known:
            pkg, _, rest = cname.partition("__")
            kind = rest.split("__", 1)[0]
            for header in sorted((self.include / pkg / kind / "detail").glob("*__struct.h")):
                self.known.update(parse_struct_header(header.read_text(encoding="utf-8", errors="replace")))
                if cname in self.known:
                    break
        return self.known.get(cname)

    def end(self, cname: str, offset: int, where: str) -> int:
        """The offset after the largest sample of ``cname`` written at ``offset``."""
        struct = self.find(cname)
        if struct is None:
            raise LookupError(cname)
        for f in struct.fields:
            at = f"{where}.{f.name}" if where else f.name
            for _ in range(f.array or 1):
                offset = self._field(struct, f, offset, at)
        return offset

    def _field(self, struct: Struct, f: Field, offset: int, where: str) -> int:
        if f.ctype in _PRIMITIVES:
            size = _PRIMITIVES[f.ctype]
            return _align(offset, size) + size
        if f.ctype in ("rosidl_runtime_c__String", "rosidl_runtime_c__U16String"):
            return self._string(struct, f, offset, where)
        seq = re.fullmatch(r"(\w+?)__Sequence", f.ctype)
        if seq is None:
            return self.end(f.ctype, offset, where)
        if f.name not in struct.max_size:
            raise Unbounded(where)
        count = struct.max_size[f.name]
        offset = _align(offset, 4) + 4
        element = seq[1].removeprefix("rosidl_runtime_c__")
        for _ in range(count):
            if element in _SEQUENCE_ELEMENTS:
                size = _SEQUENCE_ELEMENTS[element]
                offset = _align(offset, size) + size
            elif element in ("String", "U16String"):
                offset = self._string(
                    struct, Field(f.name, f"rosidl_runtime_c__{element}", None), offset, where
                )
            else:
                offset = self.end(seq[1], offset, where)
        return offset

    def _string(self, struct: Struct, f: Field, offset: int, where: str) -> int:
        if f.name not in struct.max_string:
            raise Unbounded(where)
        width = 2 if f.ctype.endswith("U16String") else 1
        return _align(offset, 4) + 4 + (struct.max_string[f.name] + 1) * width


@dataclass(frozen=True)
class Limits:
    """What the library's streams carry: the transport's MTU and the reliable stream history."""

    mtu: int
    mtu_option: str
    history: int
    history_option: str

    @property
    def best_effort(self) -> int:
        return self.mtu - BEST_EFFORT_HEADERS

    def reliable(self, history: int | None = None, mtu: int | None = None) -> int:
        return (history or self.history) * ((mtu or self.mtu) - FRAGMENT_HEADERS) - WRITE_DATA_HEADERS


def limits(options: Mapping[str, Mapping[str, str]], transport: str | None) -> Limits:
    """From build-info.json's cmake_options (the options in force) and upstream's defaults."""
    client = options.get("microxrcedds_client", {})
    rmw = options.get("rmw_microxrcedds", {})
    mtu_option = f"UCLIENT_{(transport or 'custom').upper()}_TRANSPORT_MTU"
    history_option = "RMW_UXRCE_STREAM_HISTORY"
    history = rmw.get(history_option, "4")
    if rmw.get("RMW_UXRCE_STREAM_HISTORY_INPUT") and rmw.get("RMW_UXRCE_STREAM_HISTORY_OUTPUT"):
        history_option = "RMW_UXRCE_STREAM_HISTORY_OUTPUT"
        history = rmw[history_option]
    return Limits(int(client.get(mtu_option, "512")), mtu_option, int(history), history_option)


def verdict(type_name: str, size: int | None, where: str, lim: Limits) -> tuple[bool, str]:
    """(is it a warning, the line) for one type: its largest size (None: unbounded, at ``where``)."""
    mtu = f"{lim.mtu_option}={lim.mtu}"
    hist = f"{lim.history_option}={lim.history}"
    if size is None:
        return False, (
            f"{type_name}: unbounded ({where}): a sample over {lim.best_effort} bytes cannot go over a "
            f"best-effort stream ({mtu}), over {lim.reliable()} not even a reliable one ({hist})"
        )
    if size <= lim.best_effort:
        return False, f"{type_name}: up to {size} bytes: fits one MTU ({mtu}), best-effort or reliable"
    fits_mtu = size + BEST_EFFORT_HEADERS
    if size <= lim.reliable():
        return True, (
            f"{type_name}: up to {size} bytes, more than one MTU carries ({mtu}: {lim.best_effort}): "
            f"best-effort streams do not fragment, so only a reliable publisher/subscription carries it "
            f"(or {lim.mtu_option}={fits_mtu})"
        )
    history = 1 << max(0, math.ceil(math.log2((size + WRITE_DATA_HEADERS) / (lim.mtu - FRAGMENT_HEADERS))))
    mtu_for = math.ceil((size + WRITE_DATA_HEADERS) / lim.history) + FRAGMENT_HEADERS
    return True, (
        f"{type_name}: up to {size} bytes, more than even a reliable stream carries "
        f"({lim.mtu} x {hist}: {lim.reliable()}): "
        f"set {lim.history_option}={history} or {lim.mtu_option}={mtu_for}"
    )


def message_sizes(include: Path, used: Mapping[str, frozenset[str]]) -> list[tuple[str, int | None, str]]:
    """(``pkg/msg/Type``, largest size or None, the unbounded field) of every message type in
    ``used`` (package -> ``msg/<stem>``, as the firmware scan finds them) the include tree has."""
    sizer = Sizer(include, {})
    out: list[tuple[str, int | None, str]] = []
    for pkg, kinds in sorted(used.items()):
        for item in sorted(kinds):
            kind, _, stem = item.partition("/")
            header = include / pkg / kind / "detail" / f"{stem}__struct.h"
            if kind != "msg" or not header.is_file():
                continue
            structs = parse_struct_header(header.read_text(encoding="utf-8", errors="replace"))
            sizer.known.update(structs)
            for cname in structs:
                if not cname.startswith(f"{pkg}__msg__") or cname.endswith("__Sequence"):
                    continue
                type_name = f"{pkg}/msg/{cname.removeprefix(f'{pkg}__msg__')}"
                try:
                    out.append((type_name, sizer.end(cname, 0, ""), ""))
                except Unbounded as exc:
                    out.append((type_name, None, exc.where))
                except LookupError:
                    continue  # a nested type the library lacks: nothing to say
    return out


def verdicts(
    output: Path, info: BuildInfo, used: Mapping[str, frozenset[str]]
) -> list[tuple[str, bool, str]]:
    """(type, is it a warning, the line) for each message type in ``used``, against the output's
    own options (its build-info.json) and include tree."""
    lim = limits(info.cmake_options, info.transport)
    return [
        (name, *verdict(name, size, where, lim))
        for name, size, where in message_sizes(output / info.include.dir, used)
    ]
