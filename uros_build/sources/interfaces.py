"""ROS 2 interface packages: check .msg/.srv files and scaffold a package (pure).

rosidl's own errors surface deep in a CMake stack; checking the files' shape first gives the file,
the line and the rule. The rules follow rosidl_adapter's parser
(https://github.com/ros2/rosidl/blob/humble/rosidl_adapter/rosidl_adapter/parser.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from uros_build import __version__, loader
from uros_build.errors import ConfigError

PRIMITIVES = {
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
    "int64", "uint64", "string", "wstring",
}  # fmt: skip
_TYPE = re.compile(
    r"^(?:(?P<pkg>[a-z][a-z0-9_]*)/)?(?P<base>[A-Za-z][A-Za-z0-9_]*)(?:<=\d+)?(?P<array>\[(?:<=)?\d*\])?$"
)
_CONSTANT_DEF = re.compile(r"^(?P<name>\w+)\s*=\s*\S")
_FIELD = re.compile(r"^[a-z][a-z0-9]*(_[a-z0-9]+)*$")
_CONST = re.compile(r"^[A-Z][A-Z0-9]*(_[A-Z0-9]+)*$")
_TYPE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
_PACKAGE = re.compile(r"^[a-z][a-z0-9]*(_[a-z0-9]+)*$")


@dataclass(frozen=True)
class InterfaceFile:
    kind: str  # msg | srv
    name: str  # CamelCase type name
    text: str
    dependencies: tuple[str, ...]  # packages its fields refer to
    source: str = ""  # the flag and file it came from, for messages


def _check_lines(lines: list[tuple[int, str]], source: str) -> set[str]:
    """The dependencies of one message (a .msg, or one half of a .srv); a ConfigError naming the
    line of the first problem."""
    deps: set[str] = set()
    names: dict[str, int] = {}  # field or constant -> its line: rosidl refuses a name given twice
    for number, raw in lines:
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split(None, 1)
        if len(parts) < 2:
            raise ConfigError(f"{source}:{number}: expected 'TYPE NAME', got {line!r}")
        type_text, rest = parts
        match = _TYPE.match(type_text)
        if match is None:
            raise ConfigError(f"{source}:{number}: {type_text!r} is not a valid field type")
        base, pkg = match.group("base"), match.group("pkg")
        if pkg is None and base not in PRIMITIVES and not _TYPE_NAME.match(base):
            raise ConfigError(
                f"{source}:{number}: unknown type {base!r}", f"primitives: {', '.join(sorted(PRIMITIVES))}"
            )
        if pkg is not None:
            deps.add(pkg)
        constant = _CONSTANT_DEF.match(rest)
        if constant is not None:
            name = constant.group("name")
            if not _CONST.match(name):
                raise ConfigError(f"{source}:{number}: constant {name!r} must be UPPER_CASE")
            if pkg is not None or base not in PRIMITIVES or match.group("array") is not None:
                raise ConfigError(
                    f"{source}:{number}: constant {name!r} must have a primitive type, no array"
                )
            _once(names, name, number, source, "constant")
            value = rest.split("=", 1)[1].strip()
            _check_default(base, value, f"{source}:{number}", "constant value")
            continue
        name, *default = rest.split(None, 1)
        if not _FIELD.match(name):
            raise ConfigError(
                f"{source}:{number}: field name {name!r} is invalid",
                "field names are lower_snake_case, start with a letter, no double or trailing underscore",
            )
        _once(names, name, number, source, "field")
        if default:
            where, value, array = f"{source}:{number}", default[0].strip(), match.group("array")
            if pkg is not None or base not in PRIMITIVES:  # rosidl: "not supported", deep in CMake
                raise ConfigError(
                    f"{where}: field {name!r} of type {type_text!r} cannot have a default value",
                    "only primitive types (and arrays of them) take one",
                )
            if array is None:
                _check_default(base, value, where)
            else:
                _check_array_default(base, array, value, where)
    return deps


def _check_array_default(base: str, array: str, value: str, where: str) -> None:
    """An array's default as rosidl_adapter reads it (parse_value_string): ``[a, b]``, as many
    elements as a fixed size says (at most a bound's), each a valid value of the type."""
    if not (value.startswith("[") and value.endswith("]")):
        raise ConfigError(f"{where}: default value {value!r} of an array is not in [ ]", "e.g. [1, 2, 3]")
    inner = value[1:-1]
    if base in ("string", "wstring"):
        items = _string_items(inner, value, where)
    else:
        items = [v.strip() for v in inner.split(",")] if inner else []
    size = array[1:-1]
    if size:
        bound = int(size.removeprefix("<="))
        if len(items) > bound or (not size.startswith("<=") and len(items) != bound):
            raise ConfigError(
                f"{where}: default value {value!r} has {len(items)} elements; the type's {array} "
                f"holds {'at most' if size.startswith('<=') else 'exactly'} {bound}"
            )
    for item in items:
        if base not in ("string", "wstring"):
            _check_default(base, item, where, "array element")


def _string_items(inner: str, value: str, where: str) -> list[str]:
    """The elements of a string array's default: quoted ones may hold ',' (rosidl's
    parse_string_array_value_string); a quote opened and never closed is refused."""
    items, rest = [], inner.strip()
    while rest:
        quote = rest[0]
        if quote in ("'", '"'):
            end = 1
            while True:
                end = rest.find(quote, end)
                if end == -1:
                    raise ConfigError(
                        f"{where}: default value {value!r}: the string {rest!r} is not closed",
                        f"end it with {quote}; a '#' starts a comment even inside quotes",
                    )
                if rest[end - 1] != "\\":
                    break
                end += 1
            items.append(rest[1:end])
            rest = rest[end + 1 :].lstrip()
            if rest and not rest.startswith(","):
                raise ConfigError(f"{where}: default value {value!r}: expected ',' after {items[-1]!r}")
            rest = rest[1:].lstrip()
        else:
            item, _comma, rest = rest.partition(",")
            items.append(item.strip())
            rest = rest.lstrip()
    return items


def _once(names: dict[str, int], name: str, number: int, source: str, what: str) -> None:
    """rosidl_adapter's MessageSpecification refuses duplicate field names (and constant names),
    deep in a CMake stack; uros names both lines."""
    if name in names:
        raise ConfigError(
            f"{source}:{number}: {what} {name!r} is already defined on line {names[name]}",
            "give every field and constant of a message its own name",
        )
    names[name] = number


_INTEGERS = {"byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64"}


def _check_default(type_name: str, value: str, where: str, what: str = "default value") -> None:
    """The value rules rosidl_adapter applies to scalar primitives, for defaults and constants
    alike (parse_primitive_value_string)."""
    problem = None
    if type_name in _INTEGERS:
        try:
            number = int(value, 0)
        except ValueError:
            problem = "is not an integer"
        else:
            bits = int(type_name.removeprefix("u").removeprefix("int")) if "int" in type_name else 8
            low, high = (
                (0, 2**bits - 1)
                if type_name.startswith("u") or type_name in ("byte", "char")
                else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
            )
            if not low <= number <= high:
                problem = f"is outside {low}..{high}"
    elif type_name in ("float32", "float64"):
        try:
            float(value)
        except ValueError:
            problem = "is not a number"
    elif type_name == "bool" and value.lower() not in ("true", "false", "0", "1"):
        problem = "is not true/false"
    elif type_name in ("string", "wstring"):
        _check_string(value, where, what)
    if problem:
        raise ConfigError(f"{where}: {what} {value!r} {problem} for type {type_name}")


def _check_string(value: str, where: str, what: str) -> None:
    """rosidl takes a string value between quotes (' or "), with inner quotes of that kind escaped
    (parse_primitive_value_string); one that opens a quote and never closes it is kept as it
    stands, quote included, which no one means. A '#' ends the line even inside quotes: rosidl
    cuts comments first, so ``"a # b"`` reaches it as ``"a``."""
    quote = value[:1]
    if quote not in ("'", '"'):
        return
    if len(value) < 2 or not value.endswith(quote):
        raise ConfigError(
            f"{where}: {what} {value!r}: the string is not closed",
            f"end it with {quote}; a '#' starts a comment even inside quotes (rosidl cuts the line there)",
        )
    if re.search(rf"(?<!\\){quote}", value[1:-1]):
        raise ConfigError(
            f"{where}: {what} {value!r}: a {quote} inside the string is not escaped",
            f"write it as \\{quote}, or quote the string with the other kind of quote",
        )


def read_interface(path: Path, kind: str) -> InterfaceFile:
    flag = f"--{kind}"
    if not path.is_file():
        raise ConfigError(f"{flag} {path}: no such file")
    if path.suffix != f".{kind}":
        raise ConfigError(f"{flag} {path}: expected a .{kind} file")
    if not _TYPE_NAME.match(path.stem):
        raise ConfigError(
            f"{flag} {path}: {path.stem!r} is not a valid type name", "use CamelCase, e.g. CmdVel.msg"
        )
    text = loader.read_text(path, flag, "rosidl reads interface files as UTF-8: save it so")
    lines = list(enumerate(text.splitlines(), start=1))
    if kind == "srv":
        separators = [n for n, line in lines if line.strip() == "---"]
        if len(separators) != 1:
            raise ConfigError(f"{path}: a .srv needs one '---' line between request and response")
    deps: set[str] = set()
    # a .srv's request and response are two messages: each may use a name the other uses
    part: list[tuple[int, str]] = []
    for number, line in [*lines, (0, "---")]:
        if line.strip() == "---":
            deps |= _check_lines(part, str(path))
            part = []
        else:
            part.append((number, line))
    return InterfaceFile(kind, path.stem, text, tuple(sorted(deps)), f"{flag} {path}")


def package_files(name: str, files: list[InterfaceFile]) -> dict[str, str]:
    """Relative path -> text of an interface package (pure)."""
    if not _PACKAGE.match(name):
        raise ConfigError(f"interface new: {name!r} is not a valid package name", "use lower_snake_case")
    if not files:
        raise ConfigError("interface new: no interface files given", "pass --msg FILE.msg and/or --srv FILE")
    given: dict[tuple[str, str], InterfaceFile] = {}
    for f in files:
        first = given.setdefault((f.kind, f.name), f)
        if first is not f:  # both would be written to msg/<Name>.msg: one would be lost
            raise ConfigError(
                f"{f.source}: a second {f.name}.{f.kind} (the first: {first.source})",
                f"give each {f.kind} file once, and different types different names",
            )
    deps = sorted({d for f in files for d in f.dependencies} - {name})
    depend_xml = "".join(f"  <depend>{d}</depend>\n" for d in deps)
    package_xml = f"""<?xml version="1.0"?>
<!-- Generated by uros {__version__} interface new. -->
<package format="3">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>Custom interfaces for micro-ROS firmware</description>
  <maintainer email="firmware@example.com">firmware</maintainer>
  <license>Apache-2.0</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
{depend_xml}  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""
    ordered = sorted(files, key=lambda f: (f.kind, f.name))
    listed = "\n".join(f'  "{f.kind}/{f.name}.{f.kind}"' for f in ordered)
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in deps)
    dep_arg = f"\n  DEPENDENCIES {' '.join(deps)}" if deps else ""
    cmake = f"""# Generated by uros {__version__} interface new.
cmake_minimum_required(VERSION 3.8)
project({name})

find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
{finds}
rosidl_generate_interfaces(${{PROJECT_NAME}}
{listed}{dep_arg}
)

ament_export_dependencies(rosidl_default_runtime)
ament_package()
"""
    out = {"package.xml": package_xml, "CMakeLists.txt": cmake}
    for f in files:
        out[f"{f.kind}/{f.name}.{f.kind}"] = f.text
    return out
