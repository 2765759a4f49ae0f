"""The lossy link's pure pieces (run/relay.py, issue 40 item 4): the fault plan as written on the
command line, the XRCE serial frames cut from a byte stream, and the seeded faults applied to them."""

from __future__ import annotations

import random

import pytest

from uros_build.errors import ConfigError
from uros_build.run import relay, xrcewire


def frame(payload: bytes, src: int = 0, dst: int = 1) -> bytes:
    """A frame as the XRCE-DDS client's serial framing writes it (escapes applied; a fixed CRC)."""
    body = bytes([src, dst, len(payload) & 0xFF, len(payload) >> 8]) + payload + b"\x12\x34"
    out = bytearray([xrcewire.FLAG])
    for byte in body:
        out += (
            bytes([xrcewire.ESCAPE, byte ^ xrcewire.XOR])
            if byte in (xrcewire.FLAG, xrcewire.ESCAPE)
            else bytes([byte])
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
    framer = xrcewire.Framer()
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
    out = xrcewire.Framer().feed(cut + whole)
    assert out == [(True, cut), (True, whole)]
    assert xrcewire.frame_end(frame(b"abc")[:-1]) is None  # not all here yet


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
    counts = {
        "board_to_agent": {"frames": 233, "lost": 20, "retransmitted": 9},
        "agent_to_board": {"frames": 222, "lost": 27},
    }
    assert relay.describe_counts(counts) == (
        "board to agent 233 frames: 20 lost, 0 corrupted, 0 duplicated, 0 reordered; the sender's reliable "
        "retransmissions 9; agent to board 222 frames: 27 lost, 0 corrupted, 0 duplicated, 0 reordered; the "
        "sender's reliable retransmissions 0"
    )
    assert relay.describe_counts({"transport": "udp", **counts}).startswith("board to agent 233 datagrams:")


def message(session: int, stream: int, seq: int, *subs: tuple[int, bytes], key: bytes = b"") -> bytes:
    """An XRCE message as the client writes it: the header, then submessages aligned to 4 bytes."""
    out = bytearray([session, stream, seq & 0xFF, seq >> 8]) + key
    for kind, payload in subs:
        out += b"\0" * (-len(out) % 4)
        out += bytes([kind, 0, len(payload) & 0xFF, len(payload) >> 8]) + payload
    return bytes(out)


def create_client(key: bytes) -> bytes:
    """CREATE_CLIENT with a CLIENT_Representation: cookie, version, vendor, the client key, ..."""
    return message(0x80, 0, 0, (xrcewire.CREATE_CLIENT, b"XRCE\x01\x00\x01\x0f" + key + b"\x81\x00\x00\x02"))


def test_a_frame_gives_back_its_message() -> None:
    payload = message(0x81, 0x01, 3, (xrcewire.WRITE_DATA, b"\x7e\x01\x02"))
    assert xrcewire.unframe(frame(payload)) == payload
    assert xrcewire.unframe(frame(payload)[:-1]) is None  # cut short


def test_messages_are_read_header_and_submessages() -> None:
    heartbeat = 11
    data = message(0x01, 0x80, 258, (heartbeat, b"\1\2\3"), (xrcewire.DATA, b"abcd"), key=b"\xaa\xbb\xcc\xdd")
    read = xrcewire.parse_message(data)
    assert read is not None and (read.session, read.stream, read.seq) == (0x01, 0x80, 258)
    assert [kind for kind, _ in read.submessages] == [11, xrcewire.DATA]  # the second aligned to 4
    assert read.submessages[1][1] == b"abcd"
    assert xrcewire.parse_message(b"\x81") is None
    cut = xrcewire.parse_message(message(0x81, 1, 0, (xrcewire.DATA, b"abcdef"))[:-2])
    assert cut is not None and cut.submessages == ()  # a submessage past the end is left out


def test_the_observer_counts_best_effort_samples_retransmissions_and_sessions() -> None:
    seen = relay.Observer()
    seen.observe(create_client(b"\x11\x22\x33\x44"), 10.0)
    seen.observe(create_client(b"\x11\x22\x33\x44"), 10.5)  # sent again: a retry, the same session
    for seq in (0, 1, 1, 2):  # seq 1 sent twice: one retransmission
        seen.observe(message(0x81, 0x80, seq, (xrcewire.WRITE_DATA, b"x")), 11.0)
    for seq in range(3):
        best = seen.observe(message(0x81, 0x01, seq, (xrcewire.WRITE_DATA, b"y")), 11.0)
        seen.delivered(best, 0 if seq == 1 else 1)  # the second lost on the link
    seen.observe(create_client(b"\x55\x66\x77\x88"), 20.0)  # a new session numbers anew
    seen.observe(message(0x81, 0x80, 1, (xrcewire.WRITE_DATA, b"x")), 21.0)
    t = seen.traffic
    assert (t.reliable, t.retransmitted) == (5, 1)
    assert (t.best_effort, t.best_effort_passed, t.sessions) == (3, 2, 3)
    assert [e for e in seen.events if e[0] == "create"] == [
        ("create", "11223344", 10.0),
        ("create", "11223344", 10.5),
        ("create", "55667788", 20.0),
    ]
    back = relay.Observer()
    answer = back.observe(message(0x81, 0, 0, (xrcewire.STATUS_AGENT, b"\0\0")), 10.6)
    back.delivered(answer, 1, 10.6)
    back.delivered(answer, 0, 10.7)  # lost: no answer reached the board
    assert back.events == [("answered", "", 10.6)]


def test_a_way_counts_what_got_through_intact() -> None:
    plan = relay.FaultPlan(loss=0.2, corrupt=0.1, duplicate=0.1, seed=3)
    way = relay.Way(plan, "up", framed=False)
    for seq in range(300):
        data = message(0x81, 0x01, seq, (xrcewire.WRITE_DATA, b"sample"))
        way.carry(data, data, 1.0)
    twin = relay.Direction(plan, random.Random("3-up"), framed=False)  # the same seeded stream
    intact = 0
    for seq in range(300):
        data = message(0x81, 0x01, seq, (xrcewire.WRITE_DATA, b"sample"))
        intact += sum(1 for _, out in twin.apply(data) if out == data)
    c, t = way.faults.counts, way.observer.traffic
    assert t.best_effort == 300 and c.lost > 30 and c.corrupted > 10 and c.duplicated > 10
    assert t.best_effort_passed == intact


def test_over_udp_any_bit_may_be_corrupted() -> None:
    """A datagram has no flag or escape bytes: every flip is a corruption (serial: a flip into 0x7E
    or 0x7D is a frame cut short, not counted as corrupted)."""
    plan = relay.FaultPlan(corrupt=1.0, seed=5)
    udp = relay.Direction(plan, random.Random(5), framed=False)
    for _ in range(100):
        udp.apply(b"\x7c" * 16)
    assert udp.counts.corrupted == 100
