"""Jinja2 environment over the shipped ``templates/`` folder (strict: an undefined name is a bug),
and the escapes every value rendered into a CMake file goes through.

A value reaches a CMake file in one of three places, each with its own escape:

- inside a quoted argument (``set(X "...")``): :func:`cmake_quote`;
- inside a ``#`` comment: :func:`cmake_comment` (a line break would end the comment and start code);
- in a compile-flags string (``CMAKE_<LANG>_FLAGS_INIT``): :func:`cmake_flags`, which also escapes
  for the shell and for the build tool, since CMake writes these strings into build.ninja or
  flags.make verbatim ("a command-line string fragment",
  https://cmake.org/cmake/help/latest/variable/CMAKE_LANG_FLAGS_INIT.html).
"""

from __future__ import annotations

import json
import re
import shlex
from collections.abc import Iterable
from functools import cache
from typing import TYPE_CHECKING, Any

from uros_build import resources
from uros_build.errors import ConfigError

if TYPE_CHECKING:
    import jinja2

_QUOTED_ESCAPES = {"\\": "\\\\", '"': '\\"', "$": "\\$", "\n": "\\n", "\r": "\\r", "\t": "\\t"}
# What CMake itself cannot carry in a path (a tool, a source or build folder, the toolchain file):
# it writes such paths unescaped into files it reads back (CMakeFiles/<version>/CMakeSystem.cmake
# include()s the toolchain file, CMake<LANG>Compiler.cmake sets the compiler) and into build
# files. Measured with CMake 3.25 and both generators: '"' and '\' break those files, ';' splits
# the path into a list, '${...}', '$ENV{...}' and '$(...)' are expanded; a plain '$x' works.
_PATH_UNUSABLE = re.compile(r'["\\;]|\$[A-Za-z_]*\{|\$\(')


def cmake_unusable(path: str) -> str | None:
    """The part of ``path`` that CMake cannot use in a path, or None."""
    found = _PATH_UNUSABLE.search(path)
    return found.group(0) if found else None


def _control(text: str) -> str | None:
    return next((c for c in text if ord(c) < 32 or ord(c) == 127), None)


def cmake_quote(text: str) -> str:
    """The body of a CMake quoted argument holding exactly ``text``: nothing in it is expanded
    (``${...}``, ``$ENV{...}``), nothing ends the argument, and a line break stays an escape, so
    the value cannot become code (https://cmake.org/cmake/help/latest/manual/cmake-language.7.html#quoted-argument)."""
    bad = _control(text.replace("\n", "").replace("\r", "").replace("\t", ""))
    if bad is not None:
        raise ConfigError(
            f"{text!r}: holds the control character {bad!r}, which cannot be written into a CMake file",
            "remove it from the name, path or flag",
        )
    return "".join(_QUOTED_ESCAPES.get(c, c) for c in text)


def cmake_comment(text: str) -> str:
    """``text`` for a ``#`` comment: anything unprintable (a line break would end the comment and
    make the rest CMake code) is shown as its Python escape."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def cmake_path(text: str) -> str:
    """A tool path for a quoted argument; a path CMake itself cannot use is refused."""
    bad = cmake_unusable(text)
    if bad is not None:
        raise ConfigError(
            f"{text}: CMake cannot use a tool path containing {bad!r}",
            "move or link the toolchain to a folder without it (and point --compiler-prefix there)",
        )
    return cmake_quote(text)


def shell_words(flags: Iterable[str]) -> str:
    """Compiler flags as one shell command-line fragment: a flag with a space, quote, ';' or '$' is
    single-quoted as one word, so that it reaches the compiler intact (never split, never
    expanded, never run as a command)."""
    words = []
    for flag in flags:
        bad = _control(flag)
        if bad is not None:
            raise ConfigError(
                f"compiler flag {flag!r}: holds the control character {bad!r}",
                "one flag per --cflags / list entry, without line breaks or tabs",
            )
        safe = all(c.isalnum() or c in "-_=+./,:@%^" for c in flag)
        words.append(flag if safe and flag else shlex.quote(flag))
    return " ".join(words)


def cmake_flags(flags: Iterable[str]) -> str:
    """Compile flags for ``CMAKE_<LANG>_FLAGS_INIT`` (quoted-argument body).

    Three layers: the shell (:func:`shell_words`), the build tool, and CMake's quoted argument.
    CMake copies these flags unescaped into build.ninja (``FLAGS = ...``) and flags.make
    (``C_FLAGS = ...``), where ninja and make both read ``$5``/``$x``/``${HOME}`` as their own
    variables and ``$$`` as one ``$`` (https://ninja-build.org/manual.html#ref_lexer,
    https://www.gnu.org/software/make/manual/html_node/Reference.html); so every ``$`` is doubled.
    Only Ninja and Makefile generators are meant (the toolchain file checks the generator where
    a flag holds a ``$``). Linker flags are not for this filter: see :func:`cmake_link_flags`.
    """
    return cmake_quote(shell_words(flags).replace("$", "$$"))


def cmake_link_flags(flags: Iterable[str]) -> str:
    """Linker flags for ``CMAKE_EXE_LINKER_FLAGS_INIT``: CMake itself escapes ``$`` in these for
    Ninja (``LINK_FLAGS = ...$$...``), and the Makefile generators run link lines from link.txt
    without make, so a ``$`` is written once (measured with CMake 3.25, both generators)."""
    return cmake_quote(shell_words(flags))


def make_flags(flags: Iterable[str]) -> str:
    """Flags for a make variable, run by the shell: shell words (:func:`shell_words`), then ``$``
    doubled (make's own variables) and ``#`` escaped (a comment otherwise)
    (https://www.gnu.org/software/make/manual/html_node/Reference.html)."""
    return shell_words(flags).replace("$", "$$").replace("#", "\\#")


# What pkg-config cannot pass on: pkgconf splits a field like a shell, then prints the words for a
# shell to read with only some characters escaped (measured with pkgconf 1.8.1: '$', '(' and ')'
# come out bare, quotes and '\\' garbled, '#' starts a comment in a variable's line; '$$' stays two).
_PC_UNUSABLE = "$()#'\"\\`"


def pc_flags(flags: Iterable[str]) -> str:
    """Flags for a pkg-config field: shell words (pkg-config splits them like a shell); a flag
    holding a character pkg-config cannot pass on to the compiler is refused."""
    for flag in flags:
        bad = next((c for c in flag if c in _PC_UNUSABLE), None)
        if bad is not None:
            raise ConfigError(
                f"flag {flag!r}: holds {bad!r}, which pkg-config cannot pass on (pkgconf prints it "
                "unescaped or garbled into the compile line a shell reads)",
                "use `uros export cmake` or `uros export make` for this output",
            )
    return shell_words(flags)


def meson_string(text: str) -> str:
    """A Meson string literal holding exactly ``text`` (single-quoted; backslash and quote escaped)
    (https://mesonbuild.com/Syntax.html#strings)."""
    bad = _control(text)
    if bad is not None:
        raise ConfigError(f"{text!r}: holds the control character {bad!r}", "remove it from the flag or path")
    return "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"


def meson_list(items: Iterable[str]) -> str:
    return "[" + ", ".join(meson_string(i) for i in items) + "]"


def python_literal(value: str | list[str] | dict[str, str]) -> str:
    """A Python literal of strings, lists and dicts of strings: JSON's escapes (ASCII only, every
    quote, backslash and control character escaped) are Python's, so the value stays data."""
    return json.dumps(value, sort_keys=True)


@cache
def _env() -> jinja2.Environment:
    import jinja2  # on the first render: most starts render nothing (start-up cost, ~0.04 s)

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(resources.templates_dir())),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["cmake_flags"] = cmake_flags
    env.filters["cmake_link_flags"] = cmake_link_flags
    env.filters["cmake_quote"] = cmake_quote
    env.filters["cmake_comment"] = cmake_comment
    env.filters["cmake_path"] = cmake_path
    env.filters["make_flags"] = make_flags
    env.filters["pc_flags"] = pc_flags
    env.filters["meson_string"] = meson_string
    env.filters["meson_list"] = meson_list
    env.filters["python_literal"] = python_literal
    # a shell script's words (the uros-python shim): one word each, never split or expanded
    env.filters["sh_quote"] = shlex.quote
    env.filters["sh_join"] = shlex.join
    return env


def render(template: str, **context: Any) -> str:
    return _env().get_template(template).render(**context)
