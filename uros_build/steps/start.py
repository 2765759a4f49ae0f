"""The run itself, before the target's lock: its log, what the plan found worth saying, the host
and target facts (the two make the build's context with the plan), then the extra packages and the
dev workspace (built once, shared by every target)."""

from __future__ import annotations

from uros_build import console
from uros_build.colcon import devws, hosttools
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.config.targets import target_profile
from uros_build.proc import Runner
from uros_build.steps.context import Context


def open_run(plan: BuildPlan) -> Runner:
    """The run's log and its first lines (the target, the workspace, warnings, the selection)."""
    ws = plan.workspace
    ws.mark_ignored()
    runner = Runner(ws.new_log("build", plan.target.key), verbose=plan.verbose, owner=str(plan.target_dir))
    console.step(f"uros build: target {plan.target.key}, workspace {ws.root}")
    console.info(f"log: {runner.log_path}")
    if plan.verbose:  # what each setting is and who chose it (config/settings.py's precedence)
        console.info("settings (the command line, then the environment, then uros.yaml, then the default):")
        for line in plan.settings.lines():
            console.info(f"  {line}")
    for warning in plan.warnings:
        console.warn(warning)
    idf, rtos, stack = plan.platform.idf, plan.platform.rtos, plan.platform.ip_stack
    if idf is not None:
        console.info(
            f"ESP-IDF {idf.version_text} project {idf.build_dir} ({idf.target}): {idf.components} "
            f"components, {len(idf.include_dirs)} include folders, sdkconfig.h {idf.sdkconfig_sha256[:12]}"
        )
    if rtos is not None:
        console.info(
            f"RTOS {rtos.name}: kernel {rtos.kernel}, port {' '.join(rtos.port)}, config {rtos.config} "
            f"(headers {rtos.headers_sha256[:12]})"
        )
    if stack is not None:
        console.info(
            f"IP stack {stack.name} (PLATFORM_NAME {stack.platform}): {stack.dir}, config {stack.config} "
            f"(headers {stack.headers_sha256[:12]})"
        )
    _say_selection(plan)
    return runner


def host_facts(plan: BuildPlan, runner: Runner) -> HostFacts:
    """The host's and target's tools (probes cached by program identity)."""
    return hosttools.probe_host(
        runner,
        target_profile(plan.target),
        plan.target_dir,
        check_libraries=plan.config is not None,
        cache=hosttools.ProbeCache(plan.workspace.state_dir / "probes.json"),
    )


def sync_extra_packages(ctx: Context) -> None:
    """The workspace's extra packages (uros.yaml) brought to what uros.yaml says."""
    if ctx.plan.config is not None:
        ctx.plan.workspace.sync_extra_packages(ctx.plan.config)


def build_dev_workspace(ctx: Context) -> None:
    """The dev_ws built when the MCU packages need more of it (shared by every target). A
    workspace with a hand-written uros.yaml may have no dev_ws: nothing to build then."""
    plan, ws = ctx.plan, ctx.plan.workspace
    if (
        plan.config is None
        or not ws.dev_dir.is_dir()
        or not devws.dev_needs_building(ws, plan.workspace_packages)
    ):
        return
    devws.build_dev_workspace(ws, plan.config, plan.distro, ctx.runner, plan.verbose, plan.jobs)


def _say_selection(plan: BuildPlan) -> None:
    sel = plan.selection
    if sel is None:
        return
    if sel.firmware is not None:
        console.info(f"the firmware uses ({sel.firmware.scanned} files read): {sel.firmware.describe()}")
    parts = [f"{', '.join(sel.wanted)} (asked for)"] if sel.wanted else []
    if sel.firmware is not None:
        parts.append(f"{', '.join(sorted(sel.firmware.packages))} (the firmware's)")
    if sel.core:
        parts.append(f"{', '.join(sel.core)} (core)")
    if sel.extra:
        parts.append(f"{', '.join(sel.extra)} (extra packages)")
    console.info(f"building {'; '.join(parts)} and what they depend on")
