"""What a built library offers, read from its output folder (pure): the ROS 2
interface types its include tree declares and the CMake options its colcon.meta put in force.

The type names come from rosidl's generated C structs, not from the header file names: rosidl
turns ``UInt8`` into ``u_int8.h`` (rosidl_pycommon's convert_camel_case_to_lower_case_underscore),
which cannot be turned back, while ``detail/u_int8__struct.h`` declares ``std_msgs__msg__UInt8``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

from uros_build.sources.meta import Meta

INTERFACE_KINDS = ("msg", "srv", "action")


def _camel(stem: str) -> str:
    return "".join(part[:1].upper() + part[1:] for part in stem.split("_"))


def interface_types(include: Path) -> tuple[str, ...]:
    """``pkg/msg/Type``, ``pkg/srv/Type``, ``pkg/action/Type`` for every interface header of the
    flattened include tree (``include/<pkg>/<kind>/<type>.h``; ``detail/`` holds the parts)."""
    found = []
    for kind in INTERFACE_KINDS:
        for header in sorted(include.glob(f"*/{kind}/*.h")):
            pkg, stem = header.parent.parent.name, header.stem
            struct = header.parent / "detail" / f"{stem}__struct.h"
            name = None
            if struct.is_file():
                text = struct.read_text(encoding="utf-8", errors="replace")
                match = re.search(rf"\b{re.escape(pkg)}__{kind}__([A-Za-z0-9]+)", text)
                name = match.group(1) if match else None
            found.append(f"{pkg}/{kind}/{name or _camel(stem)}")
    return tuple(found)


def cmake_options(meta: Meta) -> dict[str, dict[str, str]]:
    """package -> -D option -> value, of every package's cmake-args (the options in force)."""
    out: dict[str, dict[str, str]] = {}
    for pkg, options in sorted(meta.names.items()):
        args = options.get("cmake-args", ())
        for arg in args if isinstance(args, tuple) else ():
            if arg.startswith("-D") and "=" in arg:
                name, value = arg[2:].split("=", 1)
                out.setdefault(pkg, {})[name.split(":", 1)[0]] = value
    return out


# The options users look for in a build: XRCE-DDS entity limits, history, MTU, transport.
MEMORY_PREFIXES = ("RMW_UXRCE_", "UCLIENT_")


def memory_options(options: Mapping[str, Mapping[str, str]]) -> dict[str, dict[str, str]]:
    out = {}
    for pkg, opts in options.items():
        picked = {k: v for k, v in opts.items() if k.startswith(MEMORY_PREFIXES)}
        if picked:
            out[pkg] = picked
    return out
