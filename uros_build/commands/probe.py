"""`uros probe`: does a built libmicroros.a work at run time? Build the probe firmware against the
output's CMake package, boot it in QEMU when the target has a machine there, connect it over an
emulated UART to a real Micro XRCE-DDS Agent on the host, and report what the firmware saw.

output → QEMU machine (meta/probe/machines.yaml) → qemu-system-arm and the agent found → firmware
configured and built like a user's project → QEMU started (its link on a pseudo-terminal) → the
agent on that terminal → QEMU's exit status (the firmware's main()) → one line, the logs kept.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from uros_build import console
from uros_build.colcon.fingerprint import digest
from uros_build.config.plan import finish_killed_swaps, folder_key, resolve_output
from uros_build.config.settings import AGENT, resolve_outside
from uros_build.errors import ConfigError, MissingToolError, StepFailed, VerifyError
from uros_build.files import locked
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.proc import Background, Runner, new_run_log, user_log_dir
from uros_build.sources.workspace import workspace_of_output
from uros_build.target import machines as probe_mod

_AGENT_HINT = (
    "pass --agent PATH (or set UROS_AGENT) to a MicroXRCEAgent: eProsima Micro-XRCE-DDS-Agent v2.3.0 "
    "builds against Debian 12's libfastcdr-dev and libspdlog-dev with -DUAGENT_SUPERBUILD=OFF "
    "-DUAGENT_USE_SYSTEM_FASTCDR=ON -DUAGENT_USE_SYSTEM_LOGGER=ON -DUAGENT_P2P_PROFILE=OFF "
    "-DCMAKE_CXX_FLAGS=-DFMT_DEPRECATED_OSTREAM=1 (docs/probe.md)"
)


@dataclass(frozen=True)
class ProbeReport:
    target: str
    machine: str
    status: int | None  # the firmware's exit status; None: it did not finish in time
    verdict: str
    seconds: float
    heap_bytes: int | None
    stack_bytes: int | None
    limits: dict[str, int]  # nodes/publishers/subscriptions: as many as RMW_UXRCE_MAX_* were created
    console_log: str
    agent_log: str
    run_log: str


def _agent(given: str | None, runner: Runner) -> str:
    wanted = resolve_outside(AGENT, given or None).value  # --agent, else $UROS_AGENT
    if not wanted:
        raise MissingToolError("uros probe: no Micro XRCE-DDS Agent was given", _AGENT_HINT)
    if os.sep in wanted and not (Path(wanted).is_file() and os.access(wanted, os.X_OK)):
        raise MissingToolError(f"--agent {wanted}: no such program", _AGENT_HINT)
    return runner.which(wanted, _AGENT_HINT)


def _wait_for_pty(qemu_output: Path, qemu: Background, seconds: float) -> str | None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        text = qemu_output.read_text(encoding="utf-8", errors="replace") if qemu_output.is_file() else ""
        pty = probe_mod.pty_of(text)
        if pty is not None:
            return pty
        if qemu.wait(0.1) is not None:
            return None
    return None


def probe(
    output: Path | None,
    workspace: Path | None,
    toolchain: str | None,
    agent: str | None,
    timeout: float,
    as_json: bool,
    verbose: bool = False,
) -> ProbeReport:
    check_timeout(timeout)
    finish_killed_swaps(output, workspace)
    out = resolve_output(output, workspace, toolchain).resolve()
    info = read_build_info(out, "OUTPUT")
    if output is not None and toolchain is not None:
        check_toolchain_matches(toolchain, folder_key(toolchain), out, info.target)
    machine = probe_mod.machine_for(info.target, probe_mod.load_machines())
    ws = workspace_of_output(out, info.target)
    base = ws.state_dir if ws is not None else user_log_dir().parent
    # One probe of a target at a time: two at once shared the work folder (one deleted the other's
    # firmware and console log) and blamed a good library ("no agent answered", "an entity could not
    # be created"); the second waits, and says for whom.
    with locked(base / "probe" / "locks" / info.target, info.target, command="uros probe"):
        return _probe(out, info, machine, base, agent, timeout, as_json, verbose)


def check_timeout(timeout: float) -> None:
    """--timeout is a number of seconds more than 0 (0 or less gave "the firmware did not finish")."""
    if not (math.isfinite(timeout) and timeout > 0):
        raise ConfigError(
            f"--timeout {timeout:g}: must be a number of seconds more than 0",
            "e.g. --timeout 60",
        )


def check_toolchain_matches(toolchain: str, key: str, out: Path, target: str) -> None:
    """OUTPUT names the output to probe; a --toolchain beside it that names another target
    contradicts it (it was ignored without a word)."""
    if key != target:
        raise ConfigError(
            f"--toolchain {toolchain}: OUTPUT {out} is the output of {target}, not {key}",
            "pass OUTPUT or --toolchain, not both",
        )


def _probe(
    out: Path,
    info: BuildInfo,
    machine: probe_mod.Machine,
    base: Path,
    agent: str | None,
    timeout: float,
    as_json: bool,
    verbose: bool,
) -> ProbeReport:
    work = base / "probe" / f"{info.target}-{digest(str(out))[:10]}"
    work.mkdir(parents=True, exist_ok=True)
    runner = Runner(new_run_log(work / "log", "probe", info.target), verbose=verbose)
    console.step(f"uros probe: {out} ({info.target}) in QEMU {machine.machine}")
    console.info(f"log: {runner.log_path}")
    qemu_program = runner.which(
        "qemu-system-arm", "install qemu-system-arm (Debian: apt-get install qemu-system-arm)"
    )
    agent_program = _agent(agent, runner)
    cmake = runner.which("cmake")

    # the firmware, built as a user's project would be: the output's toolchain file and package
    src, build = work / "src", work / "build"
    # afresh every time (it takes a second): another output of the target has another toolchain file
    shutil.rmtree(src, ignore_errors=True)
    shutil.rmtree(build, ignore_errors=True)
    shutil.copytree(probe_mod.firmware_sources(), src)
    runner.run(
        [cmake, "-S", str(src), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
         f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={out}"],
        step="configure the probe firmware", quiet=not verbose,
    )  # fmt: skip
    runner.run([cmake, "--build", str(build)], step="build the probe firmware", quiet=not verbose)
    elf = next(iter(sorted(p for p in build.glob("uros_probe*") if p.suffix in ("", ".elf"))), None)
    if elf is None or not elf.is_file():
        raise StepFailed(
            "build the probe firmware: no uros_probe ELF was made", f"the log is {runner.log_path}"
        )

    console_log, qemu_log, agent_log = work / "console.log", work / "qemu.log", work / "agent.log"
    console_log.unlink(missing_ok=True)
    argv = probe_mod.qemu_argv(machine, elf, console_log)
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
        agent_proc = runner.start(
            probe_mod.agent_argv(agent_program, pty), step="the agent", output=agent_log
        )
        status = qemu.wait(timeout)
    finally:
        qemu.stop()
        if agent_proc is not None:
            agent_proc.stop()
    seconds = time.monotonic() - started
    text = console_log.read_text(encoding="utf-8", errors="replace") if console_log.is_file() else ""
    runner.log("firmware console:\n" + text)
    used = probe_mod.resources_used(text)
    limits = probe_mod.limits_held(text)
    report = ProbeReport(
        target=info.target,
        machine=machine.machine,
        status=status,
        verdict=probe_mod.verdict(status),
        seconds=round(seconds, 2),
        heap_bytes=used[0] if used else None,
        stack_bytes=used[1] if used else None,
        limits={kind: limit for kind, (limit, _) in limits.items()},
        console_log=str(console_log),
        agent_log=str(agent_log),
        run_log=str(runner.log_path),
    )
    if as_json:
        sys.stdout.write(json.dumps(asdict(report), indent=2, sort_keys=True) + "\n")
    if status != 0:
        raise VerifyError(
            f"uros probe {info.target} ({machine.machine}): {report.verdict}",
            f"the firmware's console: {console_log}; the agent's log: {agent_log}",
        )
    memory = f"; heap {used[0]:,} B, stack {used[1]:,} B" if used else ""
    console.step(
        f"probe passed: {info.target} in QEMU {machine.machine} talked to the agent: session, node, "
        f"publisher, subscription, every sample back ({seconds:.1f} s{memory})"
    )
    if limits:
        console.info(probe_mod.describe_limits(limits))
    return report
