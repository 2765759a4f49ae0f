"""The verdict said: the report as JSON on stdout with --json, then one line: the failure as the
command's error (exit 5), or what passed, with the logs named."""

from __future__ import annotations

from dataclasses import asdict

from uros_build import console
from uros_build.errors import VerifyError
from uros_build.probesteps.context import ProbeContext
from uros_build.probesteps.report import ProbeReport, ProbeRun
from uros_build.run import appverdict
from uros_build.run import freertos as freertos_mod
from uros_build.run import machines as probe_mod
from uros_build.run import network as network_mod
from uros_build.run import relay as relay_mod
from uros_build.run import stages as stages_mod


def say_probe(ctx: ProbeContext, run: ProbeRun) -> ProbeReport:
    """The probe firmware's verdict: the failure as the error, or what passed and what was skipped."""
    report, ran = run.report, run.session
    target, machine, on = report.target, report.machine, ctx.on
    if run.with_peer:
        return _say_peer(ctx, report)
    _json(ctx, report)
    if not report.passed:
        raise VerifyError(
            f"uros probe {target} ({machine}{on}): {report.verdict}",
            f"the firmware's console: {ran.console_log}; the agent's log: {ran.agent_log}",
        )
    used = probe_mod.resources_used(ran.console)
    memory = f"; heap {used[0]:,} B, stack {used[1]:,} B" if used else ""
    console.step(
        f"probe passed: {target} in QEMU {machine}{on} talked to the agent: "
        f"{stages_mod.describe(run.stages) or 'every sample back'} ({ran.seconds:.1f} s{memory})"
    )
    for skipped in (s for s in run.stages if s.result == "skip"):
        console.info(f"stage {skipped.name} skipped: {skipped.detail}")
    if ctx.plan.rtos is not None:
        console.info(freertos_mod.describe_run(ran.console))
    if ctx.network is not None:
        console.info(network_mod.describe_run(ran.console, ctx.work / network_mod.PCAP))
    if run.limits:
        console.info(probe_mod.describe_limits(run.limits))
    if ran.link is not None:
        console.info(f"the link: {relay_mod.describe_counts(ran.link)}")
        for stage in (s for s in run.stages if s.name in ("best_effort", "time", "restart")):
            console.info(f"{stage.name}: {stage.detail}")
    return report


def _say_peer(ctx: ProbeContext, report: ProbeReport) -> ProbeReport:
    """The run's verdict with a peer (already judged: report.passed); both logs named in the line."""
    _json(ctx, report)
    target, machine = report.target, report.machine
    logs = f"the firmware's console: {report.console_log}; the peer's log: {report.peer_log}"
    if not report.passed:
        raise VerifyError(
            f"uros probe {target} ({machine}) with a peer: {report.verdict}",
            f"{logs}; the agent's log: {report.agent_log}",
        )
    console.step(
        f"probe passed: {target} in QEMU {machine} and a ROS 2 peer on the host, over DDS "
        f"({report.seconds:.1f} s); {logs}"
    )
    return report


def say_app(ctx: ProbeContext, report: appverdict.AppReport) -> appverdict.AppReport:
    """An app's verdict line; with a peer, both logs are named in it (the two halves of the verdict)."""
    _json(ctx, report)
    line = appverdict.describe(report)
    logs = f"its console: {report.console_log}; the agent's log: {report.agent_log}"
    if report.peer_log:
        logs += f"; the peer's log: {report.peer_log}"
    if not report.passed:
        raise VerifyError(line, logs)
    console.step(
        f"{line}; the console: {report.console_log}; the peer's log: {report.peer_log}"
        if report.peer_log
        else line
    )
    return report


def _json(ctx: ProbeContext, report: ProbeReport | appverdict.AppReport) -> None:
    if ctx.request.as_json:
        console.print_json(asdict(report))
