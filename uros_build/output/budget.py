"""Does it fit the chip? The library's static RAM and flash, the heap and stack a probe run
measured, against a RAM and flash budget; and the colcon.meta options that cost most RAM, each by
the size of the static pools it sets, read from the library's own symbols (pure: text in, numbers
and lines out).

Flash is text + data (GNU size's text holds .rodata too; .data's initial values live in flash),
static RAM is data + bss: what `arm-none-eabi-size` users add up by hand.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import ConfigError
from uros_build.output.sizes import Sizes
from uros_build.sources.options import KnownOption
from uros_build.target.memsize import SIZE_HELP, parse_bytes, show_bytes

# nm's types of symbols that take RAM: initialised (D/d), zeroed (B/b), common (C)
_RAM_TYPES = frozenset("DdBbC")
# a whole-number define of a configured header (CMake's configure_file: "#define NAME 4")
_DEFINE = re.compile(r"^\s*#\s*define\s+([A-Za-z_][A-Za-z0-9_]*)\s+(-?[0-9]+)\s*$", re.M)


def header_defines(text: str) -> dict[str, str]:
    """NAME -> value of every ``#define NAME <whole number>`` in a header's text."""
    return {m.group(1): m.group(2) for m in _DEFINE.finditer(text)}


def configured_headers(include: Path, names: Iterable[str]) -> dict[str, dict[str, str]]:
    """header -> its whole-number defines, for the configured headers of an include tree that
    hold the options' values (rmw_microxrcedds_c/config.h, uxr/client/config.h); absent ones left out."""
    found = {}
    for name in sorted(n for n in names if n):
        path = include / name
        if path.is_file():
            found[name] = header_defines(path.read_text(encoding="utf-8", errors="replace"))
    return found


def budget_value(value: str | None, flag: str) -> int | None:
    """--ram/--flash as bytes (None: not given); a value that is no size is refused naming the flag."""
    if value is None:
        return None
    number = parse_bytes(value)
    if number is None:
        shown = value if len(value) <= 24 else f"{value[:20]}... ({len(value):,} characters)"
        raise ConfigError(f"{flag} {shown}: not a size more than 0: {SIZE_HELP}")
    return number


def symbol_sizes(nm_posix: str) -> dict[str, int]:
    """RAM symbol -> its size in bytes, from ``nm -g --format=posix`` text of an archive (``name
    type value size`` per line; a member's header line and undefined symbols carry no size)."""
    out: dict[str, int] = {}
    for line in nm_posix.splitlines():
        parts = line.split()
        if len(parts) != 4 or parts[1] not in _RAM_TYPES:
            continue
        try:
            size = int(parts[3], 16)
        except ValueError:
            continue
        out[parts[0]] = max(out.get(parts[0], 0), size)
    return out


@dataclass(frozen=True)
class OptionCost:
    package: str
    option: str
    value: str  # in force in the library: its own header's, else its colcon.meta's, else upstream's default
    bytes: int  # the static pools it sets, as the library holds them
    pools: tuple[str, ...]
    each: int | None = None  # bytes one less frees (pools that are arrays of `value` elements)
    value_from: str = "default"  # "header", "meta" or "default"


def value_in_force(
    option: KnownOption,
    cmake_options: Mapping[str, Mapping[str, str]],
    headers: Mapping[str, Mapping[str, str]],
) -> tuple[str, str]:
    """(the value the library was built with, where from): its own header's define (``headers``:
    header path -> its defines, from the output's include tree), else ``cmake_options`` (its
    build-info.json's), else its upstream default."""
    defined = headers.get(option.header, {}).get(option.macro or option.name)
    if defined is not None:
        return defined, "header"
    meta = cmake_options.get(option.package, {}).get(option.name)
    if meta is not None:
        return meta, "meta"
    return option.default, "default"


def option_costs(
    known: Iterable[KnownOption],
    cmake_options: Mapping[str, Mapping[str, str]],
    transport: str | None,
    sizes: Mapping[str, int],
    headers: Mapping[str, Mapping[str, str]] | None = None,
) -> list[OptionCost]:
    """The options that size a static pool of this library, most bytes first. An option counts
    with the value the library was built with: its own header's define (``headers``: header path ->
    its defines, from the output's include tree), else ``cmake_options`` (its build-info.json's),
    else its upstream default; an MTU option only for the library's transport; a pool the library does not
    hold (another rmw, a renamed array) costs nothing, and an option whose pools all are absent is
    left out rather than shown as free."""
    costs = []
    for option in known:
        if not option.pools or (option.transport and option.transport != transport):
            continue
        value, value_from = value_in_force(option, cmake_options, headers or {})
        held = tuple(p for p in option.pools if sizes.get(p))
        if not value or not held:
            continue
        total = sum(sizes[p] for p in held)
        count = int(value) if option.per_value and value.isdigit() else 0
        # whole elements only: a pool that does not divide evenly is not what the notes say it is
        each = total // count if count > 0 and total % count == 0 else None
        costs.append(OptionCost(option.package, option.name, value, total, held, each, value_from))
    costs.sort(key=lambda c: (-c.bytes, c.package, c.option))
    return costs


@dataclass(frozen=True)
class Need:
    """What the firmware needs of the chip, part by part (None: not measured)."""

    library: Sizes  # the library's text/data/bss as counted (linked, or the whole archive)
    rest: Sizes | None = None  # the rest of the user's firmware, from its map file
    heap: int | None = None
    stack: int | None = None

    @property
    def static_ram(self) -> int:
        return sum(s.data + s.bss for s in (self.library, self.rest) if s is not None)

    @property
    def ram(self) -> int:
        return self.static_ram + (self.heap or 0) + (self.stack or 0)

    @property
    def flash(self) -> int:
        return sum(s.text + s.data for s in (self.library, self.rest) if s is not None)


def _part(what: str, need: int, budget: int | None) -> tuple[bool, str]:
    if budget is None:
        return True, f"{what} {need:,} B (no budget: --{what.lower()} N)"
    if need <= budget:
        return True, f"{what} {need:,} of {budget:,} B ({100 * need / budget:.0f}%)"
    return False, f"{what} needs {need:,} B: {need - budget:,} B over {show_bytes(budget)} ({budget:,} B)"


def verdict(need: Need, ram: int | None, flash: int | None, unmeasured: str | None) -> tuple[bool, str]:
    """(fits, the one line that says so). ``unmeasured``: why heap and stack are not counted."""
    ram_ok, ram_text = _part("RAM", need.ram, ram)
    flash_ok, flash_text = _part("flash", need.flash, flash)
    fits = ram_ok and flash_ok
    line = f"{'fits' if fits else 'does not fit'}: {ram_text}, {flash_text}"
    if unmeasured is not None:
        line += f" (static RAM only; heap and stack {unmeasured})"
    return fits, line


def over_by(need: Need, ram: int | None, flash: int | None) -> dict[str, int]:
    """resource -> bytes over its budget (only those over)."""
    over = {}
    if ram is not None and need.ram > ram:
        over["ram"] = need.ram - ram
    if flash is not None and need.flash > flash:
        over["flash"] = need.flash - flash
    return over


def values_that_fit(costs: Iterable[OptionCost], over: int) -> list[tuple[OptionCost, int, int]]:
    """(option, the value that would fit, the bytes it frees): each option that alone frees ``over``
    bytes of RAM while keeping at least one element, by the element size measured in the library."""
    found = []
    for cost in costs:
        if cost.each is None or over <= 0:
            continue
        fewer = -(-over // cost.each)  # ceil
        value = int(cost.value) - fewer
        if value >= 1:
            found.append((cost, value, fewer * cost.each))
    return found
