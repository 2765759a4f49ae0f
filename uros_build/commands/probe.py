"""`uros probe`: does a built libmicroros.a work at run time? Build the probe firmware (or the user's
--app) against the output's CMake package, boot it in QEMU when the target has a machine there,
connect it over an emulated UART (or UDP) to a real Micro XRCE-DDS Agent on the host, and report
what the firmware saw.

The probe is the sequence of steps in uros_build/probesteps/, each over one frozen context, as a
build's are: the request planned (output, board, kernel; nothing runs) → under the target's probe
lock the run opened → QEMU and the agent found → the peer's environment → the firmware built → the
session (QEMU, the agent on its link) → the report (the stages judged, report.json) → the verdict.
"""

from __future__ import annotations

from uros_build.probesteps import firmware, fleet, peer, plan, report, session, start, tools, verdict
from uros_build.probesteps.context import ProbeRequest
from uros_build.probesteps.fleet import FleetReport
from uros_build.probesteps.plan import app_request
from uros_build.probesteps.report import ProbeReport
from uros_build.run.appverdict import AppReport

__all__ = ["ProbeRequest", "app_request", "probe"]  # what cli/data.py hands the command


def probe(request: ProbeRequest) -> ProbeReport | AppReport | FleetReport:
    """One probe, every action in the order it is taken: each step takes the frozen context and
    what earlier steps returned."""
    planned = plan.plan_probe(request)
    with start.probe_lock(planned):
        ctx = start.open_run(request, planned)
        programs = tools.find_tools(ctx)
        peer_run = peer.prepare_peer(ctx)
        built = firmware.build(ctx, peer_run)
        if request.instances > 1:  # N boards on one agent, each judged apart (run/fleet.py)
            return fleet.run(ctx, programs, built)
        ran = session.run(ctx, programs, peer_run, built)
        if planned.app is not None:
            return verdict.say_app(ctx, report.app_report(ctx, built, ran))
        return verdict.say_probe(ctx, report.probe_report(ctx, programs, built, ran))
