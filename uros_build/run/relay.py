"""A link that drops (issue 40 item 4): a relay in user space between QEMU's serial pty and the
agent, which drops, corrupts, duplicates, reorders and delays whole XRCE serial frames at set rates,
seeded so that a run repeats. The kernel here has no `tc netem`, and a serial link has no packets
for it anyway: the relay cuts the byte stream into the frames the XRCE-DDS client's serial framing
writes (``0x7E``, source and destination address, a 16-bit little-endian length, the payload and a
CRC-16, with ``0x7D`` escaping ``0x7E``/``0x7D`` as ``0x7D, byte ^ 0x20``), so "10 % loss" means one
frame in ten, as on a radio link, not one byte in ten (which would lose nearly every frame).

The relay runs in a thread of uros (no process): it opens QEMU's pty, makes a new pty for the
agent, and moves frames both ways through the fault plan. Bytes between frames (a firmware's
console text on a shared UART) are passed on as they come.
"""

from __future__ import annotations

import contextlib
import heapq
import importlib
import os
import random
import re
import select
import threading
import time
from dataclasses import dataclass, field

from uros_build.errors import ConfigError

FLAG, ESCAPE, XOR = 0x7E, 0x7D, 0x20
HEADER = 4  # source, destination, length (2, little-endian), all after unescaping
CRC = 2


@dataclass(frozen=True)
class FaultPlan:
    """What the relay does to each frame, each direction alike: rates are fractions of frames."""

    loss: float = 0.0
    corrupt: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    delay_ms: tuple[int, int] = (0, 0)  # one way, uniform in [low, high]
    seed: int = 1

    def describe(self) -> str:
        low, high = self.delay_ms
        delay = f"{low}" if low == high else f"{low}-{high}"
        return (
            f"loss {self.loss:.0%}, corrupt {self.corrupt:.0%}, duplicate {self.duplicate:.0%}, "
            f"reorder {self.reorder:.0%}, delay {delay} ms each way, seed {self.seed}"
        )


_KEYS = ("loss", "corrupt", "duplicate", "reorder", "delay", "seed")
_RATE = re.compile(r"(\d+(?:\.\d+)?)(%?)")
_DELAY = re.compile(r"(\d+)(?:-(\d+))?(?:ms)?")


def parse_plan(text: str, flag: str = "--link") -> FaultPlan:
    """``loss=10%,delay=50-150,seed=7`` (pure): rates as a percentage or a fraction, the delay in ms
    one way (a range is uniform), the seed an integer."""
    values: dict[str, str] = {}
    for part in (p.strip() for p in text.split(",") if p.strip()):
        key, eq, value = part.partition("=")
        if not eq or key not in _KEYS:
            raise ConfigError(
                f"{flag} {text!r}: {part!r} is not KEY=VALUE with KEY one of {', '.join(_KEYS)}",
                "e.g. --link loss=10%,delay=50-150,seed=7",
            )
        values[key] = value
    rates = {}
    for key in ("loss", "corrupt", "duplicate", "reorder"):
        if key not in values:
            continue
        found = _RATE.fullmatch(values[key])
        rate = (float(found[1]) / (100 if found[2] else 1)) if found else -1.0
        if not 0.0 <= rate <= 1.0:
            raise ConfigError(f"{flag}: {key}={values[key]}: a rate is 0-100% or 0-1", f"e.g. {key}=10%")
        rates[key] = rate
    delay = (0, 0)
    if "delay" in values:
        found = _DELAY.fullmatch(values["delay"])
        if not found or (found[2] is not None and int(found[2]) < int(found[1])):
            raise ConfigError(
                f"{flag}: delay={values['delay']}: milliseconds, or LOW-HIGH", "e.g. delay=50-150"
            )
        delay = (int(found[1]), int(found[2] if found[2] is not None else found[1]))
    seed = 1
    if "seed" in values:
        if not values["seed"].isdigit():
            raise ConfigError(f"{flag}: seed={values['seed']}: an integer", "e.g. seed=7")
        seed = int(values["seed"])
    return FaultPlan(delay_ms=delay, seed=seed, **rates)


class Framer:
    """Cuts a byte stream into XRCE serial frames (each returned with its flag and escapes, as it
    was on the wire) and the bytes between them. Fed as bytes arrive."""

    def __init__(self) -> None:
        self.buffer = bytearray()

    def feed(self, data: bytes) -> list[tuple[bool, bytes]]:
        """(is a frame, its bytes) in order; an unfinished frame waits for more."""
        self.buffer += data
        out: list[tuple[bool, bytes]] = []
        while self.buffer:
            start = self.buffer.find(FLAG)
            if start != 0:
                loose = bytes(self.buffer if start < 0 else self.buffer[:start])
                out.append((False, loose))
                del self.buffer[: len(loose)]
                continue
            end = frame_end(self.buffer)
            if end is None:
                break
            out.append((True, bytes(self.buffer[:end])))
            del self.buffer[:end]
        return out


def frame_end(buf: bytes | bytearray) -> int | None:
    """Where the frame that starts at ``buf[0]`` (a flag) ends, or None: not all here (pure). A flag
    inside it (a frame cut short) ends it there: the next frame starts at that flag."""
    raw: list[int] = []
    i = 1
    while i < len(buf):
        byte = buf[i]
        if byte == FLAG:
            return i  # cut short: the receiver drops it, as it would
        if byte == ESCAPE:
            if i + 1 >= len(buf):
                return None
            byte = buf[i + 1] ^ XOR
            i += 1
        raw.append(byte)
        i += 1
        if len(raw) >= HEADER:
            length = raw[2] | raw[3] << 8
            if len(raw) == HEADER + length + CRC:
                return i
    return None


@dataclass
class Counts:
    frames: int = 0
    lost: int = 0
    corrupted: int = 0
    duplicated: int = 0
    reordered: int = 0


@dataclass
class Direction:
    """One way through the relay: its own seeded random stream, so each repeats."""

    plan: FaultPlan
    rng: random.Random
    counts: Counts = field(default_factory=Counts)
    held: bytes | None = None  # a frame kept back to be sent after the next (reorder)

    def apply(self, frame: bytes) -> list[tuple[float, bytes]]:
        """What to send for ``frame``: (delay in seconds, bytes) each (pure but for the stream)."""
        self.counts.frames += 1
        r = self.rng
        low, high = self.plan.delay_ms
        delay = r.uniform(low, high) / 1000.0
        if r.random() < self.plan.loss:
            self.counts.lost += 1
            return []
        if len(frame) > 2 and r.random() < self.plan.corrupt:
            at = r.randrange(1, len(frame))
            flipped = frame[at] ^ (1 << r.randrange(8))
            if flipped not in (FLAG, ESCAPE):  # a bit flipped inside: the receiver's CRC check drops it
                self.counts.corrupted += 1
                frame = frame[:at] + bytes([flipped]) + frame[at + 1 :]
        out = [frame]
        if r.random() < self.plan.duplicate:
            self.counts.duplicated += 1
            out.append(frame)
        if self.held is not None:
            out.append(self.held)
            self.held = None
        elif r.random() < self.plan.reorder:
            self.counts.reordered += 1
            self.held = out.pop(0)
        return [(delay, data) for data in out]


class Relay:
    """The relay's thread: QEMU's pty on one side, a pty of its own (``agent_pty``) on the other."""

    def __init__(self, qemu_pty: str, plan: FaultPlan) -> None:
        self.plan = plan
        tty = importlib.import_module("tty")  # POSIX only: imported when a relay runs, not with uros
        self.qemu = os.open(qemu_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.qemu)
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.agent_pty = os.ttyname(slave)
        os.close(slave)  # the agent opens it by name; until then reads of the master fail (EIO)
        os.set_blocking(self.master, False)
        self.up = Direction(plan, random.Random(f"{plan.seed}-up"))  # board -> agent
        self.down = Direction(plan, random.Random(f"{plan.seed}-down"))  # agent -> board
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="uros-relay", daemon=True)

    def start(self) -> Relay:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        for fd in (self.qemu, self.master):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _run(self) -> None:
        framers = {self.qemu: Framer(), self.master: Framer()}
        route = {self.qemu: (self.master, self.up), self.master: (self.qemu, self.down)}
        queue: list[tuple[float, int, int, bytes]] = []  # (when, order, to fd, bytes)
        order = 0
        while not self._stop.is_set():
            wait = max(0.0, min((q[0] for q in queue), default=time.monotonic() + 0.05) - time.monotonic())
            try:
                ready, _, _ = select.select([self.qemu, self.master], [], [], min(wait, 0.05))
            except (OSError, ValueError):
                return
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except BlockingIOError:
                    continue
                except OSError:  # the agent's side closed (stopped for the restart stage): wait
                    time.sleep(0.02)
                    continue
                target, direction = route[fd]
                now = time.monotonic()
                for is_frame, chunk in framers[fd].feed(data):
                    sends = direction.apply(chunk) if is_frame else [(0.0, chunk)]
                    for delay, out in sends:
                        order += 1
                        heapq.heappush(queue, (now + delay, order, target, out))
            now = time.monotonic()
            while queue and queue[0][0] <= now:
                _, _, target, out = heapq.heappop(queue)
                with contextlib.suppress(OSError):  # nobody on that side now: lost on the wire
                    os.write(target, out)

    def summary(self) -> dict[str, dict[str, int]]:
        return {
            "board_to_agent": vars(self.up.counts).copy(),
            "agent_to_board": vars(self.down.counts).copy(),
        }


def describe_counts(counts: dict[str, dict[str, int]]) -> str:
    """``board to agent 120 frames: 12 lost, ...; agent to board ...`` (pure)."""
    parts = []
    for way, label in (("board_to_agent", "board to agent"), ("agent_to_board", "agent to board")):
        c = counts.get(way, {})
        faults = ", ".join(f"{c.get(k, 0)} {k}" for k in ("lost", "corrupted", "duplicated", "reordered"))
        parts.append(f"{label} {c.get('frames', 0)} frames: {faults}")
    return "; ".join(parts)
