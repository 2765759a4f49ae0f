"""The build's live view, rendered from a snapshot (pure)."""

from __future__ import annotations

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
