"""Status lines on the terminal (through rich): steps, notes, warnings, errors.

Status lines go to stderr so that ``--json`` output on stdout stays machine-readable (listings
and rendered files are written to stdout by their commands).
When stderr is not a terminal (CI, pipes), rich prints plain lines without colour.
"""

from __future__ import annotations

import builtins
import functools
import json
import os
import re
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console
    from rich.live import Live
    from rich.text import Text

_plain_lock = threading.Lock()
# What rich's emoji codes look like (``:name:``, rich.emoji's pattern without its variants): a line
# with one goes through rich, which may replace it.
_EMOJI_LIKE = re.compile(r":\S*?:")


@functools.cache
def _rich() -> Console:
    """rich's console for stderr, made on the first line that needs it: importing rich is ~0.05 s
    of CPU, a seventh of a command's start, and a command whose stderr is a pipe (CI, the tests,
    scripts) prints only lines :func:`_plain` writes as rich would."""
    from rich.console import Console

    return Console(stderr=True, highlight=False, soft_wrap=True)


def _is_terminal() -> bool:
    """What rich's Console.is_terminal answers for our console (rich 13-15: TTY_COMPATIBLE, then
    FORCE_COLOR, then isatty), True where it could be (Jupyter), so that a line rich would
    colour or render differently always goes through rich."""
    if hasattr(builtins, "get_ipython"):
        return True
    tty_compatible = os.environ.get("TTY_COMPATIBLE", "")
    if tty_compatible in ("0", "1"):
        return tty_compatible == "1"
    force_color = os.environ.get("FORCE_COLOR")
    if force_color is not None:
        return force_color != ""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def _plain(text: str) -> bool:
    """``text`` (plain, no markup) written as its line if that is exactly what rich would print
    (no terminal: no colour; printable characters only, so no tab to expand or control code to
    drop; no trailing whitespace, which rich crops past the width; nothing like an emoji code; no
    backslash, which rich's markup reads as an escape). False: the caller prints through rich."""
    if (
        not text.isprintable()
        or text != text.rstrip()
        or "\\" in text
        or _EMOJI_LIKE.search(text)
        or _is_terminal()
    ):
        return False
    with _plain_lock:
        sys.stderr.write(text + "\n")
        sys.stderr.flush()
    return True


def _print(prefix: str, markup: str, text: str, style: str | None = None) -> None:
    """A status line: ``prefix`` (plain) then ``text``, as rich prints ``markup`` + ``text``."""
    if not _plain(prefix + text):
        from rich.markup import escape

        _rich().print(markup + escape(text), style=style)


# The run's log also gets every status line, so that it says what uros decided (what changed, what
# was pruned, where the output came from, the final error) between the tools' output, as
# colcon-core's add_file_handler puts its own logger's lines in its per-run log.
_record: Path | None = None
_record_lock = threading.Lock()


def print_json(data: object) -> None:
    """``data`` as JSON on standard output, what every ``--json`` prints: indented, keys sorted
    (generated JSON is deterministic), one newline at the end."""
    sys.stdout.write(json.dumps(data, indent=2, sort_keys=True) + "\n")
    sys.stdout.flush()


def record_to(path: Path | None) -> None:
    """Append every status line to ``path`` from now on (None: stop)."""
    global _record
    _record = path


def _recorded(line: str) -> None:
    if _record is None:
        return
    try:
        with _record_lock, _record.open("a", encoding="utf-8") as log:
            log.write(f"uros: {line}\n")
    except OSError:
        pass  # a log that cannot be written must not stop the build (the disk-full path says why)


def logged(text: str) -> None:
    """Into the run log only (a long list a warning line sums up)."""
    for line in text.splitlines():
        _recorded(line)


def step(text: str) -> None:
    _recorded(f"==> {text}")
    _print("==> ", "[bold cyan]==>[/] ", text)


def info(text: str) -> None:
    _recorded(text)
    _print("", "", text)


def tool_line(text: str) -> None:
    """A line of an external tool's output, shown with --verbose."""
    _print("", "", text, style="dim")


def warn(text: str) -> None:
    _recorded(f"warning: {text}")
    _print("warning: ", "[yellow]warning:[/] ", text)


def error(text: str, hint: str | None) -> None:
    _recorded(f"error: {text}" + (f" (hint: {hint})" if hint else ""))
    _print("error: ", "[bold red]error:[/] ", text)
    if hint:
        _print("hint: ", "[bold]hint:[/] ", hint)


# ---------------------------------------------------------------------------------------------
# a build's progress


@dataclass(frozen=True)
class Progress:
    """Where a build stands: packages done of ``total``, those building now (name -> when they
    started, monotonic seconds) and when the build started."""

    done: int
    total: int
    running: tuple[tuple[str, float], ...]
    started: float
    failed: tuple[str, ...] = ()


def progress_text(progress: Progress, now: float, width: int = 100) -> Text:
    """The live view's text (pure): a bar, done/total, elapsed time, the packages building now
    with how long each has been at it, longest first."""
    from rich.text import Text

    total = max(progress.total, progress.done + len(progress.running), 1)
    cells = 24
    filled = min(cells, round(cells * progress.done / total))
    text = Text()
    text.append("[" + "#" * filled + "-" * (cells - filled) + "] ", style="cyan")
    text.append(f"{progress.done}/{total} packages", style="bold")
    text.append(f"  {_clock(now - progress.started)}")
    if progress.failed:
        text.append(f"  failed: {', '.join(progress.failed)}", style="bold red")
    building = sorted(progress.running, key=lambda item: item[1])
    if building:
        names = ", ".join(f"{name} {_clock(now - since)}" for name, since in building)
        line = f"building: {names}"
        text.append("\n" + (line if len(line) <= width else line[: width - 3] + "..."), style="dim")
    return text


def _clock(seconds: float) -> str:
    seconds = max(0.0, seconds)
    return f"{int(seconds // 60)}:{int(seconds % 60):02d}" if seconds >= 60 else f"{seconds:.0f}s"


class _LiveRenderable:
    def __init__(self, view: ProgressView) -> None:
        self.view = view

    def __rich__(self) -> Text:
        return progress_text(self.view.progress, time.monotonic(), _rich().width)


class ProgressView:
    """A build's progress on stderr: a live view redrawn four times a second on a terminal (the
    timers of the packages building now tick between colcon's lines); one plain line per
    finished or failed package otherwise (CI logs, pipes) or with ``plain``."""

    def __init__(self, total: int, plain: bool = False) -> None:
        self.progress = Progress(0, total, (), time.monotonic())
        self.live: Live | None = None
        if _is_terminal() and _rich().is_terminal and not plain:
            from rich.live import Live  # a terminal's live view only (start-up cost)

            self.live = Live(
                _LiveRenderable(self),
                console=_rich(),
                refresh_per_second=4,
                transient=True,
                redirect_stderr=False,
            )
            self.live.start()

    def update(self, progress: Progress, finished: tuple[str, str, float] | None = None) -> None:
        """``finished``: (what, package, seconds) of the package that just ended, for the plain line."""
        self.progress = progress
        if self.live is None and finished is not None:
            what, package, seconds = finished
            total = max(progress.total, progress.done + len(progress.running))
            _print("", "", f"[{progress.done}/{total}] {what} {package} ({seconds:.1f} s)")

    def stop(self) -> None:
        if self.live is not None:
            self.live.stop()
            self.live = None
