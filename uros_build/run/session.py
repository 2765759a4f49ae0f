"""One run of a firmware in QEMU against a real Micro XRCE-DDS Agent: QEMU starts with the
firmware's link on a pseudo-terminal, the agent opens that terminal, and QEMU's exit status (the
firmware's, through semihosting) is the result. Every process goes through the one runner.

The agent's DDS middleware (Fast DDS; the probe's service stage needs it: the CED middleware makes
no requesters or repliers) runs in a network namespace of the run's own, loopback only
(run/netns.py), with a host peer (`uros probe --peer`) beside it: the peer's exit status is the
second half of the verdict (run/peer.py). uros watches the firmware's console while it runs: each
line gets the host time it appeared (`ConsoleLine.seen`, read every WATCH_SECONDS), and when the
firmware asks for an agent restart (the probe's restart stage) uros stops the agent and, once the
firmware says it lost it, starts it again on the same terminal."""

from __future__ import annotations

import os
import random
import shutil
import socket
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.errors import StepFailed
from uros_build.proc import Background, Runner, stop_leftovers, stop_processes
from uros_build.run import machines, netns
from uros_build.run.relay import FaultPlan, Relay, UdpRelay
from uros_build.run.stages import RESTART_ASKED, ConsoleLine

# How long the agent outlives the firmware while a peer runs: the firmware's last samples (sent
# just before its exit) are still on their way through the agent to the peer.
AGENT_GRACE = 2.0
WATCH_SECONDS = 0.01  # how often the console is read: the resolution of a line's host time
AGENT_LOST = "uros-probe: agent lost"
LOST_WAIT = 5.0  # seconds to wait for AGENT_LOST before starting the agent again all the same


@dataclass(frozen=True)
class SessionSpec:
    """How the agent side of a run is set up (the firmware side is the ELF and the machine)."""

    middleware: str = "dds"  # the agent's -m: dds (Fast DDS, in a namespace of its own) or ced
    restart_agent: bool = False  # stop and start the agent when the firmware asks (RESTART_ASKED)
    # the probe over UDP (run/network.py): the agent on `udp4 -p udp_port`, QEMU's user network for
    # the board's NIC (in the run's namespace when there is one) and its frames recorded in pcap
    udp_port: int | None = None
    pcap: Path | None = None
    link: FaultPlan | None = None  # a relay between QEMU's pty or port and the agent (run/relay.py)


# rmw_microxrcedds (humble) keeps the agent's port in char agent_port[MAX_PORT_LEN], MAX_PORT_LEN 5
# (rmw_microros/rmw_microros.h), NUL included: rmw_uros_options_set_udp_address accepts "53055"
# (strlen <= 5) and keeps "5305" (snprintf). Measured: a probe told 53055 sent every datagram to
# 5305 (board.pcap). The agent's port must have 4 digits at most.
LARGEST_PORT = 9999
FIRST_PORT = 1024


def free_udp_port(tries: int = 200) -> int:
    """A UDP port of 4 digits at most (LARGEST_PORT) that nothing uses now: the agent's, without a
    namespace of the run's own."""
    rng = random.Random()
    for _ in range(tries):
        port = rng.randint(FIRST_PORT, LARGEST_PORT)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            try:
                sock.bind(("0.0.0.0", port))
            except OSError:
                continue
            return port
    raise StepFailed(
        f"uros probe: no free UDP port from {FIRST_PORT} to {LARGEST_PORT} for the agent",
        "run as root (the agent then runs in a network namespace of the run's own, on 8888)",
    )


def relay_port(board_port: int, namespace: bool) -> int:
    """The agent's port behind a UDP relay on the firmware's: the next one in the run's own
    namespace (nothing else is there), else a free one."""
    if namespace:
        return board_port + 1
    while (port := free_udp_port()) == board_port:
        continue
    return port


def middleware_for(peer: bool, euid: int) -> str:
    """The agent's middleware (pure): DDS in a namespace of the run's own when uros can make one
    (root), so the service stage can run (the CED middleware creates no XRCE requesters or
    repliers); without root CED, with no network at all. A peer speaks DDS (it refuses non-root
    itself, before anything is built)."""
    return "dds" if peer or euid == 0 else "ced"


def run_owner(lock: Path) -> str:
    """The UROS_OWNER mark of every process a probe run starts (proc.Runner's owner), from the
    folder of the lock one probe of a target holds: a build's mark is its target folder, so a probe
    never stops a build's processes, nor a build a probe's."""
    return f"uros probe {lock}"


def stop_left_running(owner: str) -> None:
    """With the probe's lock held: stop what an earlier run that was killed (SIGKILL: no finally
    ran) left running, such as a peer's child, as `uros build` does for its target."""
    stopped = stop_leftovers(owner)
    if stopped:
        console.warn(
            f"stopped {len(stopped)} processes left running by an earlier uros probe that was killed "
            f"(pids {' '.join(map(str, stopped))})"
        )


def stop_the_rest(runner: Runner, namespace: str | None) -> None:
    """Once the run's own programs are stopped: whatever they started that still runs, by its mark
    (a peer's plain child) and by the run's network namespace (a daemon, even one that cleared its
    environment), so nothing of the run outlives it nor keeps its namespace alive."""
    stopped = runner.stop_marked()
    if namespace is not None:
        stopped += stop_processes(netns.members(namespace))
    if stopped:
        console.warn(
            f"stopped {len(stopped)} processes the run's programs left running (pids "
            f"{' '.join(map(str, stopped))}): a peer must end what it starts"
        )


@dataclass(frozen=True)
class SessionRun:
    """What one session runs: QEMU and the agent (the programs found), the firmware's ELF on its
    machine, the work folder its logs go to, and how long the firmware may take."""

    qemu_program: str
    agent_program: str
    machine: machines.Machine
    elf: Path
    work: Path
    timeout: float


@dataclass(frozen=True)
class PeerRun:
    """A host program the run starts once the agent is up, beside the firmware (its exit status
    counts in the verdict)."""

    argv: tuple[str, ...]
    env: Mapping[str, str]
    log: Path


@dataclass(frozen=True)
class Session:
    status: int | None  # the firmware's exit status; None: it did not finish in time
    seconds: float
    console: str  # the firmware's UART0
    console_log: Path
    agent_log: Path
    qemu_log: Path
    peer_status: int | None = None  # the peer's exit status; None: no peer, or it did not finish
    peer_log: Path | None = None  # None: no peer ran
    lines: tuple[ConsoleLine, ...] = ()  # the console as it appeared
    restarts: tuple[tuple[float, float], ...] = ()  # host times: the agent stopped, started again
    link: dict[str, object] | None = None  # the relay's counts per direction (spec.link)


class ConsoleReader:
    """The console file's whole lines as QEMU writes them, each stamped when first read."""

    def __init__(self, path: Path) -> None:
        self.path, self.offset, self.partial = path, 0, b""

    def read(self) -> list[ConsoleLine]:
        if not self.path.is_file():
            return []
        with self.path.open("rb") as f:
            f.seek(self.offset)
            data = f.read()
        self.offset += len(data)
        now = time.time()
        *whole, self.partial = (self.partial + data).split(b"\n")
        return [ConsoleLine(now, x.decode("utf-8", "replace").rstrip("\r")) for x in whole]


def wait_for_pty(qemu_output: Path, qemu: Background, seconds: float) -> str | None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        text = qemu_output.read_text(encoding="utf-8", errors="replace") if qemu_output.is_file() else ""
        pty = machines.pty_of(text)
        if pty is not None:
            return pty
        if qemu.wait(0.1) is not None:
            return None
    return None


def _wait_for_agent(agent_log: Path, agent: Background, seconds: float, link: str | None = None) -> None:
    """Until the agent says it opened the link ("running..."), or holds the link open (an agent
    built without a logger, as `uros agent build`'s, says nothing), or exits, or ``seconds`` pass."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if agent_log.is_file() and "running..." in agent_log.read_text(encoding="utf-8", errors="replace"):
            return
        if link is not None and _holds(agent.proc.pid, link):
            return
        if agent.wait(0.05) is not None:
            return


def _holds(pid: int, path: str) -> bool:
    """Process ``pid`` has ``path`` open (Linux: /proc/<pid>/fd; elsewhere: never known)."""
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        try:
            if os.readlink(f"/proc/{pid}/fd/{fd}") == path:
                return True
        except OSError:
            continue
    return False


# QEMU 7.2's pty chardev (chardev/char-pty.c) looks for the other end of a pty nobody held once a
# second; a firmware that runs before it did may write through and never read again (docs/esp32.md)
PTY_POLL_SECONDS = 2.0


def continue_paused(monitor: Path, qemu: Background, seconds: float) -> None:
    """Say `cont` on the monitor of a QEMU started paused (-S): the firmware runs from then on."""
    end = time.monotonic() + seconds
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
        while True:
            try:
                conn.connect(str(monitor))
                break
            except OSError as exc:
                if qemu.wait(0.05) is not None or time.monotonic() > end:
                    raise StepFailed(f"QEMU's monitor {monitor} did not answer: {exc}") from None
        conn.settimeout(max(0.1, end - time.monotonic()))
        heard = b""
        try:
            while heard.count(b"(qemu)") < 1:  # the banner and its first prompt
                heard += conn.recv(4096) or b"(qemu)"
            conn.sendall(b"cont\n")
            while heard.count(b"(qemu)") < 2:  # the prompt after cont
                heard += conn.recv(4096) or b"(qemu)"
        except OSError as exc:
            raise StepFailed(f"QEMU's monitor {monitor} did not take `cont`: {exc}") from None


def open_namespace(runner: Runner, work: Path) -> Background:
    """A network namespace of the run's own, loopback up with multicast (run/netns.py)."""
    holder = runner.start(netns.holder_argv(), step="the network namespace", output=work / "netns.log")
    end = time.monotonic() + 5.0
    while not netns.entered(holder.proc.pid):
        if holder.wait(0.02) is not None or time.monotonic() > end:
            holder.stop()
            raise StepFailed(
                "uros probe: could not make a network namespace (unshare --net)", f"see {work / 'netns.log'}"
            )
    try:
        runner.run(netns.enter_argv(holder.proc.pid, netns.loopback_argv()), step="loopback up", quiet=True)
    except BaseException:
        holder.stop()
        raise
    return holder


def run_session(
    runner: Runner, run: SessionRun, peer: PeerRun | None = None, spec: SessionSpec = SessionSpec()
) -> Session:
    qemu_program, agent_program, machine, elf = run.qemu_program, run.agent_program, run.machine, run.elf
    work, timeout = run.work, run.timeout
    console_log, qemu_log, agent_log = work / "console.log", work / "qemu.log", work / "agent.log"
    console_log.unlink(missing_ok=True)
    udp = spec.udp_port is not None
    # a board that starts paused: the monitor's socket in a short folder of its own (a Unix socket's
    # path has at most 107 bytes; the work folder's may be longer)
    paused = machine.board.start_paused and not udp
    started = time.monotonic()
    middleware = "dds" if peer is not None else spec.middleware  # a peer speaks DDS
    holder = open_namespace(runner, work) if middleware == "dds" else None
    namespace = netns.namespace_id(holder.proc.pid) if holder is not None else None
    # made once the namespace is there, so that a namespace that cannot be made leaves no folder
    monitor: Path | None = None
    try:
        monitor = Path(tempfile.mkdtemp(prefix="uros-qemu-")) / "monitor" if paused else None
        argv = machines.qemu_argv(machine, elf, console_log, spec.pcap if udp else None, monitor)
        qemu_argv = [qemu_program, *argv[1:]]
        if udp and holder is not None:  # the user network's 10.0.2.2 is the loopback of QEMU's namespace
            qemu_argv = netns.enter_argv(holder.proc.pid, qemu_argv)
        qemu = runner.start(qemu_argv, step="QEMU", output=qemu_log)
    except BaseException:
        if holder is not None:
            holder.stop()
        if monitor is not None:
            shutil.rmtree(monitor.parent, ignore_errors=True)
        raise
    agents: list[Background] = []
    relay: Relay | UdpRelay | None = None
    peer_proc = None
    peer_status = None
    lines: list[ConsoleLine] = []
    restarts: list[tuple[float, float]] = []
    try:
        if spec.udp_port is not None:
            agent_port = spec.udp_port
            if spec.link is not None:  # the relay on the firmware's port, the agent on another
                agent_port = relay_port(spec.udp_port, holder is not None)
                space = netns.namespace_of(holder.proc.pid) if holder is not None else None
                relay = UdpRelay(spec.udp_port, agent_port, spec.link, space)
                relay.start()
                runner.log(f"the link: a relay udp {spec.udp_port} <-> {agent_port} ({spec.link.describe()})")
            agent_argv = machines.agent_udp_argv(agent_program, agent_port, middleware)
        else:
            pty = wait_for_pty(qemu_log, qemu, 10.0)
            if pty is None:
                raise StepFailed(
                    f"QEMU {machine.machine} did not open the firmware's link (no pseudo-terminal)",
                    f"its output is in {qemu_log}",
                )
            if spec.link is not None:  # the agent on the relay's pty, the relay on QEMU's
                relay = Relay(pty, spec.link)
                relay.start()
                runner.log(f"the link: a relay {pty} <-> {relay.agent_pty} ({spec.link.describe()})")
                pty = relay.agent_pty
            agent_argv = machines.agent_argv(agent_program, pty, middleware)
        if holder is not None:  # Fast DDS in the namespace: the peer's participants find the agent's
            agent_argv = netns.enter_argv(holder.proc.pid, agent_argv)
        agents.append(runner.start(agent_argv, step="the agent", output=agent_log))
        if monitor is not None:  # the agent holds the link before the firmware's first byte
            _wait_for_agent(agent_log, agents[0], 5.0, pty)
            qemu.wait(PTY_POLL_SECONDS)  # QEMU sees the pty's other end (its timer: once a second)
            continue_paused(monitor, qemu, 5.0)
            runner.log(f"QEMU started paused; `cont` {PTY_POLL_SECONDS:.0f} s after the agent held {pty}")
        if peer is not None and holder is not None:
            _wait_for_agent(agent_log, agents[0], 5.0, None if spec.udp_port is not None else pty)
            peer_proc = runner.start(
                netns.enter_argv(holder.proc.pid, peer.argv), step="the peer", output=peer.log, env=peer.env
            )
        # the firmware's text: its console file, or QEMU's own output (meta/probe/machines.yaml)
        console = ConsoleReader(qemu_log if machine.board.console_stdout else console_log)
        stopped: float | None = None  # when uros stopped the agent for a restart
        status = None
        while time.monotonic() - started < timeout:
            status = qemu.wait(WATCH_SECONDS)
            new = console.read()
            lines.extend(new)
            texts = {line.text for line in new}
            if spec.restart_agent and RESTART_ASKED in texts and stopped is None and not restarts:
                agents[-1].stop()
                stopped = time.time()
            # once the firmware lost it (or said nothing for LOST_WAIT: it then fails the stage itself)
            if stopped is not None and (AGENT_LOST in texts or time.time() - stopped > LOST_WAIT):
                agents.append(runner.start(agent_argv, step="the agent", output=work / "agent-restarted.log"))
                restarts.append((stopped, time.time()))
                stopped = None
            if status is not None:
                break
        runner.log(f"the firmware ended after {time.monotonic() - started:.1f} s")
        if peer_proc is not None:  # what the firmware sent last still reaches the peer
            peer_status = peer_proc.wait(min(AGENT_GRACE, max(0.1, timeout - (time.monotonic() - started))))
        # the agent goes with the firmware: it would wait for the pty to come back, and another run's
        # QEMU may be given the same /dev/pts number
        agents[-1].stop()
        if peer_proc is not None and peer_status is None:  # the peer gets what is left of the same time
            peer_status = peer_proc.wait(max(0.1, timeout - (time.monotonic() - started)))
            runner.log(f"the peer ended after {time.monotonic() - started:.1f} s")
    finally:
        qemu.stop()
        for proc in (peer_proc, *agents, holder):
            if proc is not None:
                proc.stop()
        if relay is not None:
            relay.stop()
        stop_the_rest(runner, namespace)
        if monitor is not None:
            shutil.rmtree(monitor.parent, ignore_errors=True)
    seconds = time.monotonic() - started
    if machine.board.console_stdout and qemu_log.is_file():  # console.log as on every machine
        console_log.write_text(qemu_log.read_text(encoding="utf-8", errors="replace"), encoding="utf-8")
    text = console_log.read_text(encoding="utf-8", errors="replace") if console_log.is_file() else ""
    runner.log("firmware console:\n" + text)
    if peer is not None:
        runner.log(
            "peer output:\n"
            + (peer.log.read_text(encoding="utf-8", errors="replace") if peer.log.is_file() else "")
        )
    return Session(
        status, seconds, text, console_log, agent_log, qemu_log,
        peer_status=peer_status, peer_log=peer.log if peer is not None else None,
        lines=tuple(lines), restarts=tuple(restarts), link=relay.summary() if relay is not None else None,
    )  # fmt: skip
