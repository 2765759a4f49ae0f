"""A small reader of CMake's language, enough to check what uros renders: which commands a file
runs, and the exact value of every quoted argument (cmake-language(7): quoted arguments, escape
sequences, variable references, line comments). Tests use it to prove that a hostile value stays
one value: it never adds a command and never becomes a variable reference."""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field

_ESCAPES = {"n": "\n", "r": "\r", "t": "\t", "\\": "\\", '"': '"', "$": "$", " ": " ", "(": "(", ")": ")"}


@dataclass
class Command:
    name: str
    args: list[str] = field(default_factory=list)
    quoted: list[bool] = field(default_factory=list)
    expands: list[bool] = field(default_factory=list)  # the argument holds a ${...} / $ENV{...}


def parse(text: str) -> list[Command]:
    commands: list[Command] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "#":
            i = text.find("\n", i)
            i = n if i < 0 else i
            continue
        m = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\s*\(").match(text, i)
        if m is None:
            if not c.isspace():
                raise ValueError(f"not CMake at {i}: {text[i : i + 40]!r}")
            i += 1
            continue
        cmd = Command(m.group(0).rstrip("( \t"))
        i, depth = m.end(), 1
        while depth:
            c = text[i]
            if c == '"':
                value, expands, i = _quoted(text, i + 1)
                cmd.args.append(value)
                cmd.quoted.append(True)
                cmd.expands.append(expands)
            elif c == "(":
                depth += 1
                i += 1
            elif c == ")":
                depth -= 1
                i += 1
            elif c == "#":
                i = text.index("\n", i)
            elif c.isspace():
                i += 1
            else:
                start = i
                while i < n and not text[i].isspace() and text[i] not in '()"#':
                    i += 2 if text[i] == "\\" else 1
                word = text[start:i]
                cmd.args.append(word)
                cmd.quoted.append(False)
                cmd.expands.append("${" in word.replace("\\$", ""))
        commands.append(cmd)
    return commands


def _quoted(text: str, i: int) -> tuple[str, bool, int]:
    out, expands = [], False
    while True:
        c = text[i]
        if c == '"':
            return "".join(out), expands, i + 1
        if c == "\\":
            nxt = text[i + 1]
            if nxt == "\n":  # line continuation
                i += 2
                continue
            if nxt not in _ESCAPES and not re.match(r"[^A-Za-z0-9;]", nxt):
                raise ValueError(f"invalid escape \\{nxt}")
            out.append(_ESCAPES.get(nxt, nxt) if nxt != ";" else "\\;")
            i += 2
            continue
        if c == "$" and (text.startswith("${", i) or re.match(r"\$[A-Z]*\{", text[i:])):
            expands = True
        out.append(c)
        i += 1


def set_values(text: str) -> dict[str, str]:
    """NAME -> value of every ``set(NAME "value" ...)``."""
    return {c.args[0]: c.args[1] for c in parse(text) if c.name == "set" and len(c.args) > 1 and c.quoted[1]}


def flags_as_compiled(value: str) -> list[str]:
    """What the compiler receives from a CMAKE_<LANG>_FLAGS value: ninja and make turn '$$' into
    '$' (a lone '$' would be their own variable), then /bin/sh splits the words."""
    assert "$" not in value.replace("$$", ""), f"a lone $ in {value!r}"
    return shlex.split(value.replace("$$", "$"))
