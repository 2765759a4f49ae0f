"""Status lines on the terminal (through rich): steps, notes, warnings, errors.

Status lines go to stderr so that ``--json`` output on stdout stays machine-readable (listings
and rendered files are written to stdout by their commands).
When stderr is not a terminal (CI, pipes), rich prints plain lines without colour.
"""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape

_err = Console(stderr=True, highlight=False, soft_wrap=True)


def step(text: str) -> None:
    _err.print(f"[bold cyan]==>[/] {escape(text)}")


def info(text: str) -> None:
    _err.print(escape(text))


def tool_line(text: str) -> None:
    """A line of an external tool's output, shown with --verbose."""
    _err.print(escape(text), style="dim")


def warn(text: str) -> None:
    _err.print(f"[yellow]warning:[/] {escape(text)}")


def error(text: str, hint: str | None) -> None:
    _err.print(f"[bold red]error:[/] {escape(text)}")
    if hint:
        _err.print(f"[bold]hint:[/] {escape(hint)}")
