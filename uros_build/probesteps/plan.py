"""Before anything runs: `uros probe`'s command line checked and what it probes found (the output,
its build-info.json, the packages the firmware needs, the QEMU board, FreeRTOS or bare metal), as
config/plan.py plans a build. Every refusal here starts no process."""

from __future__ import annotations

import math
import os
from pathlib import Path

from uros_build.config.outputs import finish_killed_swaps, resolve_output
from uros_build.config.resolver import resolve_outside
from uros_build.config.settings import FREERTOS, ROS2_VENV
from uros_build.config.targets import folder_key
from uros_build.errors import ConfigError
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.probesteps.context import AppRequest, ProbePlan, ProbeRequest
from uros_build.run import app as app_mod
from uros_build.run import fleet as fleet_mod
from uros_build.run import freertos as freertos_mod
from uros_build.run import graph as graph_mod
from uros_build.run import machines as probe_mod
from uros_build.run import netns, peerenv
from uros_build.run import relay as relay_mod
from uros_build.run import stages as stages_mod
from uros_build.run.report import probe_base
from uros_build.sources.workspace import workspace_of_output

# Less is no run at all: 0 or less gave "the firmware did not finish" about a good library, 1e-9
# started QEMU for nothing (QEMU alone takes longer to open the firmware's link).
MIN_TIMEOUT = 1.0


def plan_probe(request: ProbeRequest) -> ProbePlan:
    """The request checked, and the output, the board and the kernel it names found."""
    check_timeout(request.timeout)
    check_instances(request)
    faults = relay_mod.parse_plan(request.link) if request.link is not None else None  # --link
    app, peer = request.app, request.peer
    if request.graph:  # the graph stage's peer is uros's own (run/graph.py)
        peer = check_graph(peer, app is not None, os.geteuid())
    check_freertos(request.freertos)
    duration_ms = app_mod.check_duration(app.duration) if app is not None else 0
    defines = app_mod.parse_defines(app.defines) if app is not None else ()
    if peer is not None:
        check_peer(peer, os.geteuid())
        peerenv.cache_root(resolve_outside(ROS2_VENV).value)  # a file there: refused before anything runs
    output, toolchain = request.output, request.toolchain
    finish_killed_swaps(output, request.workspace)
    out = resolve_output(output, request.workspace, toolchain).resolve()
    info = read_build_info(out, "OUTPUT")
    if output is not None and toolchain is not None:
        check_toolchain_matches(toolchain, folder_key(toolchain), out, info.target)
    ws = workspace_of_output(out, info.target)
    plan = None
    if app is not None:  # before anything is built: the app's interfaces must be in the library
        plan = app_mod.AppPlan(app_mod.scan_app(app.folder), defines, duration_ms)
        missing = app_mod.missing_packages(plan.app, info.packages)
        if missing:
            raise app_mod.missing_packages_error(plan.app, missing, out, ws.root if ws is not None else None)
    else:  # the probe firmware's own packages (it would fail in the compiler without them)
        stages_mod.check_packages(info.packages, out, info.target, ws.root if ws is not None else None)
    machine = probe_mod.machine_for(info.target, probe_mod.load_machines(), request.board)
    if request.instances > 1:  # many boards on one agent: the built-in probe's, on an Arm board
        fleet_mod.check_board(machine.board.arch, machine.machine)
    rtos = _freertos(info, request.freertos)
    return ProbePlan(out, info, machine, rtos, probe_base(out, info.target), plan, peer, faults)


def app_request(folder: Path | None, defines: tuple[str, ...], duration: float | None) -> AppRequest | None:
    """--app with its options; --define or --duration without --app is refused (the probe firmware
    takes neither)."""
    if folder is None:
        if defines or duration is not None:
            flag = "--duration" if duration is not None else "--define"
            raise ConfigError(f"{flag}: only with --app DIR", "give --app DIR, or drop it")
        return None
    return AppRequest(folder, defines, duration)


def check_instances(request: ProbeRequest) -> None:
    """--instances N and --client-keys (run/fleet.py); many boards run the built-in probe alone (no
    --app, --peer or --graph: one peer, one graph a run)."""
    fleet_mod.check_instances(request.instances)
    fleet_mod.check_keys(request.client_keys, request.instances)
    flags = (("--app", request.app), ("--peer", request.peer), ("--graph", request.graph))
    given = [flag for flag, on in flags if on]
    if request.instances > 1 and given:
        raise ConfigError(
            f"--instances {request.instances} with {given[0]}: many boards run the built-in probe alone",
            f"drop {given[0]} or --instances",
        )


def check_graph(peer: Path | None, app: bool, euid: int) -> Path:
    """--graph: the built-in probe, with uros's own peer (one peer a run), in a namespace (root)."""
    if peer is not None or app:
        flag = "--peer" if peer is not None else "--app"
        raise ConfigError(
            f"--graph with {flag}: the graph stage is the built-in probe's, with a peer of its own",
            f"drop --graph or {flag}",
        )
    netns.check_root(euid, "uros probe --graph")
    return graph_mod.script()


def check_peer(script: Path, euid: int) -> None:
    """--peer names a Python file, and uros can make the namespace it runs in (root)."""
    if not script.is_file():
        raise ConfigError(
            f"--peer {script}: no such file", "pass a Python script using rclpy (docs/probe.md)"
        )
    netns.check_root(euid, f"uros probe --peer {script}")


def _freertos(info: BuildInfo, given: str | None) -> freertos_mod.FreeRtos | None:
    """The FreeRTOS kernel the probe runs on (the library's, or --freertos), or None: bare metal."""
    env = resolve_outside(FREERTOS, None).value  # $UROS_FREERTOS: a gone kernel's stand-in only
    return freertos_mod.choose(info.target, info.rtos, given, env)


def check_timeout(timeout: float) -> None:
    """--timeout is a number of seconds, at least MIN_TIMEOUT."""
    if not (math.isfinite(timeout) and timeout >= MIN_TIMEOUT):
        raise ConfigError(
            f"--timeout {timeout:g}: must be a number of seconds, at least {MIN_TIMEOUT:g}",
            "e.g. --timeout 60 (the built-in probe's run takes 6-15 s)",
        )


def check_freertos(given: str | None) -> None:
    """--freertos names a folder: an empty one probed bare metal without a word."""
    if given is not None and not given.strip():
        raise ConfigError(
            f"--freertos {given!r}: names no FreeRTOS-Kernel folder",
            "give the kernel's checkout (--freertos PATH), or leave --freertos out to probe bare metal",
        )


def check_toolchain_matches(toolchain: str, key: str, out: Path, target: str) -> None:
    """OUTPUT names the output to probe; a --toolchain beside it that names another target
    contradicts it (it was ignored without a word)."""
    if key != target:
        raise ConfigError(
            f"--toolchain {toolchain}: OUTPUT {out} is the output of {target}, not {key}",
            "pass OUTPUT or --toolchain, not both",
        )
