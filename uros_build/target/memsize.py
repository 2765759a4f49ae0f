"""The one reader of a memory size written with a unit (``264K``, ``2MB``), shared by a profile's
``chip:`` and ``uros size --ram/--flash``.

Units are 1024-based, as datasheets count memory: the RP2040's "264kB" of SRAM is 270,336 bytes
(six banks of 64 + 64 + 64 + 64 + 4 + 4 KiB).
"""

from __future__ import annotations

import re

# at most 12 digits: a number of thousands of digits is no size (int() refuses more than 4,300)
_SIZE = re.compile(r"0*([0-9]{1,12})\s*(|B|K|KB|KIB|M|MB|MIB)", re.IGNORECASE)
_SCALE = {"": 1, "B": 1, "K": 1024, "KB": 1024, "KIB": 1024, "M": 1024**2, "MB": 1024**2, "MIB": 1024**2}
MAX_BYTES = 4 * 1024**3  # a 32-bit address space: no microcontroller's memory is larger
SIZE_HELP = "a whole number of bytes, or with K, KB, M or MB (1024-based), e.g. 256K or 2MB, up to 4 GB"


def parse_bytes(text: str) -> int | None:
    """``text`` (``"264K"``, ``"2 MB"``, ``"65536"``) as bytes, or None when it is no size, 0 or
    more than :data:`MAX_BYTES`."""
    found = _SIZE.fullmatch(text.strip())
    if found is None:
        return None
    number = int(found.group(1)) * _SCALE[found.group(2).upper()]
    return number if 0 < number <= MAX_BYTES else None


def show_bytes(number: int) -> str:
    """The short form a datasheet would print: 270336 -> "264 KB", 2097152 -> "2 MB"."""
    for unit, scale in (("MB", 1024**2), ("KB", 1024)):
        if number >= scale and number % scale == 0:
            return f"{number // scale} {unit}"
    return f"{number:,} B"
