"""`uros probe --instances N`: the session of N boards on one agent (run/fleet.py), each board's
stages judged apart from what uros measured (its console and exit status, the client keys its
CREATE_CLIENT carried on the wire), the report (report-fleet.json) and the verdict: the run passes
only when every board passes; boards that shared a client key fail by name, with the fix."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

from uros_build import console
from uros_build.errors import ConfigError, VerifyError
from uros_build.files import write_atomic
from uros_build.probesteps.context import Firmware, ProbeContext, Tools
from uros_build.run import fleet as fleet_mod
from uros_build.run import machines as probe_mod
from uros_build.run import relay as relay_mod
from uros_build.run import stages as stages_mod
from uros_build.run.session import SessionRun, SessionSpec

REPORT = "report-fleet.json"


@dataclass(frozen=True)
class BoardReport:
    index: int
    status: int | None  # its QEMU's exit status (the firmware's); None: it did not finish in time
    passed: bool
    verdict: str
    stages: dict[str, dict[str, object]]
    client_keys: list[str]  # the keys of its CREATE_CLIENTs, read off the wire
    console_log: str
    heap_bytes: int | None
    stack_bytes: int | None
    link: dict[str, object] | None = None  # --link: the relay's counts each way on its link


@dataclass(frozen=True)
class FleetReport:
    target: str
    machine: str
    instances: int
    client_keys: str  # own, same or drawn (--client-keys)
    transport: str  # the agent's: multiserial or udp4
    passed: bool
    verdict: str
    seconds: float
    boards: list[BoardReport]
    agent_log: str
    run_log: str


def run(ctx: ProbeContext, tools: Tools, firmware: Firmware) -> FleetReport:
    """The boards' session, judged, kept and said."""
    request, plan, network = ctx.request, ctx.plan, ctx.network
    keys = fleet_mod.check_keys(request.client_keys, request.instances)
    if plan.link is not None and network is not None:
        raise ConfigError(
            "--link with --instances: each board's relay is on its serial link; this library runs over UDP",
            "drop --link, or probe one board",
        )
    udp_port = firmware.port if network is not None else None
    spec = SessionSpec(middleware=firmware.middleware, restart_agent=True, udp_port=udp_port)
    what = SessionRun(tools.qemu, tools.agent, plan.machine, firmware.elf, ctx.work, request.timeout)
    transport = "udp4" if udp_port is not None else "multiserial"
    console.info(
        f"{request.instances} boards of one image on one agent ({transport}), client keys: {_KEYS[keys]}"
    )
    ids = fleet_mod.uids(request.instances, keys)
    ran = fleet_mod.run_fleet(ctx.runner, what, spec, ids, plan.link)
    report = judge(ctx, ran, keys, transport, firmware.middleware)
    write_atomic(ctx.work / REPORT, json.dumps(asdict(report), indent=2, sort_keys=True) + "\n")
    return say(ctx, report)


_KEYS = {
    "own": "each board its own, from the unique id uros passes it",
    "same": "the same on every board (a test of the failure: it must fail)",
    "drawn": "the library's own draw (srand(uxr_nanos()); rand())",
}


def judge(
    ctx: ProbeContext, ran: fleet_mod.FleetRun, keys: str, transport: str, middleware: str
) -> FleetReport:
    """Every board's stages (the probe's, and the host's client-key stage) judged apart."""
    sent = {b.index: b.keys for b in ran.boards}
    boards = []
    for board in ran.boards:
        session = board.session
        stages = [
            *stages_mod.stages_of(session.lines, session.restarts, middleware),
            fleet_mod.key_stage(board.index, sent),
        ]
        failed = stages_mod.failed(stages)
        ok = stages_mod.passed(session.status, stages)
        verdict = (
            stages_mod.failure_line(failed) if failed else probe_mod.verdict(0 if ok else session.status)
        )
        used = probe_mod.resources_used(session.console)
        boards.append(
            BoardReport(
                index=board.index,
                status=session.status,
                passed=ok,
                verdict=verdict,
                stages={
                    s.name: {"result": s.result, "detail": s.detail, "seconds": s.seconds} for s in stages
                },
                client_keys=[fleet_mod.key_text(k) for k in dict.fromkeys(board.keys)],
                console_log=str(session.console_log),
                heap_bytes=used[0] if used else None,
                stack_bytes=used[1] if used else None,
                link=session.link,
            )
        )
    shared = fleet_mod.shared_line(sent)
    first = next((b for b in boards if not b.passed), None)
    verdict = shared or (f"board {first.index}: {first.verdict}" if first else "every board passed")
    return FleetReport(
        target=ctx.plan.info.target,
        machine=ctx.plan.machine.machine,
        instances=len(boards),
        client_keys=keys,
        transport=transport,
        passed=first is None and shared is None,
        verdict=verdict,
        seconds=round(ran.seconds, 2),
        boards=boards,
        agent_log=str(ran.agent_log),
        run_log=str(ctx.runner.log_path),
    )


def say(ctx: ProbeContext, report: FleetReport) -> FleetReport:
    """Each board's line, then the run's: the failure as the error (exit 5), or what passed."""
    if ctx.request.as_json:
        console.print_json(asdict(report))
    for board in report.boards:
        stages = ", ".join(f"{name} {s['result']}" for name, s in board.stages.items())
        console.info(f"board {board.index} ({', '.join(board.client_keys) or 'no key seen'}): {stages}")
        if board.link is not None:
            console.info(f"board {board.index}'s link: {relay_mod.describe_counts(board.link)}")
    where = f"{report.instances} boards of {report.target} in QEMU {report.machine}{ctx.on} on one agent"
    if not report.passed:
        raise VerifyError(
            f"uros probe {where}: {report.verdict}",
            f"each board's console: {ctx.work}/board<i>/console.log; the agent's log: {report.agent_log}",
        )
    keys = {k for b in report.boards for k in b.client_keys}
    skipped = [n for n, s in report.boards[0].stages.items() if s["result"] == "skip"]
    but = f" (skipped: {', '.join(skipped)})" if skipped else ""
    console.step(
        f"probe passed: {where} ({report.transport}): every board passed its stages{but}; "
        f"{len(keys)} client keys, none shared ({report.seconds:.1f} s)"
    )
    return report
