"""The memory and entity options users look for (``meta/options.yaml``): known options per package,
their upstream defaults and what they cost, loaded into frozen dataclasses; and the check of
``--set``/uros.yaml ``set:`` entries against them (pure)."""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable, Mapping
from dataclasses import astuple, dataclass

from uros_build import loader, resources
from uros_build.errors import ConfigError, did_you_mean
from uros_build.sources.meta import split_set

TYPES = ("int", "bool", "string")
_BOOLS = ("ON", "OFF", "TRUE", "FALSE", "1", "0", "YES", "NO")
# A whole number as CMake passes it on into a C #define: Python's int() also takes " 4", "1_000",
# "+4" and other scripts' digits, which the compiler then rejects (or reads otherwise).
_WHOLE = re.compile(r"-?[0-9]+")
# an int option reaches the library's C code as a #define its types hold (int, size_t, uint16_t):
# none is larger than a C int unless options.yaml says less (a 5000-digit value was an internal error)
INT_MAX = 2**31 - 1


@dataclass(frozen=True)
class KnownOption:
    package: str
    name: str
    default: str
    cost: str
    type: str = "string"  # int, bool or string
    choices: tuple[str, ...] = ()
    power_of_two: bool = False
    minimum: int = 0  # int options are counts, sizes and times: none is negative unless it says
    maximum: int = INT_MAX  # the largest value the option's code keeps whole
    # the library's static arrays (symbols) whose size the option sets: `uros size` reads their
    # size from the library as the option's RAM cost
    pools: tuple[str, ...] = ()
    # an MTU option sizes its pools only in a library built for this transport ("": any)
    transport: str = ""
    # each pool is an array of the option's value elements: one less frees pool/value bytes
    per_value: bool = False
    # the header of the library's include tree that #defines the value it was built with, and the
    # macro there ("": the option's name)
    header: str = ""
    macro: str = ""
    why: str = ""  # why the range is what it is (options.yaml's `range_why:`), said when it refuses

    @property
    def _why(self) -> str:
        return f": {self.why}" if self.why else ""

    def problem(self, value: str) -> str | None:
        """Why ``value`` cannot be right for this option, or None."""
        if self.choices and value not in self.choices:
            return f"must be one of {', '.join(self.choices)}"
        if self.type == "int":
            if not _WHOLE.fullmatch(value):
                return f"must be a whole number ({self.minimum} or more), got {value!r}"
            digits = len(value.lstrip("-").lstrip("0"))
            if digits > len(
                str(self.maximum)
            ):  # out of range whatever it is: never int() thousands of digits
                shown = value if len(value) <= 20 else f"a number of {digits:,} digits"
                if value.startswith("-"):
                    return f"must be {self.minimum} or more, got {shown}{self._why}"
                return f"must be {self.maximum} or less, got {shown}{self._why}"
            number = int(value)
            if number < self.minimum:
                return f"must be {self.minimum} or more, got {number}{self._why}"
            if number > self.maximum:
                return f"must be {self.maximum} or less, got {number}{self._why}"
            if self.power_of_two and (number < 1 or number & (number - 1)):
                return "must be a power of two (1, 2, 4, 8, ...)"
        if self.type == "bool" and value.upper() not in _BOOLS:
            return "must be ON or OFF"
        return None


def parse_options(data: object, source: str) -> tuple[KnownOption, ...]:
    top = loader.mapping(data, source, {"packages"}, required=("packages",))
    out = []
    for package, options in loader.mapping(top["packages"], f"{source}: packages").items():
        where = f"{source}: packages.{package}"
        for name, entry in loader.mapping(options, where).items():
            item_where = f"{where}.{name}"
            item = loader.mapping(
                entry,
                item_where,
                {
                    "default",
                    "cost",
                    "type",
                    "choices",
                    "power_of_two",
                    "minimum",
                    "maximum",
                    "pools",
                    "transport",
                    "per_value",
                    "header",
                    "macro",
                    "range_why",
                },
                ("default", "cost"),
            )
            default = item["default"]
            if not isinstance(default, str):
                raise ConfigError(f"{item_where}: default: must be a string (quote it), got {default!r}")
            option = KnownOption(
                package=str(package),
                name=str(name),
                default=default,
                cost=loader.string(item, "cost", item_where),
                type=loader.one_of(item, "type", item_where, TYPES, "string"),
                choices=loader.string_list(item, "choices", item_where),
                power_of_two=loader.boolean(item, "power_of_two", item_where),
                minimum=loader.integer(item, "minimum", item_where, 0),
                maximum=loader.integer(item, "maximum", item_where, INT_MAX),
                pools=loader.string_list(item, "pools", item_where),
                transport=loader.string(item, "transport", item_where) if "transport" in item else "",
                per_value=loader.boolean(item, "per_value", item_where),
                header=loader.string(item, "header", item_where) if "header" in item else "",
                macro=loader.string(item, "macro", item_where) if "macro" in item else "",
                why=loader.string(item, "range_why", item_where) if "range_why" in item else "",
            )
            if option.default and option.problem(option.default):
                raise ConfigError(
                    f"{item_where}: default {option.default!r} {option.problem(option.default)}"
                )
            out.append(option)
    return tuple(out)


@functools.lru_cache(maxsize=1)
def known_options() -> tuple[KnownOption, ...]:
    path = resources.meta_dir() / "options.yaml"
    return parse_options(loader.load_yaml(path), str(path))


def by_package(options: Iterable[KnownOption]) -> dict[str, dict[str, KnownOption]]:
    out: dict[str, dict[str, KnownOption]] = {}
    for option in options:
        out.setdefault(option.package, {})[option.name] = option
    return out


def check_sets(
    sets: Iterable[str],
    known: Mapping[str, Mapping[str, KnownOption]],
    origins: Mapping[str, str] | None = None,
) -> list[str]:
    """Warnings for PKG.OPTION=VALUE entries naming an option uros does not know for a package it
    knows (a typo builds with the default, silently: CMake only lists unused variables); a value
    that cannot be right (not a number, negative, not a power of two, not one of the choices) is an
    error. ``origins``: item -> where it was given (uros.yaml's ``set:``; else ``--set``)."""
    warnings = []
    for item in sets:
        where = (origins or {}).get(item, "--set")
        package, name, value = astuple(split_set(item, where))
        if package not in known:
            continue
        option = known[package].get(name)
        if option is None:
            near = did_you_mean(name, known[package])
            warnings.append(
                f"{where} {item}: {package} has no option {name} that uros knows{near} (`uros meta options`)"
            )
            continue
        problem = option.problem(value)
        if problem is not None:
            shown = item if len(item) <= 100 else f"{item[:80]}... ({len(item):,} characters)"
            raise ConfigError(
                f"{where} {shown}: {name} {problem}", f"`uros meta options` lists {package}'s options"
            )
    return warnings
