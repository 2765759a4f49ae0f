"""Many boards on one agent (`uros probe --instances N`, issue 40 item 3): N QEMUs of one probe image
against ONE agent, `multiserial` over N serial links (a pty each) or `udp4` on one port (N QEMU user
networks), the agent restarted once for all of them (the restart stage), and everything stopped at
the end, as run/session.py does for one board.

The image is the same on every board; what tells the boards apart is what uros passes each QEMU on
its semihosting command line (templates/probe/fleet.h), as a real board reads its chip's UID: its
index (its ROS namespace, `board<i>`, so that its samples are its own) and, unless the library's own
draw is asked for, a unique id the firmware derives its client key from.

What uros judges is what it measured: each board's console and exit status, and the client key of
every CREATE_CLIENT each board sent, read off the wire (the serial frames through a relay of
run/relay.py that passes every frame, or the UDP datagrams of the board's pcap), never the key a
firmware prints."""

from __future__ import annotations

import struct
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import ConfigError, StepFailed
from uros_build.files import read_regular, remove_tree
from uros_build.proc import Background, Runner
from uros_build.run import machines, netns
from uros_build.run.relay import Direction, FaultPlan, Relay
from uros_build.run.session import (
    AGENT_LOST,
    LOST_WAIT,
    WATCH_SECONDS,
    ConsoleReader,
    Session,
    SessionRun,
    SessionSpec,
    open_namespace,
    stop_the_rest,
    wait_for_pty,
)
from uros_build.run.stages import RESTART_ASKED, ConsoleLine, Stage
from uros_build.run.xrcewire import CREATE_CLIENT, parse_message, unframe

# A QEMU each (about 40 MB of host RAM and a share of a core), a relay thread each on serial, one
# agent for all: 16 keeps a run on a workstation bounded; 8 passed on this project's 2 cores.
MAX_INSTANCES = 16
KEY_MODES = ("own", "same", "drawn")
# A board's unique id as uros hands it over ("own": one per board; "same": board 0's on every board)
UID_BASE = 0x0B0A0D00
# How long the agent waits for the last board to ask for the restart after the first asked: the
# firmware waits up to 60 s when it is one of many (fleet.h), uros a little less
RESTART_BARRIER = 50.0
MAX_PCAP_BYTES = 64 * 1024 * 1024
COOKIE = b"XRCE"
FIX = (
    "give each board its own client key from a unique id (its chip's UID, its MAC address): "
    "rmw_uros_options_set_client_key(key, rcl_init_options_get_rmw_init_options(&options)) before "
    "rclc_support_init_with_options"
)


def check_instances(count: int) -> None:
    """--instances is 1 to MAX_INSTANCES (pure)."""
    if not 1 <= count <= MAX_INSTANCES:
        raise ConfigError(
            f"--instances {count}: must be 1 to {MAX_INSTANCES} (a QEMU a board, all on one agent)",
            f"e.g. --instances 8 (more than {MAX_INSTANCES} QEMUs on one host test the host, not the agent)",
        )


def check_keys(keys: str | None, count: int) -> str:
    """--client-keys: own (the default), same or drawn, and only with two boards or more (pure)."""
    if keys is None:
        return "own"
    if keys not in KEY_MODES:
        raise ConfigError(
            f"--client-keys {keys}: must be one of {', '.join(KEY_MODES)}", "e.g. --client-keys own"
        )
    if count < 2:
        raise ConfigError(
            f"--client-keys {keys}: with --instances 2 or more (one board has no other to share a key with)",
            "add --instances 2, or drop --client-keys",
        )
    return keys


def check_board(arch: str, machine: str) -> None:
    """A board's index and id reach the firmware through Arm semihosting (templates/probe/arm/board.c)."""
    if arch != "arm":
        raise ConfigError(
            f"--instances: the board {machine} is {arch}; uros tells each board who it is through Arm "
            "semihosting, which the probe firmware reads on Arm boards only",
            "probe an Arm target (cortex-m*) with --instances, or drop --instances",
        )


def uids(count: int, keys: str) -> tuple[int | None, ...]:
    """The unique id each board gets (pure): its own, board 0's on every board, or none (the library
    draws the key itself)."""
    if keys == "drawn":
        return (None,) * count
    return tuple(UID_BASE + (1 if keys == "same" else i + 1) for i in range(count))


def board_argv(argv: Sequence[str], index: int, uid: int | None) -> list[str]:
    """QEMU's argv with the board's index and unique id on its semihosting command line (pure)."""
    out = list(argv)
    at = out.index("-semihosting-config") + 1
    args = f",arg=uros_probe,arg=uros-board={index}"
    if uid is not None:
        args += f",arg=uros-uid={uid:08x}"
    out[at] += args
    return out


def agent_multiserial_argv(agent: str, ptys: Sequence[str], middleware: str) -> list[str]:
    """One agent on every board's serial link (`multiserial`; eProsima's agent and micro_ros_agent)."""
    return [agent, "multiserial", "--devs", " ".join(ptys), "-b", "115200", "-m", middleware, "-v6"]


def client_keys(message: bytes) -> list[int]:
    """The client keys of the CREATE_CLIENT submessages in one XRCE message (pure): its header is 4
    bytes, 8 with a key for a session id under 0x80; each submessage a 4-byte header (id, flags,
    little-endian length) and its payload, aligned to 4; CREATE_CLIENT's payload the cookie "XRCE",
    version and vendor (4), then the key (4, big-endian as the agent prints it)."""
    read = parse_message(message)
    return [
        int.from_bytes(payload[8:12], "big")
        for kind, payload in (read.submessages if read is not None else ())
        if kind == CREATE_CLIENT and payload[:4] == COOKIE and len(payload) >= 12
    ]


def pcap_payloads(data: bytes, port: int) -> list[bytes]:
    """The UDP payloads sent to ``port`` in a pcap of Ethernet frames (QEMU's filter-dump) (pure)."""
    if len(data) < 24:
        return []
    magic = data[:4]
    endian = "<" if magic in (b"\xd4\xc3\xb2\xa1", b"\x4d\x3c\xb2\xa1") else ">"
    out, at = [], 24
    while at + 16 <= len(data):
        captured = struct.unpack(f"{endian}I", data[at + 8 : at + 12])[0]
        frame = data[at + 16 : at + 16 + captured]
        at += 16 + captured
        if len(frame) < 14 + 20 or frame[12:14] != b"\x08\x00":
            continue
        ip = frame[14:]
        header = (ip[0] & 0x0F) * 4
        if ip[9] != 17 or len(ip) < header + 8:  # UDP
            continue
        udp = ip[header:]
        if struct.unpack(">H", udp[2:4])[0] == port:
            out.append(udp[8 : struct.unpack(">H", udp[4:6])[0]])
    return out


def key_text(key: int) -> str:
    return f"0x{key:08X}"


def shared_keys(keys: Mapping[int, Sequence[int]]) -> dict[int, tuple[int, ...]]:
    """Each key two boards or more sent, with those boards (pure)."""
    boards: dict[int, list[int]] = {}
    for board, sent in keys.items():
        for key in dict.fromkeys(sent):
            boards.setdefault(key, []).append(board)
    return {key: tuple(b) for key, b in boards.items() if len(b) > 1}


def key_stage(board: int, keys: Mapping[int, Sequence[int]]) -> Stage:
    """The host's stage `client-key` of one board, from the keys every board's CREATE_CLIENT carried."""
    sent = list(dict.fromkeys(keys.get(board, ())))
    if not sent:
        return Stage("client-key", "fail", "the board sent no CREATE_CLIENT: it asked for no session")
    shared = {k: b for k, b in shared_keys(keys).items() if board in b}
    if shared:
        key, boards = next(iter(shared.items()))
        others = ", ".join(str(b) for b in boards if b != board)
        said = f"client key {key_text(key)} also board {others}'s: the agent took them for one client"
        return Stage("client-key", "fail", said)
    return Stage("client-key", "pass", f"{', '.join(key_text(k) for k in sent)}, no other board's")


def shared_line(keys: Mapping[int, Sequence[int]]) -> str | None:
    """The run's failure when boards shared a client key, with the fix (pure), or None."""
    shared = shared_keys(keys)
    if not shared:
        return None
    key, boards = next(iter(shared.items()))
    return (
        f"boards {', '.join(map(str, boards))} shared client key {key_text(key)}: the agent took them "
        f"for one client (each board's CREATE_CLIENT reset the other's session); {FIX}"
    )


class _KeyTap(Direction):
    """The relay's board-to-agent way, passing every frame as it comes, noting the client keys."""

    def __init__(self, inner: Direction) -> None:
        super().__init__(inner.plan, inner.rng, inner.counts, inner.held)
        self.keys: list[int] = []

    def apply(self, frame: bytes) -> list[tuple[float, bytes]]:
        message = unframe(frame)
        if message is not None:
            self.keys.extend(client_keys(message))
        return super().apply(frame)


@dataclass(frozen=True)
class Board:
    """One board's run: its session as one board's would be, and the client keys it sent."""

    index: int
    session: Session
    keys: tuple[int, ...]
    work: Path


@dataclass(frozen=True)
class FleetRun:
    """The boards' runs and the agent they shared."""

    boards: tuple[Board, ...]
    agent_log: Path
    seconds: float
    agent_argv: tuple[str, ...]


def board_work(work: Path, index: int) -> Path:
    return work / f"board{index}"


def restart_due(asked: dict[int, float], ended: Iterable[int], count: int, now: float) -> bool:
    """The agent is restarted once every board still running asked, or RESTART_BARRIER after the first."""
    if not asked:
        return False
    waiting = set(range(count)) - set(asked) - set(ended)
    return not waiting or now - min(asked.values()) > RESTART_BARRIER


def _at(runner: Runner, started: float, text: str) -> None:
    """A line of the run log with the run's time (the restart's barrier is read from them)."""
    runner.log(f"[{time.monotonic() - started:7.2f} s] {text}")


def run_fleet(
    runner: Runner,
    run: SessionRun,
    spec: SessionSpec,
    ids: Sequence[int | None],
    link: FaultPlan | None = None,
) -> FleetRun:
    """N boards, one agent, until every board ends or the timeout; everything stopped at the end."""
    count, work, machine = len(ids), run.work, run.machine
    udp = spec.udp_port is not None
    middleware = spec.middleware
    agent_log = work / "agent.log"
    for stale in work.glob("board*"):  # an earlier run's boards beyond this run's
        if stale.name[len("board") :].isdigit() and int(stale.name[len("board") :]) >= count:
            remove_tree(stale)
    started = time.monotonic()
    holder = open_namespace(runner, work) if middleware == "dds" else None
    namespace = netns.namespace_id(holder.proc.pid) if holder is not None else None
    qemus: list[Background] = []
    relays: list[Relay] = []
    taps: list[_KeyTap] = []
    agents: list[Background] = []
    consoles: list[ConsoleReader] = []
    lines: list[list[ConsoleLine]] = [[] for _ in range(count)]
    status: list[int | None] = [None] * count
    restarts: list[tuple[float, float]] = []
    agent_argv: list[str] = []
    try:
        for index, uid in enumerate(ids):
            folder = board_work(work, index)
            folder.mkdir(parents=True, exist_ok=True)
            console_log = folder / "console.log"
            console_log.unlink(missing_ok=True)
            pcap = folder / "board.pcap" if udp else None
            argv = board_argv(machines.qemu_argv(machine, run.elf, console_log, pcap), index, uid)
            argv[0] = run.qemu_program
            if udp and holder is not None:
                argv = netns.enter_argv(holder.proc.pid, argv)
            qemus.append(runner.start(argv, step=f"QEMU board {index}", output=folder / "qemu.log"))
            log = folder / "qemu.log" if machine.board.console_stdout else console_log
            consoles.append(ConsoleReader(log))
        if udp:
            assert spec.udp_port is not None
            agent_argv = machines.agent_udp_argv(run.agent_program, spec.udp_port, middleware)
        else:
            ptys = []
            for index, qemu in enumerate(qemus):
                pty = wait_for_pty(board_work(work, index) / "qemu.log", qemu, 10.0)
                if pty is None:
                    raise StepFailed(
                        f"QEMU {machine.machine} of board {index} did not open the firmware's link "
                        "(no pseudo-terminal)",
                        f"its output is in {board_work(work, index) / 'qemu.log'}",
                    )
                relay = Relay(pty, link or FaultPlan())
                tap = _KeyTap(relay.up.faults)
                relay.up.faults = tap
                relay.start()
                relays.append(relay)
                taps.append(tap)
                ptys.append(relay.agent_pty)
            agent_argv = agent_multiserial_argv(run.agent_program, ptys, middleware)
        if holder is not None:
            agent_argv = netns.enter_argv(holder.proc.pid, agent_argv)
        agents.append(runner.start(agent_argv, step="the agent", output=agent_log))
        asked: dict[int, float] = {}
        lost: set[int] = set()
        stopped: float | None = None
        while time.monotonic() - started < run.timeout:
            time.sleep(WATCH_SECONDS)
            for index, qemu in enumerate(qemus):
                if status[index] is None:
                    status[index] = qemu.wait(0)
                new = consoles[index].read()
                lines[index].extend(new)
                texts = {line.text for line in new}
                if RESTART_ASKED in texts and index not in asked:
                    asked[index] = time.time()
                    _at(runner, started, f"board {index} asked for the agent's restart")
                if AGENT_LOST in texts:
                    lost.add(index)
                    _at(runner, started, f"board {index} lost the agent")
            ended = [i for i in range(count) if status[i] is not None]
            due = restart_due(asked, ended, count, time.time())
            if spec.restart_agent and stopped is None and not restarts and due:
                _at(runner, started, f"the agent stopped for the restart (boards asked: {sorted(asked)})")
                agents[-1].stop()
                stopped = time.time()
            if stopped is not None and (set(asked) <= lost | set(ended) or time.time() - stopped > LOST_WAIT):
                _at(runner, started, "the agent started again")
                agents.append(runner.start(agent_argv, step="the agent", output=work / "agent-restarted.log"))
                restarts.append((stopped, time.time()))
                stopped = None
            if len(ended) == count:
                break
        runner.log(f"the boards ended after {time.monotonic() - started:.1f} s: exit statuses {status}")
    finally:
        for qemu in qemus:
            qemu.stop()
        for proc in (*agents, holder):
            if proc is not None:
                proc.stop()
        for relay in relays:
            relay.stop()
        stop_the_rest(runner, namespace)
    seconds = time.monotonic() - started
    boards = []
    for index in range(count):
        folder = board_work(work, index)
        console_log, qemu_log = folder / "console.log", folder / "qemu.log"
        if machine.board.console_stdout and qemu_log.is_file():
            console_log.write_text(qemu_log.read_text(encoding="utf-8", errors="replace"), encoding="utf-8")
        text = console_log.read_text(encoding="utf-8", errors="replace") if console_log.is_file() else ""
        runner.log(f"board {index}'s console:\n{text}")
        if udp:
            assert spec.udp_port is not None
            pcap = folder / "board.pcap"
            data = read_regular(pcap, MAX_PCAP_BYTES) if pcap.is_file() else b""
            keys = [k for payload in pcap_payloads(data, spec.udp_port) for k in client_keys(payload)]
        else:
            keys = list(taps[index].keys) if index < len(taps) else []
        counts = relays[index].summary() if link is not None and index < len(relays) else None
        session = Session(
            status[index], seconds, text, console_log, agent_log, qemu_log,
            lines=tuple(lines[index]), restarts=tuple(restarts), link=counts,
        )  # fmt: skip
        boards.append(Board(index, session, tuple(keys), folder))
    return FleetRun(tuple(boards), agent_log, seconds, tuple(agent_argv))
