"""Jinja2 environment over the shipped ``templates/`` folder (strict: an undefined name is a bug)."""

from __future__ import annotations

import shlex
from collections.abc import Iterable
from functools import cache
from typing import Any

import jinja2

from uros_build import resources


def cmake_quote(text: str) -> str:
    """A CMake quoted-argument body: escape what CMake would interpret."""
    return text.replace("\\", "\\\\").replace('"', '\\"').replace("$", "\\$")


def cmake_flags(flags: Iterable[str]) -> str:
    """Join compiler flags into one CMake flags string, safe for the shell CMake's generators use.

    Flags are kept as a list until here; a flag with a space, quote or ';' is shell-quoted as one
    word so that it reaches the compiler intact (never split, never run as a command).
    """
    words = []
    for flag in flags:
        safe = all(c.isalnum() or c in "-_=+./,:@%^" for c in flag)
        words.append(flag if safe and flag else shlex.quote(flag))
    return cmake_quote(" ".join(words))


@cache
def _env() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(resources.templates_dir())),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["cmake_flags"] = cmake_flags
    env.filters["cmake_quote"] = cmake_quote
    return env


def render(template: str, **context: Any) -> str:
    return _env().get_template(template).render(**context)
