"""The firmware of the run, configured and built like a user's project against the output: the
probe's (templates/probe/) or the user's --app on the probe's board; the agent's middleware and port
chosen first, since the firmware is built for them."""

from __future__ import annotations

import os

from uros_build.probesteps.context import Firmware, ProbeContext
from uros_build.run import app as app_mod
from uros_build.run import freertos as freertos_mod
from uros_build.run import machines as probe_mod
from uros_build.run import network as network_mod
from uros_build.run.firmware import FirmwareBuild, build_firmware
from uros_build.run.session import PeerRun, free_udp_port, middleware_for
from uros_build.target.toolsearch import bintools_beside


def build(ctx: ProbeContext, peer: PeerRun | None) -> Firmware:
    """The agent's DDS middleware: its CED one creates no XRCE requesters or repliers (the service
    stage's rclc_service_init_default returned 1 with -m ced), so it runs in a namespace of its own;
    that needs root: without, the CED middleware and no service stage (said so), not a refusal. Over
    UDP the agent's port is the firmware's to know: fixed in the run's own namespace, else free."""
    plan, network, rtos = ctx.plan, ctx.network, ctx.plan.rtos
    middleware = middleware_for(peer is not None, os.geteuid())
    port = network_mod.NAMESPACE_PORT if middleware == "dds" else free_udp_port()
    defines = (*freertos_mod.cmake_defines(rtos), *network_mod.cmake_defines(network, port))
    folders = (*freertos_mod.firmware_folders(rtos), *network_mod.firmware_folders(network))
    verbose = ctx.request.verbose
    if plan.app is None:
        # --link: the best-effort stage, whose loss the relay counts (templates/probe/stage_best_effort.c)
        lossy = f"-DUROS_PROBE_LINK={'ON' if plan.link is not None else 'OFF'}"
        spec = FirmwareBuild(
            probe_mod.firmware_sources(),
            "uros_probe",
            plan.machine,
            plan.out,
            ctx.work,
            (*defines, lossy),
            folders,
        )
        return Firmware(build_firmware(ctx.runner, spec, verbose), middleware, port)
    compiler = plan.info.compiler.path if plan.info.compiler is not None else None
    tools = bintools_beside(compiler)
    staged, nonce = app_mod.stage_app(plan.app, ctx.work)
    spec = FirmwareBuild(
        staged, "uros_app", plan.machine, plan.out, ctx.work, defines, folders, {"app": plan.app.app.folder}
    )
    elf, sizes = app_mod.build_app(ctx.runner, spec, verbose, plan.app.app, tools)
    return Firmware(elf, middleware, port, sizes, nonce)
