"""The session: QEMU with the firmware, the agent on its link (and the peer beside it), until the
firmware ends or the timeout (run/session.py)."""

from __future__ import annotations

from uros_build import console
from uros_build.probesteps.context import Firmware, ProbeContext, Tools
from uros_build.run import app as app_mod
from uros_build.run import network as network_mod
from uros_build.run.session import PeerRun, Session, SessionRun, SessionSpec, run_session
from uros_build.run.stages import CED_SERVICE as CED

NO_SERVICES = "services cannot be created"


def run(ctx: ProbeContext, tools: Tools, peer: PeerRun | None, firmware: Firmware) -> Session:
    """The probe's session restarts the agent when the firmware asks (its restart stage); an app's
    runs --timeout, or with --duration that and the runner's start-up."""
    plan, network, middleware = ctx.plan, ctx.network, firmware.middleware
    pcap = ctx.work / network_mod.PCAP if network is not None else None
    udp_port = firmware.port if network is not None else None
    timeout = ctx.request.timeout
    link = plan.link
    if link is not None:
        console.info(f"the link: a relay between QEMU and the agent ({link.describe()})")
    if plan.app is None:
        if middleware == "ced":
            console.info(f"not root: the agent runs its CED middleware (no network namespace); {CED}")
        spec = SessionSpec(middleware=middleware, restart_agent=True, udp_port=udp_port, pcap=pcap, link=link)
    else:
        timeout = app_mod.session_timeout(timeout, plan.app.duration_ms)
        # without root (no namespace to run DDS in) the agent's CED middleware, as for the built-in
        # probe: an app's topics need no DDS, its services do (said so)
        options = plan.info.cmake_options
        note = network_mod.default_address_note(options or {}, firmware.port) if network is not None else None
        if note:
            console.info(note)
        spec = SessionSpec(middleware=middleware, udp_port=udp_port, pcap=pcap, link=link)
        if middleware == "ced":
            console.info(f"not root: the agent runs its CED middleware (no network namespace): {NO_SERVICES}")
    what = SessionRun(tools.qemu, tools.agent, plan.machine, firmware.elf, ctx.work, timeout)
    return run_session(ctx.runner, what, peer=peer, spec=spec)
