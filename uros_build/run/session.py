"""One run of a firmware in QEMU against a real Micro XRCE-DDS Agent: QEMU starts with the
firmware's link on a pseudo-terminal, the agent opens that terminal, and QEMU's exit status (the
firmware's, through semihosting) is the result. Every process goes through the one runner.

With a host peer (`uros probe --peer`), the agent speaks DDS (``-m dds``) and runs, with the peer,
in a network namespace of the run's own (run/netns.py): the peer's exit status is the second half of
the verdict (run/peer.py)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import StepFailed
from uros_build.proc import Background, Runner
from uros_build.run import machines, netns

# How long the agent outlives the firmware while a peer runs: the firmware's last samples (sent
# just before its exit) are still on their way through the agent to the peer.
AGENT_GRACE = 2.0


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


def _wait_for_pty(qemu_output: Path, qemu: Background, seconds: float) -> str | None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        text = qemu_output.read_text(encoding="utf-8", errors="replace") if qemu_output.is_file() else ""
        pty = machines.pty_of(text)
        if pty is not None:
            return pty
        if qemu.wait(0.1) is not None:
            return None
    return None


def _wait_for_agent(agent_log: Path, agent: Background, seconds: float) -> None:
    """Until the agent says it opened the link ("running..."), or exits, or ``seconds`` pass."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if agent_log.is_file() and "running..." in agent_log.read_text(encoding="utf-8", errors="replace"):
            return
        if agent.wait(0.05) is not None:
            return


def _namespace(runner: Runner, work: Path) -> Background:
    """A network namespace of the run's own, loopback up with multicast (run/netns.py)."""
    holder = runner.start(netns.holder_argv(), step="the network namespace", output=work / "netns.log")
    end = time.monotonic() + 5.0
    while not netns.entered(holder.proc.pid):
        if holder.wait(0.02) is not None or time.monotonic() > end:
            holder.stop()
            raise StepFailed(
                "uros probe: could not make a network namespace (unshare --net)", f"see {work / 'netns.log'}"
            )
    runner.run(netns.enter_argv(holder.proc.pid, netns.loopback_argv()), step="loopback up", quiet=True)
    return holder


def run_session(
    runner: Runner,
    qemu_program: str,
    machine: machines.Machine,
    elf: Path,
    agent_program: str,
    work: Path,
    timeout: float,
    peer: PeerRun | None = None,
) -> Session:
    console_log, qemu_log, agent_log = work / "console.log", work / "qemu.log", work / "agent.log"
    console_log.unlink(missing_ok=True)
    argv = machines.qemu_argv(machine, elf, console_log)
    started = time.monotonic()
    holder = _namespace(runner, work) if peer is not None else None
    qemu = runner.start([qemu_program, *argv[1:]], step="QEMU", output=qemu_log)
    agent_proc = peer_proc = None
    peer_status = None
    try:
        pty = _wait_for_pty(qemu_log, qemu, 10.0)
        if pty is None:
            raise StepFailed(
                f"QEMU {machine.machine} did not open the firmware's link (no pseudo-terminal)",
                f"its output is in {qemu_log}",
            )
        agent_argv = machines.agent_argv(agent_program, pty)
        if holder is not None:  # Fast DDS in the namespace: the peer's participants find the agent's
            agent_argv = netns.enter_argv(holder.proc.pid, [*agent_argv, "-m", "dds"])
        agent_proc = runner.start(agent_argv, step="the agent", output=agent_log)
        if peer is not None and holder is not None:
            _wait_for_agent(agent_log, agent_proc, 5.0)
            peer_proc = runner.start(
                netns.enter_argv(holder.proc.pid, peer.argv), step="the peer", output=peer.log, env=peer.env
            )
        status = qemu.wait(timeout)
        runner.log(f"the firmware ended after {time.monotonic() - started:.1f} s")
        if peer_proc is not None:  # what the firmware sent last still reaches the peer
            peer_status = peer_proc.wait(min(AGENT_GRACE, max(0.1, timeout - (time.monotonic() - started))))
        # the agent goes with the firmware: it would wait for the pty to come back, and another run's
        # QEMU may be given the same /dev/pts number
        agent_proc.stop()
        if peer_proc is not None and peer_status is None:  # the peer gets what is left of the same time
            peer_status = peer_proc.wait(max(0.1, timeout - (time.monotonic() - started)))
            runner.log(f"the peer ended after {time.monotonic() - started:.1f} s")
    finally:
        qemu.stop()
        for proc in (peer_proc, agent_proc, holder):
            if proc is not None:
                proc.stop()
    seconds = time.monotonic() - started
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
    )  # fmt: skip
