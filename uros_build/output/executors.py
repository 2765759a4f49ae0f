"""A firmware's rclc executors against the handles they were initialised for (pure): the executors
its calls initialise (``rclc_executor_init``'s ``number_of_handles``, a C expression evaluated over the
firmware's ``#define``s and the library's) and add to (every ``rclc_executor_add_*`` takes 1 handle, a
parameter server the library's ``RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES``); the one past
``number_of_handles`` returns RCL_RET_ERROR ("Buffer overflow of 'executor->handles'",
rclc/src/rclc/executor.c, humble). output/fit.py puts them beside the library's pools.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

from uros_build.sources.firmware_scan import Call, FirmwareUse

# RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES in humble's rclc_parameter.h; later rclc names it
# RCLC_PARAMETER_EXECUTOR_HANDLES_NUMBER. Read from the library's own header when it has one.
PARAMETER_HANDLES_MACROS = (
    "RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES",
    "RCLC_PARAMETER_EXECUTOR_HANDLES_NUMBER",
)
PARAMETER_HANDLES_DEFAULT = 5
PARAMETER_HEADERS = ("rclc_parameter/rclc_parameter.h", "rclc_parameter/rclc_parameter/rclc_parameter.h")


def parameter_handles(headers: Mapping[str, Mapping[str, str]]) -> int:
    """The handles a parameter server takes in an executor, from the library's rclc_parameter.h."""
    for header in PARAMETER_HEADERS:
        for macro in PARAMETER_HANDLES_MACROS:
            value = headers.get(header, {}).get(macro)
            if value is not None and value.isdigit():
                return int(value)
    return PARAMETER_HANDLES_DEFAULT


_TOKEN = re.compile(r"\s*(?:(0[xX][0-9a-fA-F]+|[0-9]+)[uUlL]*|([A-Za-z_]\w*)|(.))")


def evaluate(expr: str, defines: Mapping[str, str], depth: int = 0) -> int | None:
    """A whole-number C expression of literals, ``#define``d names, ``+ - *`` and parentheses
    (an executor's ``number_of_handles``), or None when it is anything else."""
    if depth > 8:
        return None
    tokens: list[int | str] = []
    for match in _TOKEN.finditer(expr.strip()):
        number, name, other = match.groups()
        if number is not None:
            octal = len(number) > 1 and number[0] == "0" and number[1] not in "xX"
            tokens.append(int(number, 8) if octal else int(number, 0))
        elif name is not None:
            if name not in defines:
                return None
            value = evaluate(defines[name], defines, depth + 1)
            if value is None:
                return None
            tokens.append(value)
        elif other is not None and other.strip():
            if other not in "+-*()":
                return None
            tokens.append(other)
    return _Parser(tokens).parse()


class _Parser:
    """expr := term (('+'|'-') term)*; term := unary ('*' unary)*; unary := '-' unary | atom."""

    def __init__(self, tokens: list[int | str]) -> None:
        self.tokens, self.at = tokens, 0

    def parse(self) -> int | None:
        try:
            value = self._expr()
        except (IndexError, ValueError):
            return None
        return value if self.at == len(self.tokens) else None

    def _take(self) -> int | str:
        token = self.tokens[self.at]
        self.at += 1
        return token

    def _peek(self) -> int | str | None:
        return self.tokens[self.at] if self.at < len(self.tokens) else None

    def _expr(self) -> int:
        value = self._term()
        while self._peek() in ("+", "-"):
            value = value + self._term() if self._take() == "+" else value - self._term()
        return value

    def _term(self) -> int:
        value = self._unary()
        while self._peek() == "*":
            self._take()
            value *= self._unary()
        return value

    def _unary(self) -> int:
        token = self._take()
        if token == "-":
            return -self._unary()
        if token == "(":
            value = self._expr()
            if self._take() != ")":
                raise ValueError("unbalanced")
            return value
        if isinstance(token, int):
            return token
        raise ValueError(f"unexpected {token}")


@dataclass(frozen=True)
class Executor:
    """An executor (by the name of its first argument) and the handles its adds take."""

    name: str
    init: Call | None  # None: added to, never initialised in the sources read
    handles: int | None  # what it was initialised for (None: not a number uros can read)
    adds: tuple[tuple[Call, int], ...] = field(default_factory=tuple)

    @property
    def given(self) -> int:
        return sum(n for _, n in self.adds)

    @property
    def short(self) -> bool:
        return self.handles is not None and self.given > self.handles


def _object(arg: str) -> str:
    """``&executor`` / ``& app.executor`` -> ``executor`` / ``app.executor``."""
    return arg.lstrip("&* ").replace(" ", "")


def executors(use: FirmwareUse, parameter_handles: int) -> list[Executor]:
    """Each executor the firmware initialises or adds to, with its adds' handles: 1 each, a
    parameter server's ``parameter_handles``."""
    defines = {**{m: str(parameter_handles) for m in PARAMETER_HANDLES_MACROS}, **use.defines}
    inits: dict[str, Call] = {}
    adds: dict[str, list[tuple[Call, int]]] = {}
    for call in use.calls:
        if not call.args:
            continue
        name = _object(call.args[0])
        if call.function == "rclc_executor_init":
            inits.setdefault(name, call)
        elif call.function.startswith("rclc_executor_add_"):
            took = parameter_handles if "parameter_server" in call.function else 1
            adds.setdefault(name, []).append((call, took))
    out = []
    for name in [*inits, *(n for n in adds if n not in inits)]:
        init = inits.get(name)
        handles = evaluate(init.args[2], defines) if init is not None and len(init.args) > 2 else None
        out.append(Executor(name, init, handles, tuple(adds.get(name, ()))))
    return out


def executor_line(executor: Executor) -> tuple[bool, str]:
    """(is it a warning, the line) for one executor."""
    adds = executor.adds
    given = executor.given
    if executor.init is None:
        return False, (
            f"{executor.name}: {len(adds)} rclc_executor_add_* calls ({given} handles, first at "
            f"{adds[0][0].where}); its rclc_executor_init is not in the sources read"
        )
    where, size = executor.init.where, executor.init.args[2] if len(executor.init.args) > 2 else "?"
    if executor.handles is None:
        return False, (
            f"{where}: {executor.name} is initialised for {size} handles (not a number uros can read) "
            f"and given {given}"
        )
    if not executor.short:
        return (
            False,
            f"{where}: {executor.name} is initialised for {executor.handles} handles and given {given}",
        )
    running, failing = 0, adds[-1][0]
    for call, handles in adds:
        running += handles
        if running > executor.handles:
            failing = call
            break
    return True, (
        f"{where}: {executor.name} is initialised for {executor.handles} handles and given {given}: "
        f'{failing.function} at {failing.where} returns RCL_RET_ERROR ("Buffer overflow of '
        f"'executor->handles'\"); initialise it for {given}"
    )
