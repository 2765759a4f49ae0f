"""Which interface packages a firmware uses, read from its C/C++ sources (pure).

A micro-ROS firmware names every message, service and action type it uses twice over: the
generated header it includes (``#include <std_msgs/msg/int32.h>``, ``<pkg/srv/...>``,
``<pkg/action/...>``) and the type support it hands to rclc
(``ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32)``, ``ROSIDL_GET_SRV_TYPE_SUPPORT``,
``ROSIDL_GET_ACTION_TYPE_SUPPORT``, rosidl_typesupport_interface's ``*_SYMBOL_NAME`` macros).
Either names the package; `uros build --for-firmware DIR` builds those packages and the core.
Comments are left out, so a commented-out include does not count.

The same read finds the rclc calls that create what the library must have room for (``Call``:
``rclc_publisher_init_default(...)`` and friends, ``rclc_executor_init`` and ``rclc_executor_add_*``,
with their file, line and top-level arguments) and the firmware's own object-like ``#define``s (an
executor's size is often one); output/fit.py counts them against the library's limits.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

SOURCE_SUFFIXES = frozenset(
    {".c", ".h", ".cc", ".cpp", ".cxx", ".c++", ".hh", ".hpp", ".hxx", ".ino", ".inl"}
)

_IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
_INCLUDE = re.compile(
    rf'^[ \t]*#[ \t]*include[ \t]*[<"]({_IDENT})/(msg|srv|action)/([^>"]+)[>"]', re.MULTILINE
)
_TYPE_SUPPORT = re.compile(
    rf"\bROSIDL_GET_(?:MSG|SRV|ACTION)_TYPE_SUPPORT\s*\(\s*({_IDENT})\s*,\s*(msg|srv|action)\s*,\s*({_IDENT})\s*\)"
)
_SYMBOL_NAME = re.compile(
    rf"\bROSIDL_TYPESUPPORT_INTERFACE__(?:MESSAGE|SERVICE|ACTION)_SYMBOL_NAME\s*\(\s*{_IDENT}\s*,\s*"
    rf"({_IDENT})\s*,\s*(msg|srv|action)\s*,\s*({_IDENT})\s*\)"
)
_BLOCK_COMMENT = re.compile(r"/\*.*?\*/", re.DOTALL)
_LINE_COMMENT = re.compile(r"//[^\n]*")
# the rclc calls that create entities or size an executor (rclc, rclc_parameter; humble)
_CALL = re.compile(
    r"\b(rclc_(?:publisher|subscription|service|client|timer|node)_init\w*"
    r"|rclc_parameter_server_init\w*|rclc_action_(?:server|client)_init\w*"
    r"|rclc_executor_init|rclc_executor_add_\w+)\s*\("
)
_DEFINE = re.compile(rf"^[ \t]*#[ \t]*define[ \t]+({_IDENT})[ \t]+([^\n]+)$", re.MULTILINE)
_STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"' + r"|'(?:[^'\\\n]|\\.)*'")
_HEADER_PARTS = re.compile(r"__(struct|functions|type_support|rosidl_typesupport_\w+|traits|builder)$")


def snake_case(name: str) -> str:
    """rosidl's file name for a type (``CmdVel`` -> ``cmd_vel``, ``HSVColor`` -> ``hsv_color``:
    rosidl_cmake's convert_camel_case_to_lower_case_underscore)."""
    value = re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", name)
    value = re.sub(r"([A-Z])([A-Z][a-z])", r"\1_\2", value)
    return value.lower()


def _type_of(kind: str, header: str) -> str:
    """``msg`` + ``detail/cmd_vel__struct.h`` -> ``msg/cmd_vel``."""
    stem = header.rsplit("/", 1)[-1]
    stem = stem.split(".", 1)[0]
    return f"{kind}/{_HEADER_PARTS.sub('', stem)}"


def strip_comments(text: str) -> str:
    """C and C++ comments out, line breaks kept (so that a #include stays at a line start)."""
    text = _BLOCK_COMMENT.sub(lambda m: "\n" * m[0].count("\n") or " ", text)
    return _LINE_COMMENT.sub("", text)


def scan_text(text: str) -> dict[str, set[str]]:
    """Package -> the interface types (``msg/cmd_vel``, ``srv/get_time``) ``text`` uses."""
    found: dict[str, set[str]] = {}
    code = strip_comments(text)
    for match in _INCLUDE.finditer(code):
        found.setdefault(match[1], set()).add(_type_of(match[2], match[3]))
    for pattern in (_TYPE_SUPPORT, _SYMBOL_NAME):
        for match in pattern.finditer(code):
            found.setdefault(match[1], set()).add(f"{match[2]}/{snake_case(match[3])}")
    return found


@dataclass(frozen=True)
class Call:
    """One rclc call in a firmware's sources: the function, where it is, its top-level arguments
    (blanks collapsed; a call cut off by the end of the file has the arguments read so far)."""

    function: str
    file: str
    line: int
    args: tuple[str, ...]

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}"


def _arguments(code: str, start: int) -> tuple[str, ...]:
    """The top-level comma-separated arguments of the call whose ``(`` is just before ``start``."""
    args: list[str] = []
    current: list[str] = []
    depth = 0
    for char in code[start:]:
        if char in "([{":
            depth += 1
        elif char in ")]}":
            if depth == 0:
                break
            depth -= 1
        elif char == "," and depth == 0:
            args.append("".join(current))
            current = []
            continue
        current.append(char)
    args.append("".join(current))
    return tuple(" ".join(a.split()) for a in args if a.strip() or len(args) > 1)


def _blank_strings(code: str) -> str:
    """String and character literals blanked (same length): a name or a comma in a string is
    neither a call nor an argument's end."""
    return _STRING.sub(lambda m: '"' + " " * (len(m[0]) - 2) + '"', code)


def scan_calls(text: str, file: str) -> tuple[Call, ...]:
    """The rclc calls that create entities or size an executor in ``text`` (comments and string
    literals left out), in the order they appear. A static read: a call in a loop or a helper
    called twice counts once, a call in code an ``#if`` leaves out counts too."""
    code = _blank_strings(strip_comments(text))
    calls = []
    for match in _CALL.finditer(code):
        line = code.count("\n", 0, match.start()) + 1
        calls.append(Call(match[1], file, line, _arguments(code, match.end())))
    return tuple(calls)


def scan_defines(text: str) -> dict[str, str]:
    """NAME -> its replacement text, for the object-like ``#define``s in ``text`` (a function-like
    macro's ``(`` follows its name without a blank: not matched)."""
    return {m[1]: " ".join(m[2].split()) for m in _DEFINE.finditer(strip_comments(text))}


@dataclass(frozen=True)
class FirmwareUse:
    """What a firmware's sources use: package -> types, and the files that name each package."""

    packages: Mapping[str, frozenset[str]] = field(default_factory=dict)
    files: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # package -> files (relative)
    scanned: int = 0  # source files read
    calls: tuple[Call, ...] = ()  # the rclc calls that create entities or size an executor
    defines: Mapping[str, str] = field(default_factory=dict)  # object-like #defines, first wins

    def describe(self) -> str:
        return "; ".join(
            f"{pkg} ({', '.join(sorted(types))})" for pkg, types in sorted(self.packages.items())
        )


def _skip_folder(path: Path, names: Iterable[str]) -> bool:
    """Folders that are not the firmware's own sources: a uros output (its include tree has
    every package's headers), a CMake or colcon build tree, version control, colcon's ignores."""
    listed = set(names)
    return path.name.startswith(".") or bool(
        listed & {"build-info.json", "CMakeCache.txt", "COLCON_IGNORE", "AMENT_IGNORE"}
    )


def scan_folder(root: Path) -> FirmwareUse:
    """Every C/C++ source and header under ``root`` (build trees and uros outputs left out)."""
    packages: dict[str, set[str]] = {}
    files: dict[str, list[str]] = {}
    scanned = 0
    calls: list[Call] = []
    defines: dict[str, str] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        folder = Path(dirpath)
        if folder != root and _skip_folder(folder, [*filenames, *dirnames]):
            dirnames[:] = []
            continue
        dirnames.sort()
        for name in sorted(filenames):
            path = folder / name
            if path.suffix.lower() not in SOURCE_SUFFIXES:
                continue
            try:
                text = path.read_text(encoding="utf-8", errors="replace")
            except OSError:
                continue
            scanned += 1
            for pkg, types in scan_text(text).items():
                packages.setdefault(pkg, set()).update(types)
                files.setdefault(pkg, []).append(str(path.relative_to(root)))
            relative = path.relative_to(root).as_posix()
            calls.extend(scan_calls(text, relative))
            for name, value in scan_defines(text).items():
                defines.setdefault(name, value)
    return FirmwareUse(
        packages={p: frozenset(t) for p, t in packages.items()},
        files={p: tuple(f) for p, f in files.items()},
        scanned=scanned,
        calls=tuple(calls),
        defines=defines,
    )
