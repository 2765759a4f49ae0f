"""A link that drops (issue 40 item 4): a relay in user space between QEMU's serial pty and the
agent, which drops, corrupts, duplicates, reorders and delays whole XRCE serial frames at set rates,
seeded so that a run repeats. The kernel here has no `tc netem`, and a serial link has no packets
for it anyway: the relay cuts the byte stream into the frames the XRCE-DDS client's serial framing
writes (``0x7E``, source and destination address, a 16-bit little-endian length, the payload and a
CRC-16, with ``0x7D`` escaping ``0x7E``/``0x7D`` as ``0x7D, byte ^ 0x20``), so "10 % loss" means one
frame in ten, as on a radio link, not one byte in ten (which would lose nearly every frame).

The relay runs in a thread of uros (no process): it opens QEMU's pty, makes a new pty for the
agent, and moves frames both ways through the fault plan. Bytes between frames (a firmware's
console text on a shared UART) are passed on as they come. Over UDP (`UdpRelay`) it is a proxy on
the port the firmware sends to, the agent on another, and each datagram is one XRCE message.

Either way it reads the XRCE messages it carries (`Traffic`): the best-effort samples each way and
how many it let through intact, the reliable messages a sender sent again (a sequence number seen
before in the session: a retransmission), the sessions the board opened (the client key of each
CREATE_CLIENT) and the time requests: uros's own figures of the link, never the firmware's text.
"""

from __future__ import annotations

import contextlib
import ctypes
import heapq
import importlib
import os
import random
import re
import select
import socket
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uros_build.errors import ConfigError
from uros_build.run.xrcewire import (
    CREATE_CLIENT,
    DATA,
    ESCAPE,
    FLAG,
    RELIABLE,
    STATUS_AGENT,
    TIMESTAMP,
    TIMESTAMP_REPLY,
    WRITE_DATA,
    Framer,
    Message,
    parse_message,
    unframe,
)


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


@dataclass
class Traffic:
    """What one way of the link carried, read from its XRCE messages before the faults (what the
    sender sent), and what of it the relay let through intact."""

    best_effort: int = 0  # samples on a best-effort stream: WRITE_DATA (board to agent), DATA (back)
    best_effort_passed: int = 0  # of those, delivered intact (a duplicate counts once more)
    reliable: int = 0  # messages on a reliable stream
    retransmitted: int = 0  # of those, a sequence number the relay saw before in the session
    sessions: int = 0  # CREATE_CLIENT (board to agent) or STATUS_AGENT (agent to board) submessages
    time: int = 0  # TIMESTAMP requests (board to agent) or TIMESTAMP_REPLY answers (agent to board)
    time_passed: int = 0


class Observer:
    """Counts one way's XRCE traffic (`Traffic`) and keeps the session events with their host time:
    each CREATE_CLIENT the board sent (with its client key) and each STATUS_AGENT answer that
    reached the board, for the restart stage (run/stages.py sessions_opened)."""

    def __init__(self) -> None:
        self.traffic = Traffic()
        self.seen: set[tuple[int, int, int]] = set()  # (session epoch, stream, seq) of reliable messages
        self.epoch = 0  # a new session's reliable streams start their numbers again
        self.events: list[
            tuple[str, str, float]
        ] = []  # ("create", client key, time) / ("answered", "", time)

    def observe(self, data: bytes, now: float) -> Message | None:
        message = parse_message(data)
        if message is None:
            return None
        t = self.traffic
        for kind, payload in message.submessages:
            if kind == CREATE_CLIENT:
                t.sessions += 1
                self.events.append(("create", payload[8:12].hex() if len(payload) >= 12 else "?", now))
                self.epoch += 1  # sent before any reliable message of its session, a retry too
            elif kind == STATUS_AGENT:
                t.sessions += 1
            elif kind in (TIMESTAMP, TIMESTAMP_REPLY):
                t.time += 1
            elif kind in (WRITE_DATA, DATA) and 0 < message.stream < RELIABLE:
                t.best_effort += 1
        if message.stream >= RELIABLE:
            t.reliable += 1
            mark = (self.epoch, message.stream, message.seq)
            if mark in self.seen:
                t.retransmitted += 1
            self.seen.add(mark)
        return message

    def delivered(self, message: Message | None, copies: int, now: float = 0.0) -> None:
        """``copies`` of the message reached the other side intact (0: lost or corrupted)."""
        if message is None or copies == 0:
            return
        for kind, _ in message.submessages:
            if kind in (WRITE_DATA, DATA) and 0 < message.stream < RELIABLE:
                self.traffic.best_effort_passed += copies
            elif kind in (TIMESTAMP, TIMESTAMP_REPLY):
                self.traffic.time_passed += copies
            elif kind == STATUS_AGENT:
                self.events.append(("answered", "", now))


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

    framed: bool = True  # serial frames (a flip into a flag or escape is no corruption); UDP: datagrams

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
            if not self.framed or flipped not in (FLAG, ESCAPE):  # serial: the receiver's CRC drops it
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


class Way:
    """One way through the relay: its seeded faults (`Direction`) and what it carried (`Observer`)."""

    def __init__(self, plan: FaultPlan, name: str, framed: bool) -> None:
        self.faults = Direction(plan, random.Random(f"{plan.seed}-{name}"), framed=framed)
        self.observer = Observer()

    def carry(self, message: bytes, data: bytes, now: float) -> list[tuple[float, bytes]]:
        """``data`` (a frame or a datagram carrying the XRCE ``message``) through the faults."""
        seen = self.observer.observe(message, now)
        c = self.faults.counts
        before = (c.lost, c.corrupted, c.duplicated)
        out = self.faults.apply(data)
        damaged = (c.lost, c.corrupted) != before[:2]
        self.observer.delivered(seen, 0 if damaged else 1 + c.duplicated - before[2], now)
        return out

    def summary(self) -> dict[str, int]:
        return {**vars(self.faults.counts), **vars(self.observer.traffic)}


class _Link:
    """What both relays share: the two ways, a queue of delayed sends, a thread, the summary."""

    framed = True

    def __init__(self, plan: FaultPlan) -> None:
        self.plan = plan
        self.up = Way(plan, "up", self.framed)  # board -> agent
        self.down = Way(plan, "down", self.framed)  # agent -> board
        self.queue: list[tuple[float, int, int, bytes]] = []  # (when, order, to, bytes)
        self.order = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="uros-relay", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        self._close()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select(self._sources(), [], [], self.wait())
            except (OSError, ValueError):
                return
            for source in ready:
                self._receive(source)
            self.flush()

    def _sources(self) -> list[Any]:
        raise NotImplementedError

    def _receive(self, source: Any) -> None:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError

    def _send(self, to: int, data: bytes) -> None:
        raise NotImplementedError

    def push(self, way: Way, to: int, message: bytes, data: bytes) -> None:
        now = time.monotonic()
        for delay, out in way.carry(message, data, time.time()):
            self.order += 1
            heapq.heappush(self.queue, (now + delay, self.order, to, out))
        self.down.observer.epoch = self.up.observer.epoch  # the board's new session numbers both ways anew

    def wait(self) -> float:
        """Seconds until the next delayed send is due (at most 0.05)."""
        due = min((q[0] for q in self.queue), default=time.monotonic() + 0.05)
        return min(max(0.0, due - time.monotonic()), 0.05)

    def flush(self) -> None:
        now = time.monotonic()
        while self.queue and self.queue[0][0] <= now:
            _, _, to, out = heapq.heappop(self.queue)
            self._send(to, out)

    def summary(self) -> dict[str, object]:
        return {
            "transport": "serial" if self.framed else "udp",
            "board_to_agent": self.up.summary(),
            "agent_to_board": self.down.summary(),
            "sessions": [
                {"event": event, "client_key": key, "seen": round(seen, 3)}
                for event, key, seen in sorted(
                    self.up.observer.events + self.down.observer.events, key=lambda e: e[2]
                )
            ],
        }


class Relay(_Link):
    """The serial relay's thread: QEMU's pty on one side, a pty of its own (``agent_pty``) on the other."""

    def __init__(self, qemu_pty: str, plan: FaultPlan) -> None:
        super().__init__(plan)
        tty = importlib.import_module("tty")  # POSIX only: imported when a relay runs, not with uros
        self.qemu = os.open(qemu_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.qemu)
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.agent_pty = os.ttyname(slave)
        os.close(slave)  # the agent opens it by name; until then reads of the master fail (EIO)
        os.set_blocking(self.master, False)
        self.framers = {self.qemu: Framer(), self.master: Framer()}
        self.route = {self.qemu: (self.master, self.up), self.master: (self.qemu, self.down)}

    def _close(self) -> None:
        for fd in (self.qemu, self.master):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _send(self, to: int, data: bytes) -> None:
        with contextlib.suppress(OSError):  # nobody on that side now: lost on the wire
            os.write(to, data)

    def _sources(self) -> list[Any]:
        return [self.qemu, self.master]

    def _receive(self, source: Any) -> None:
        try:
            data = os.read(source, 4096)
        except BlockingIOError:
            return
        except OSError:  # the agent's side closed (stopped for the restart stage): wait
            time.sleep(0.02)
            return
        target, way = self.route[source]
        for is_frame, chunk in self.framers[source].feed(data):
            if is_frame:
                self.push(way, target, unframe(chunk) or b"", chunk)
            else:
                self.order += 1
                heapq.heappush(self.queue, (time.monotonic(), self.order, target, chunk))


CLONE_NEWNET = 0x40000000


def _sockets_in(namespace: Path | None, board_port: int) -> tuple[socket.socket, socket.socket]:
    """The board's socket (bound to the port the firmware sends to) and the agent's (a port of its
    own), made in the network namespace of process ``namespace_pid`` when given (a socket stays in
    the namespace it was made in): from a thread of their own that enters it (setns(2) changes the
    calling thread only), so uros's other threads stay where they are."""
    made: list[socket.socket] = []
    failed: list[BaseException] = []

    def make() -> None:
        try:
            if namespace is not None:
                fd = os.open(namespace, os.O_RDONLY)
                try:
                    if ctypes.CDLL(None, use_errno=True).setns(fd, CLONE_NEWNET) != 0:
                        raise OSError(ctypes.get_errno(), "setns: could not enter the run's namespace")
                finally:
                    os.close(fd)
            board = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            board.bind(("127.0.0.1", board_port))
            agent = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            agent.bind(("127.0.0.1", 0))
            made.extend((board, agent))
        except BaseException as error:  # handed to the caller's thread
            failed.append(error)

    helper = threading.Thread(target=make, name="uros-relay-sockets", daemon=True)
    helper.start()
    helper.join()
    if failed:
        raise failed[0]
    for sock in made:
        sock.setblocking(False)
    return made[0], made[1]


class UdpRelay(_Link):
    """The UDP relay's thread: a proxy on the port the firmware sends to (``board_port``), the agent
    on ``agent_port``; each datagram is one XRCE message. Datagrams to an agent that is not there
    (the restart stage) are lost, as on a network."""

    framed = False
    BOARD, AGENT = 0, 1

    def __init__(self, board_port: int, agent_port: int, plan: FaultPlan, namespace: Path | None) -> None:
        super().__init__(plan)
        self.agent_address = ("127.0.0.1", agent_port)
        self.board_address: tuple[str, int] | None = None  # QEMU's user network, once it sent
        self.board, self.agent = _sockets_in(namespace, board_port)

    def _close(self) -> None:
        for sock in (self.board, self.agent):
            sock.close()

    def _send(self, to: int, data: bytes) -> None:
        with contextlib.suppress(OSError):
            if to == self.AGENT:
                self.agent.sendto(data, self.agent_address)
            elif self.board_address is not None:
                self.board.sendto(data, self.board_address)

    def _sources(self) -> list[Any]:
        return [self.board, self.agent]

    def _receive(self, source: Any) -> None:
        try:
            data, address = source.recvfrom(65536)
        except OSError:  # nothing after all, or an ICMP error of an agent that is gone
            return
        if source is self.board:
            self.board_address = address
            self.push(self.up, self.AGENT, data, data)
        else:
            self.push(self.down, self.BOARD, data, data)


def describe_counts(counts: Mapping[str, object]) -> str:
    """``board to agent 120 frames: 12 lost, ..., 9 retransmitted; agent to board ...`` (pure)."""
    unit = "datagrams" if counts.get("transport") == "udp" else "frames"
    parts = []
    for way, label in (("board_to_agent", "board to agent"), ("agent_to_board", "agent to board")):
        c = counts.get(way)
        c = c if isinstance(c, dict) else {}
        faults = ", ".join(f"{c.get(k, 0)} {k}" for k in ("lost", "corrupted", "duplicated", "reordered"))
        again = f"; the sender's reliable retransmissions {c.get('retransmitted', 0)}"
        parts.append(f"{label} {c.get('frames', 0)} {unit}: {faults}{again}")
    return "; ".join(parts)
