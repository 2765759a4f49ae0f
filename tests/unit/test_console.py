"""The build's live view, rendered from a snapshot (pure); status lines as rich prints them."""

from __future__ import annotations

import io
import random
import sys

import pytest

from uros_build.console import Progress, progress_text


def test_progress_text_shows_done_total_elapsed_and_who_is_building() -> None:
    text = progress_text(Progress(3, 10, (("rcl", 95.0), ("rclc", 80.0)), started=0.0), now=100.0).plain
    first, second = text.splitlines()
    assert first.startswith("[#######-----------------] 3/10 packages  1:40")
    assert second == "building: rclc 20s, rcl 5s"  # the longest-running first


def test_progress_text_never_shows_more_done_than_total_and_names_failures() -> None:
    text = progress_text(Progress(6, 5, (), started=0.0, failed=("fx_util",)), now=3.0).plain
    assert "6/6 packages" in text and "failed: fx_util" in text and "building" not in text


def test_progress_text_fits_the_width() -> None:
    running = tuple((f"package_{i}", 0.0) for i in range(40))
    text = progress_text(Progress(0, 40, running, started=0.0), now=1.0, width=60).plain
    assert len(text.splitlines()[1]) == 60 and text.endswith("...")


# Lines that a start prints without importing rich must be the bytes rich prints (issue 38: rich's
# import was a seventh of a command's CPU). Rich's own rendering is the reference here.
_TRICKY = [
    "",
    "plain words",
    "up to date: /ws/build/cortex-m7 (no input changed since its build; --rebuild forces one)",
    "[bold]not markup[/bold] [/] [link=x] \\[escaped] trailing backslash \\",
    "a\\",
    "a\\\\",
    "\\[x]",
    "emoji :smile: and :thumbs_up: and a:b:c and :not_an_emoji: and http://host:80/x",
    "C:\\path:with:colons",
    "tab\there",
    "carriage\rreturn",
    "bell\x07 escape\x1b[31m red",
    "two\nlines",
    "ends with a newline\n",
    "trailing space ",
    "x" * 200 + " ",
    "wide ✓ 日本語 ünïcødé and a non-breaking\xa0space",
    "  leading spaces",
    "[1/5] built fx_util (0.3 s)",
]
# and strings made of what markup, escapes, emoji codes and wrapping are made of (a fixed seed)
_rng = random.Random(38)
_TRICKY += ["".join(_rng.choice("[]\\/:= a#@b\t") for _ in range(_rng.randrange(12))) for _ in range(400)]


def test_plain_lines_are_what_rich_prints(monkeypatch: pytest.MonkeyPatch) -> None:
    from rich.console import Console
    from rich.markup import escape

    from uros_build import console

    for name in ("TTY_COMPATIBLE", "FORCE_COLOR", "NO_COLOR", "COLUMNS"):
        monkeypatch.delenv(name, raising=False)
    for prefix, markup in (("", ""), ("==> ", "[bold cyan]==>[/] "), ("warning: ", "[yellow]warning:[/] ")):
        for text in _TRICKY:
            reference = io.StringIO()
            Console(file=reference, highlight=False, soft_wrap=True).print(markup + escape(text))
            ours = io.StringIO()
            monkeypatch.setattr(sys, "stderr", ours)
            console._print(prefix, markup, text)
            monkeypatch.undo()
            for name in ("TTY_COMPATIBLE", "FORCE_COLOR", "NO_COLOR", "COLUMNS"):
                monkeypatch.delenv(name, raising=False)
            assert ours.getvalue() == reference.getvalue(), (prefix, text)


def test_a_terminal_or_forced_colour_goes_through_rich(monkeypatch: pytest.MonkeyPatch) -> None:
    from uros_build import console

    monkeypatch.setattr(sys, "stderr", io.StringIO())
    monkeypatch.delenv("TTY_COMPATIBLE", raising=False)
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert console._plain("text") is False
    monkeypatch.setenv("FORCE_COLOR", "")
    assert console._plain("text") is True
    monkeypatch.setenv("TTY_COMPATIBLE", "1")
    assert console._plain("text") is False
