"""What the run says: the firmware's console judged stage by stage (run/stages.py), or an app's end
line and QEMU's status (run/appverdict.py), with the peer's exit status; the probe's report.json kept for
`uros size`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace

from uros_build.probesteps.context import Firmware, ProbeContext, Tools
from uros_build.probesteps.tools import agent_root
from uros_build.run import appverdict, builtagent
from uros_build.run import graph as graph_mod
from uros_build.run import machines as probe_mod
from uros_build.run import network as network_mod
from uros_build.run import stages as stages_mod
from uros_build.run.peer import peer_verdict
from uros_build.run.report import write_report
from uros_build.run.session import Session


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
    rtos: str | None  # "freertos": the firmware ran its stages in a FreeRTOS task; None: bare metal
    # name -> {"result": pass/fail/skip, "detail": the firmware's line (+ the host's judgement),
    # "seconds": time's offset from the host clock, restart's seconds to reconnect (host)}
    stages: dict[str, dict[str, object]]
    console_log: str
    agent_log: str
    run_log: str
    peer_status: int | None = None  # --peer: the peer's exit status (None: none ran, or it did not finish)
    # the firmware's status and every stage judged (a host-judged stage can fail a status 0; without
    # root the service stage's status 7 can pass), and with --peer the peer's: what `uros size` counts
    passed: bool = False
    peer_log: str | None = None
    pcap: str | None = None  # over UDP: the board's frames (QEMU's filter-dump); None: the serial link
    # --link: the plan and the relay's counts each way (frames, lost, corrupted, duplicated, reordered)
    link: dict[str, object] | None = None


@dataclass(frozen=True)
class ProbeRun:
    """The probe firmware's run judged: the report, and what its lines say beside it."""

    report: ProbeReport
    stages: tuple[stages_mod.Stage, ...]
    limits: Mapping[str, tuple[int, bool]]  # run/machines.py limits_held
    session: Session
    with_peer: bool  # judged with a peer (--peer; --graph's peer is a stage instead)


def probe_report(ctx: ProbeContext, tools: Tools, firmware: Firmware, ran: Session) -> ProbeRun:
    """The probe firmware's run judged (every stage, the peer's status with --peer), and kept in
    report.json for `uros size`, which counts a passed run's heap and stack against a chip's RAM."""
    plan, text = ctx.plan, ran.console
    used = probe_mod.resources_used(text)
    limits = probe_mod.limits_held(text)
    stages = stages_mod.stages_of(ran.lines, ran.restarts, firmware.middleware, ran.link)
    with_peer = ctx.plan.peer is not None
    # --graph: what uros's own peer saw is a stage, not a verdict
    if ctx.request.graph and ran.peer_log is not None:
        seen = ran.peer_log.read_text(encoding="utf-8", errors="replace")
        name = builtagent.program_name(tools.agent, builtagent.current_agent(agent_root()))
        stages = [*stages, graph_mod.stage(seen, name)]
        with_peer = False
    failed = stages_mod.failed(stages)
    ok = stages_mod.passed(ran.status, stages)
    verdict = stages_mod.failure_line(failed) if failed else probe_mod.verdict(0 if ok else ran.status)
    if with_peer:  # the judged verdict (every stage, not the exit status) and the peer's
        judged = peer_verdict(ok, verdict, ran.peer_status)
        ok, verdict = judged.passed, judged.text
    pcap = ctx.work / network_mod.PCAP if ctx.network is not None else None
    report = ProbeReport(
        target=plan.info.target,
        machine=plan.machine.machine,
        status=ran.status,
        verdict=verdict,
        seconds=round(ran.seconds, 2),
        heap_bytes=used[0] if used else None,
        stack_bytes=used[1] if used else None,
        limits={kind: limit for kind, (limit, _) in limits.items()},
        rtos="freertos" if plan.rtos else None,
        stages={s.name: {"result": s.result, "detail": s.detail, "seconds": s.seconds} for s in stages},
        console_log=str(ran.console_log),
        agent_log=str(ran.agent_log),
        run_log=str(ctx.runner.log_path),
        peer_status=ran.peer_status,
        peer_log=str(ran.peer_log) if ran.peer_log else None,
        passed=ok,
        pcap=str(pcap) if pcap is not None else None,
        link=_link(plan.link.describe(), ran.link) if plan.link is not None and ran.link else None,
    )
    # its bytes' sha256, not build-info's
    write_report(ctx.work, asdict(report), plan.out / plan.info.library.file)
    return ProbeRun(report, tuple(stages), limits, ran, with_peer)


def _link(plan: str, counts: Mapping[str, object]) -> dict[str, object]:
    """--json's link: the plan, the relay's counts each way, the sessions it saw, the best-effort
    samples' figures."""
    return {"plan": plan, **counts, "best_effort": stages_mod.best_effort_figures(counts)}


def app_report(ctx: ProbeContext, firmware: Firmware, ran: Session) -> appverdict.AppReport:
    """An app's run judged: the runner's nonce-marked end line and QEMU's status (run/appverdict.py
    verdict), with --peer the peer's exit status too."""
    plan = ctx.plan.app
    assert plan is not None and firmware.sizes is not None
    end = appverdict.run_end(ran.lines, firmware.nonce)
    started = appverdict.app_started(ran.lines, firmware.nonce)
    app, duration_ms, sizes = plan.app, plan.duration_ms, firmware.sizes
    passed, said = appverdict.verdict(ran.status, end, duration_ms, started)
    report = appverdict.AppReport(
        target=ctx.plan.info.target,
        machine=ctx.plan.machine.machine,
        app=str(app.folder),
        sources=tuple(p.name for p in app.sources),
        rtos="freertos" if ctx.plan.rtos else None,
        packages=tuple(app.packages),
        defines=plan.defines,
        duration=duration_ms / 1000 if duration_ms else None,
        status=ran.status,
        exit_status=end.status if end is not None and end.kind == "exit" else None,
        ended_by=end.kind if end is not None else None,
        passed=passed,
        verdict=said,
        seconds=round(ran.seconds, 2),
        flash_bytes=sizes.text + sizes.data,
        ram_bytes=sizes.data + sizes.bss,
        size=sizes.as_dict(),
        heap_bytes=end.heap_bytes if end is not None else None,
        stack_bytes=end.stack_bytes if end is not None else None,
        elf=str(firmware.elf),
        console_log=str(ran.console_log),
        agent_log=str(ran.agent_log),
        run_log=str(ctx.runner.log_path),
        peer_status=ran.peer_status,
        peer_log=str(ran.peer_log) if ran.peer_log else None,
    )
    if ctx.plan.peer is not None:  # the app's verdict and the peer's together
        judged = peer_verdict(report.passed, report.verdict, ran.peer_status)
        report = replace(report, passed=judged.passed, verdict=judged.text)
    return report
