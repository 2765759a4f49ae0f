"""The lossy link's pure pieces (run/relay.py, issue 40 item 4): the fault plan as written on the
command line, the XRCE serial frames cut from a byte stream, and the seeded faults applied to them."""

from __future__ import annotations

import random

import pytest

from uros_build.errors import ConfigError
from uros_build.run import relay


def frame(payload: bytes, src: int = 0, dst: int = 1) -> bytes:
    """A frame as the XRCE-DDS client's serial framing writes it (escapes applied; a fixed CRC)."""
    body = bytes([src, dst, len(payload) & 0xFF, len(payload) >> 8]) + payload + b"\x12\x34"
    out = bytearray([relay.FLAG])
    for byte in body:
        out += (
            bytes([relay.ESCAPE, byte ^ relay.XOR]) if byte in (relay.FLAG, relay.ESCAPE) else bytes([byte])
        )
    return bytes(out)


def test_the_plan_as_written() -> None:
    plan = relay.parse_plan("loss=10%,delay=50-150,seed=7")
    assert plan == relay.FaultPlan(loss=0.1, delay_ms=(50, 150), seed=7)
    assert relay.parse_plan("corrupt=0.02,duplicate=2%,reorder=1%,delay=80").delay_ms == (80, 80)
    assert (
        plan.describe() == "loss 10%, corrupt 0%, duplicate 0%, reorder 0%, delay 50-150 ms each way, seed 7"
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("loss", r"'loss' is not KEY=VALUE"),
        ("drop=10%", r"'drop=10%' is not KEY=VALUE"),
        ("loss=110%", r"loss=110%: a rate is 0-100% or 0-1"),
        ("loss=1.5", r"loss=1.5: a rate"),
        ("delay=150-50", r"delay=150-50: milliseconds, or LOW-HIGH"),
        ("seed=x", r"seed=x: an integer"),
    ],
)
def test_a_bad_plan_is_one_line(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        relay.parse_plan(text)


def test_frames_are_cut_whole_with_escapes_and_text_between() -> None:
    one, two = frame(b"\x7e\x7d\x01"), frame(b"hello")
    framer = relay.Framer()
    stream = b"boot\n" + one + two
    out = []
    for i in range(0, len(stream), 3):  # as the bytes arrive, a few at a time
        out += framer.feed(stream[i : i + 3])
    text = b"".join(chunk for is_frame, chunk in out if not is_frame)
    assert text == b"boot\n"
    assert [chunk for is_frame, chunk in out if is_frame] == [one, two]
    assert framer.buffer == b""


def test_a_frame_cut_short_ends_at_the_next_flag() -> None:
    cut, whole = frame(b"abcdef")[:5], frame(b"xy")
    out = relay.Framer().feed(cut + whole)
    assert out == [(True, cut), (True, whole)]
    assert relay.frame_end(frame(b"abc")[:-1]) is None  # not all here yet


def test_the_same_seed_makes_the_same_faults() -> None:
    plan = relay.FaultPlan(loss=0.3, corrupt=0.1, duplicate=0.1, reorder=0.1, delay_ms=(50, 150), seed=7)
    frames = [frame(bytes([i]) * 8) for i in range(200)]

    def run(seed: str) -> list[list[tuple[float, bytes]]]:
        way = relay.Direction(plan, random.Random(seed))
        return [way.apply(f) for f in frames]

    first, again = run("7-up"), run("7-up")
    assert first == again
    assert run("8-up") != first
    way = relay.Direction(plan, random.Random("7-up"))
    sent = [way.apply(f) for f in frames]
    assert way.counts.frames == 200 and 40 <= way.counts.lost <= 80  # about 30 %
    assert all(0.05 <= delay <= 0.15 for out in sent for delay, _ in out)
    assert sum(len(out) for out in sent) == 200 - way.counts.lost + way.counts.duplicated


def test_no_faults_pass_every_frame_at_once() -> None:
    way = relay.Direction(relay.FaultPlan(), random.Random(1))
    assert way.apply(b"\x7eabc") == [(0.0, b"\x7eabc")]


def test_the_counts_in_one_line() -> None:
    counts = {"board_to_agent": {"frames": 233, "lost": 20}, "agent_to_board": {"frames": 222, "lost": 27}}
    assert relay.describe_counts(counts) == (
        "board to agent 233 frames: 20 lost, 0 corrupted, 0 duplicated, 0 reordered; "
        "agent to board 222 frames: 27 lost, 0 corrupted, 0 duplicated, 0 reordered"
    )
