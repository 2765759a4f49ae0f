"""Status lines on the terminal (through rich): steps, notes, warnings, errors.

Status lines go to stderr so that ``--json`` output on stdout stays machine-readable (listings
and rendered files are written to stdout by their commands).
When stderr is not a terminal (CI, pipes), rich prints plain lines without colour.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape
from rich.text import Text

if TYPE_CHECKING:
    from rich.live import Live

_err = Console(stderr=True, highlight=False, soft_wrap=True)
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
    _err.print(f"[bold cyan]==>[/] {escape(text)}")


def info(text: str) -> None:
    _recorded(text)
    _err.print(escape(text))


def tool_line(text: str) -> None:
    """A line of an external tool's output, shown with --verbose."""
    _err.print(escape(text), style="dim")


def warn(text: str) -> None:
    _recorded(f"warning: {text}")
    _err.print(f"[yellow]warning:[/] {escape(text)}")


def error(text: str, hint: str | None) -> None:
    _recorded(f"error: {text}" + (f" (hint: {hint})" if hint else ""))
    _err.print(f"[bold red]error:[/] {escape(text)}")
    if hint:
        _err.print(f"[bold]hint:[/] {escape(hint)}")


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
        return progress_text(self.view.progress, time.monotonic(), _err.width)


class ProgressView:
    """A build's progress on stderr: a live view redrawn four times a second on a terminal (the
    timers of the packages building now tick between colcon's lines); one plain line per
    finished or failed package otherwise (CI logs, pipes) or with ``plain``."""

    def __init__(self, total: int, plain: bool = False) -> None:
        self.progress = Progress(0, total, (), time.monotonic())
        self.live: Live | None = None
        if _err.is_terminal and not plain:
            from rich.live import Live  # a terminal's live view only (start-up cost)

            self.live = Live(
                _LiveRenderable(self),
                console=_err,
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
            _err.print(escape(f"[{progress.done}/{total}] {what} {package} ({seconds:.1f} s)"))

    def stop(self) -> None:
        if self.live is not None:
            self.live.stop()
            self.live = None
