"""The ar archive format (a static library), read from its bytes: the one reader that both the merge
(output/archive.py: each member's name and content, as ``ar t`` and ``ar x`` give them) and the
full-disk check (colcon/damage.py: do the member headers chain exactly to the end?) use. Pure over
a ``read_at(offset, length)`` function, so a check reads only the headers, never the members.

The format (https://en.wikipedia.org/wiki/Ar_(Unix)#File_format_details): ``!<arch>\\n``, then per
member a 60-byte header (name at 0..16, size at 48..58, ``\\x60\\n`` at 58..60) and its data, padded
to an even offset. Names: GNU/SysV ``name/``, long names as ``/offset`` into the ``//`` table; BSD
``#1/length`` with the name before the data (not part of the content). Symbol tables (``/``,
``/SYM64/``, BSD ``__.SYMDEF[ SORTED]``) are not members. Thin archives (``!<thin>\\n``) are not read.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import BinaryIO

MAGIC = b"!<arch>\n"
HEADER = 60
_SYMBOL_TABLES = (b"/", b"/SYM64/")

ReadAt = Callable[[int, int], bytes]


class ArFormatError(ValueError):
    """What is wrong with the bytes: ``kind`` is "not ar" (no ar magic), "broken" (a member header
    that is not one, at ``offset``) or "cut" (a member that ends past the end of the file)."""

    def __init__(self, kind: str, why: str, offset: int = 0) -> None:
        super().__init__(why)
        self.kind = kind
        self.offset = offset


@dataclass(frozen=True)
class Entry:
    """One header of the archive: its name field (spaces cut), where its data starts, its size."""

    field: bytes
    data_at: int
    size: int


def entries(read_at: ReadAt, size: int) -> Iterator[Entry]:
    """The headers of an archive of ``size`` bytes, in order, checked to chain exactly to its end
    (the last member's padding byte may be missing). ArFormatError where they do not."""
    if read_at(0, len(MAGIC)) != MAGIC:
        raise ArFormatError("not ar", "is not an ar archive")
    offset = len(MAGIC)
    while offset < size:
        header = read_at(offset, HEADER)
        if not header.strip(b"\n"):
            return  # padding at the end
        length = header[48:58].strip()
        if len(header) < HEADER or header[58:60] != b"`\n" or not length.isdigit():
            raise ArFormatError("broken", f"is cut short or broken at byte {offset}", offset)
        entry = Entry(header[:16].rstrip(b" "), offset + HEADER, int(length))
        if entry.data_at + entry.size > size:
            raise ArFormatError(
                "cut", f"is cut short (a member ends at byte {entry.data_at + entry.size} of {size})", offset
            )
        yield entry
        offset = entry.data_at + entry.size + entry.size % 2


def members(read_at: ReadAt, size: int) -> tuple[tuple[str, bytes], ...]:
    """Each member in archive order: its name, as ``ar t`` lists it, and its content, the bytes
    ``ar x`` writes; symbol tables left out. ArFormatError as :func:`entries`."""
    found: list[tuple[str, bytes]] = []
    long_names = b""
    for entry in entries(read_at, size):
        data = read_at(entry.data_at, entry.size)
        raw = entry.field
        if raw == b"//":
            long_names = data
        elif raw in _SYMBOL_TABLES or raw.startswith(b"__.SYMDEF"):
            continue
        elif raw.startswith(b"#1/") and raw[3:].isdigit():
            length = int(raw[3:])
            name = data[:length].rstrip(b"\0")
            if not name.startswith(b"__.SYMDEF"):
                found.append((os.fsdecode(name), data[length:]))
        elif raw.startswith(b"/") and raw[1:].isdigit():
            start = int(raw[1:])
            end = long_names.find(b"\n", start)
            name = long_names[start : end if end >= 0 else len(long_names)]
            found.append((os.fsdecode(name.removesuffix(b"/")), data))
        else:
            found.append((os.fsdecode(raw.removesuffix(b"/")), data))
    return tuple(found)


def stream_reader(stream: BinaryIO) -> tuple[ReadAt, int]:
    """``read_at`` over a seekable binary stream, and the stream's size."""
    size = stream.seek(0, os.SEEK_END)

    def read_at(offset: int, length: int) -> bytes:
        stream.seek(offset)
        return bytes(stream.read(length))

    return read_at, size
