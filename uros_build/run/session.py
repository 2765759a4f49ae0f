"""One run of a firmware in QEMU against a real Micro XRCE-DDS Agent: QEMU starts with the
firmware's link on a pseudo-terminal, the agent opens that terminal, and QEMU's exit status (the
firmware's, through semihosting) is the result. Every process goes through the one runner."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import StepFailed
from uros_build.proc import Background, Runner
from uros_build.run import machines


@dataclass(frozen=True)
class Session:
    status: int | None  # the firmware's exit status; None: it did not finish in time
    seconds: float
    console: str  # the firmware's UART0
    console_log: Path
    agent_log: Path
    qemu_log: Path


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


def run_session(
    runner: Runner,
    qemu_program: str,
    machine: machines.Machine,
    elf: Path,
    agent_program: str,
    work: Path,
    timeout: float,
) -> Session:
    console_log, qemu_log, agent_log = work / "console.log", work / "qemu.log", work / "agent.log"
    console_log.unlink(missing_ok=True)
    argv = machines.qemu_argv(machine, elf, console_log)
    started = time.monotonic()
    qemu = runner.start([qemu_program, *argv[1:]], step="QEMU", output=qemu_log)
    agent_proc = None
    try:
        pty = _wait_for_pty(qemu_log, qemu, 10.0)
        if pty is None:
            raise StepFailed(
                f"QEMU {machine.machine} did not open the firmware's link (no pseudo-terminal)",
                f"its output is in {qemu_log}",
            )
        agent_proc = runner.start(machines.agent_argv(agent_program, pty), step="the agent", output=agent_log)
        status = qemu.wait(timeout)
    finally:
        qemu.stop()
        if agent_proc is not None:
            agent_proc.stop()
    seconds = time.monotonic() - started
    text = console_log.read_text(encoding="utf-8", errors="replace") if console_log.is_file() else ""
    runner.log("firmware console:\n" + text)
    return Session(status, seconds, text, console_log, agent_log, qemu_log)
