"""`uros probe`: does a built libmicroros.a work at run time? Build the probe firmware against the
output's CMake package, boot it in QEMU when the target has a machine there, connect it over an
emulated UART to a real Micro XRCE-DDS Agent on the host, and report what the firmware saw.

output → QEMU machine (meta/probe/machines.yaml) → qemu-system-arm and the agent found → firmware
configured and built like a user's project → QEMU started (its link on a pseudo-terminal) → the
agent on that terminal → QEMU's exit status (the firmware's main()) → one line, the logs kept.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import sys
from collections.abc import Iterator
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from uros_build import console
from uros_build.config.outputs import finish_killed_swaps, resolve_output
from uros_build.config.resolver import resolve_outside
from uros_build.config.settings import AGENT, FREERTOS, FREERTOS_TCP, LWIP, ROS2_VENV
from uros_build.config.targets import folder_key
from uros_build.errors import ConfigError, MissingToolError, VerifyError
from uros_build.files import locked
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.proc import Runner, new_run_log
from uros_build.run import agentbuild, netns, peerenv
from uros_build.run import app as app_mod
from uros_build.run import freertos as freertos_mod
from uros_build.run import graph as graph_mod
from uros_build.run import machines as probe_mod
from uros_build.run import network as network_mod
from uros_build.run import stages as stages_mod
from uros_build.run.firmware import build_firmware
from uros_build.run.machines import qemu_hint
from uros_build.run.peer import peer_verdict
from uros_build.run.report import probe_base, probe_work, write_report
from uros_build.run.session import (
    PeerRun,
    SessionSpec,
    free_udp_port,
    middleware_for,
    run_owner,
    run_session,
    stop_left_running,
)
from uros_build.sources.packages import discover
from uros_build.sources.workspace import Workspace, workspace_of_output

_AGENT_HINT = (
    "run `uros agent build` once, or pass --agent PATH (or set UROS_AGENT) to a MicroXRCEAgent: eProsima "
    "Micro-XRCE-DDS-Agent v2.3.0 "
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


def _agent(given: str | None, runner: Runner) -> str:
    wanted = resolve_outside(AGENT, given or None).value  # --agent, else $UROS_AGENT
    if not wanted:  # else the agent `uros agent build` made
        built = agentbuild.current_agent(_agent_root())
        if built is None:
            raise MissingToolError("uros probe: no Micro XRCE-DDS Agent was given or built", _AGENT_HINT)
        console.info(f"agent: {built.describe()} (uros agent build)")
        return str(built.run)
    if os.sep in wanted and not (Path(wanted).is_file() and os.access(wanted, os.X_OK)):
        raise MissingToolError(f"--agent {wanted}: no such program", _AGENT_HINT)
    return runner.which(wanted, _AGENT_HINT)


def _agent_root() -> Path:
    return resolve_outside(ROS2_VENV).value.expanduser()


def probe(
    output: Path | None,
    workspace: Path | None,
    toolchain: str | None,
    agent: str | None,
    timeout: float,
    as_json: bool,
    verbose: bool = False,
    peer: Path | None = None,
    freertos: str | None = None,
    board: str | None = None,
    app: AppRequest | None = None,
    graph: bool = False,
) -> ProbeReport | app_mod.AppReport:
    check_timeout(timeout)
    if graph:  # the graph stage's peer is uros's own (run/graph.py)
        peer = check_graph(peer, app is not None, os.geteuid())
    check_freertos(freertos)
    duration_ms = app_mod.check_duration(app.duration) if app is not None else 0
    defines = app_mod.parse_defines(app.defines) if app is not None else ()
    if peer is not None:
        check_peer(peer, os.geteuid())
        peerenv.cache_root(resolve_outside(ROS2_VENV).value)  # a file there: refused before anything runs
    finish_killed_swaps(output, workspace)
    out = resolve_output(output, workspace, toolchain).resolve()
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
    machine = probe_mod.machine_for(info.target, probe_mod.load_machines(), board)
    rtos = _freertos(info, freertos)
    base = probe_base(out, info.target)
    # One probe of a target at a time: two at once shared the work folder (one deleted the other's
    # firmware and console log) and blamed a good library ("no agent answered", "an entity could not
    # be created"); the second waits, and says for whom.
    with _probe_lock(base, info.target):
        stop_left_running(_owner(base, info.target))
        if plan is not None:
            return _probe_app(plan, out, info, machine, base, (agent, timeout, as_json, verbose), peer, rtos)
        return _probe(out, info, machine, base, agent, timeout, as_json, verbose, peer, rtos, graph)


@dataclass(frozen=True)
class AppRequest:
    """--app DIR, its --define/-D macros and --duration."""

    folder: Path
    defines: tuple[str, ...] = ()
    duration: float | None = None


def app_request(folder: Path | None, defines: tuple[str, ...], duration: float | None) -> AppRequest | None:
    """--app with its options; --define or --duration without --app is refused (the probe firmware
    takes neither)."""
    if folder is None:
        if defines or duration is not None:
            flag = "--duration" if duration is not None else "--define"
            raise ConfigError(f"{flag}: only with --app DIR", "give --app DIR, or drop it")
        return None
    return AppRequest(folder, defines, duration)


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


def _peer_run(runner: Runner, script: Path, out: Path, info: BuildInfo, work: Path) -> PeerRun:
    """The peer's ROS 2 environment (run/peerenv.py), with the workspace's interface packages."""
    ws: Workspace | None = workspace_of_output(out, info.target)
    source = ws.source_dir if ws is not None else None
    own = None
    if ws is not None and ws.extra_dir.is_dir():
        own = [p.name for p in discover(ws.extra_dir)]
    root = resolve_outside(ROS2_VENV).value
    return peerenv.prepare(runner, script.resolve(), root, source, own, info.packages, work / "peer.log")


def _freertos(info: BuildInfo, given: str | None) -> freertos_mod.FreeRtos | None:
    """The FreeRTOS kernel the probe runs on (the library's, or --freertos), or None: bare metal."""
    env = resolve_outside(FREERTOS, None).value  # $UROS_FREERTOS: a gone kernel's stand-in only
    return freertos_mod.choose(info.target, info.rtos, given, env)


# Less is no run at all: 0 or less gave "the firmware did not finish" about a good library, 1e-9
# started QEMU for nothing (QEMU alone takes longer to open the firmware's link).
MIN_TIMEOUT = 1.0


def _network(
    info: BuildInfo, machine: probe_mod.Machine, rtos: freertos_mod.FreeRtos | None
) -> network_mod.Network | None:
    """The IP stack the probe runs over (the library's, run/network.py), or None: the serial link."""
    env, env_tcp = resolve_outside(LWIP, None).value, resolve_outside(FREERTOS_TCP, None).value
    return network_mod.choose(info.ip_stack, machine, rtos is not None, env, env_tcp)


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


@contextlib.contextmanager
def _probe_lock(base: Path, target: str) -> Iterator[None]:
    """The probe's lock of ``target`` (in the workspace's .uros/): a folder this user cannot write
    (a root-owned workspace) is one line naming the fix, not a PermissionError."""
    held = contextlib.ExitStack()
    try:
        held.enter_context(locked(base / "probe" / "locks" / target, target, command="uros probe"))
    except OSError as exc:
        if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS):
            raise
        raise _not_writable(exc, base) from None
    with held:
        yield


def _not_writable(exc: OSError, base: Path) -> ConfigError:
    where = Path(exc.filename) if exc.filename else base
    found = next((p for p in (where, *where.parents) if p.exists()), base)
    owner, me = found.stat().st_uid, os.geteuid()
    if owner == me:  # a read-only mount, or the folder's own mode
        return ConfigError(
            f"uros probe: cannot write {where} ({exc.strerror})",
            f"make {base} writable (chmod -R u+w {base}), or probe a copy of the workspace",
        )
    whose = "it belongs" if found == where else f"{found} belongs"
    return ConfigError(
        f"uros probe: cannot write {where} ({exc.strerror}): {whose} to {_user(owner)}, not {_user(me)}",
        f"run uros probe as {_user(owner)} (e.g. with sudo), or make the folder yours: "
        f"sudo chown -R $(id -un) {base}",
    )


def _user(uid: int) -> str:
    """root, or the uid (pwd, which names the others, is POSIX only: uros imports on Windows)."""
    return "root" if uid == 0 else f"uid {uid}"


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
    peer: Path | None,
    rtos: freertos_mod.FreeRtos | None,
    graph: bool = False,
) -> ProbeReport:
    work = probe_work(base, info.target, out)
    if machine.chosen:  # another board of the target keeps its own work folder (firmware, console, logs)
        work = work.with_name(f"{work.name}-{machine.board.name}")
    network = _network(info, machine, rtos)
    on = f" on FreeRTOS ({rtos.why})" if rtos else ""
    if network is not None:
        on += f" over UDP ({network.label} on the LAN9118)"
    title = f"uros probe: {out} ({info.target}) in QEMU {machine.machine}{on}"
    runner = _open_run(work, base, info.target, machine, title, verbose)
    if rtos is not None:
        console.info(f"FreeRTOS kernel {rtos.kernel}, port {rtos.port.relative_to(rtos.kernel)}, heap_4")
        mismatch = freertos_mod.config_differs(rtos)
        if mismatch:
            console.warn(mismatch)
    if network is not None:
        ours = network_mod.probe_config(network.stack)
        console.info(f"{network.label} {network.tree}, the probe's config ({ours})")
        mismatch = network_mod.config_differs(network)
        if mismatch:
            console.warn(mismatch)
    qemu_program = runner.which(machine.board.qemu, qemu_hint(machine.board.qemu))
    agent_program = _agent(agent, runner)
    peer_run = _peer_run(runner, peer, out, info, work) if peer is not None else None
    # the agent's DDS middleware: its CED one creates no XRCE requesters or repliers (the service
    # stage's rclc_service_init_default returned 1 with -m ced), so it runs in a namespace of its own;
    # that needs root: without, the CED middleware and no service stage (said so), not a refusal
    middleware = middleware_for(peer_run is not None, os.geteuid())
    # over UDP the agent's port is the firmware's to know: fixed in the run's own namespace, else free
    port = network_mod.NAMESPACE_PORT if middleware == "dds" else free_udp_port()
    elf = build_firmware(
        runner, probe_mod.firmware_sources(), work, out, "uros_probe", verbose, machine,
        defines=[*freertos_mod.cmake_defines(rtos), *network_mod.cmake_defines(network, port)],
        folders=[*freertos_mod.firmware_folders(rtos), *network_mod.firmware_folders(network)],
    )  # fmt: skip
    if middleware == "ced":
        console.info(
            "not root: the agent runs its CED middleware (no network namespace); " + stages_mod.CED_SERVICE
        )
    pcap = work / network_mod.PCAP if network is not None else None
    spec = SessionSpec(
        middleware=middleware, restart_agent=True, udp_port=port if network is not None else None, pcap=pcap
    )
    ran = run_session(
        runner, qemu_program, machine, elf, agent_program, work, timeout, peer=peer_run, spec=spec
    )
    status, seconds, text = ran.status, ran.seconds, ran.console
    console_log, agent_log = ran.console_log, ran.agent_log
    used = probe_mod.resources_used(text)
    limits = probe_mod.limits_held(text)
    stages = stages_mod.stages_of(ran.lines, ran.restarts, middleware)
    if graph and ran.peer_log is not None:  # uros's own peer: what it saw is a stage, not a verdict
        name = agentbuild.program_name(agent_program, agentbuild.current_agent(_agent_root()))
        stages = [*stages, graph_mod.stage(ran.peer_log.read_text(encoding="utf-8", errors="replace"), name)]
        peer_run = None
    failed = stages_mod.failed(stages)
    ok = stages_mod.passed(status, stages)
    verdict = stages_mod.failure_line(failed) if failed else probe_mod.verdict(0 if ok else status)
    if peer_run is not None:  # the judged verdict (every stage, not the exit status) and the peer's
        judged = peer_verdict(ok, verdict, ran.peer_status)
        ok, verdict = judged.passed, judged.text
    report = ProbeReport(
        target=info.target,
        machine=machine.machine,
        status=status,
        verdict=verdict,
        seconds=round(seconds, 2),
        heap_bytes=used[0] if used else None,
        stack_bytes=used[1] if used else None,
        limits={kind: limit for kind, (limit, _) in limits.items()},
        rtos="freertos" if rtos else None,
        stages={s.name: {"result": s.result, "detail": s.detail, "seconds": s.seconds} for s in stages},
        console_log=str(console_log),
        agent_log=str(agent_log),
        run_log=str(runner.log_path),
        peer_status=ran.peer_status,
        peer_log=str(ran.peer_log) if ran.peer_log else None,
        passed=ok,
        pcap=str(pcap) if pcap is not None else None,
    )
    # kept for `uros size`, which counts a passed run's heap and stack against a chip's RAM
    write_report(work, asdict(report), out / info.library.file)  # its bytes' sha256, not build-info's
    if peer_run is not None:
        return _peer_report(report, info.target, machine.machine, as_json)
    if as_json:
        sys.stdout.write(json.dumps(asdict(report), indent=2, sort_keys=True) + "\n")
    if not ok:
        raise VerifyError(
            f"uros probe {info.target} ({machine.machine}{on}): {report.verdict}",
            f"the firmware's console: {console_log}; the agent's log: {agent_log}",
        )
    memory = f"; heap {used[0]:,} B, stack {used[1]:,} B" if used else ""
    console.step(
        f"probe passed: {info.target} in QEMU {machine.machine}{on} talked to the agent: "
        f"{stages_mod.describe(stages) or 'every sample back'} ({seconds:.1f} s{memory})"
    )
    for skipped in (s for s in stages if s.result == "skip"):
        console.info(f"stage {skipped.name} skipped: {skipped.detail}")
    if rtos is not None:
        console.info(freertos_mod.describe_run(text))
    if pcap is not None:
        console.info(network_mod.describe_run(text, pcap))
    if limits:
        console.info(probe_mod.describe_limits(limits))
    return report


def _owner(base: Path, target: str) -> str:
    """What marks every process of a probe of ``target`` (run/session.run_owner)."""
    return run_owner(base / "probe" / "locks" / target)


def _open_run(
    work: Path, base: Path, target: str, machine: probe_mod.Machine, title: str, verbose: bool
) -> Runner:
    """The work folder, the run's log and its first lines; every process the run starts is marked
    as the probe's of ``target`` (stopped with the run, or by the next run if this one is killed)."""
    work.mkdir(parents=True, exist_ok=True)
    runner = Runner(new_run_log(work / "log", "probe", target), verbose=verbose, owner=_owner(base, target))
    console.step(title)
    if machine.note:
        console.info(f"{machine.machine}: {machine.note}")
    console.info(f"log: {runner.log_path}")
    return runner


def _probe_app(
    plan: app_mod.AppPlan,
    out: Path,
    info: BuildInfo,
    machine: probe_mod.Machine,
    base: Path,
    options: tuple[str | None, float, bool, bool],  # --agent, --timeout, --json, --verbose
    peer: Path | None,
    rtos: freertos_mod.FreeRtos | None,
) -> app_mod.AppReport:
    agent, timeout, as_json, verbose = options
    work = app_mod.app_work(base, info.target, out, plan.app.folder)
    if machine.chosen:  # another board of the target keeps its own work folder
        work = work.with_name(f"{work.name}-{machine.board.name}")
    on = f" on FreeRTOS ({rtos.why})" if rtos else ""
    shown = app_mod.shown(plan.app.folder)
    title = f"uros probe --app {shown}: {out} ({info.target}) in QEMU {machine.machine}{on}"
    if rtos is not None:  # the FreeRTOS firmware keeps its own work folder
        work = work.with_name(f"{work.name}-freertos")
    network = _network(info, machine, rtos)
    if network is not None:
        title += f" over UDP ({network.label} on the LAN9118)"
    runner = _open_run(work, base, info.target, machine, title, verbose)
    qemu_program = runner.which(machine.board.qemu, qemu_hint(machine.board.qemu))
    agent_program = _agent(agent, runner)
    peer_run = _peer_run(runner, peer, out, info, work) if peer is not None else None
    compiler = info.compiler.path if info.compiler is not None else None
    ran = app_mod.run_app(
        runner, plan, out, compiler, qemu_program, machine, agent_program, work, timeout, verbose, peer_run,
        rtos, network, info.cmake_options,
    )  # fmt: skip
    report = app_mod.app_report(info.target, machine.machine, plan, ran, runner, "freertos" if rtos else None)
    if peer_run is not None:  # the app's verdict and the peer's together
        judged = peer_verdict(report.passed, report.verdict, ran.session.peer_status)
        report = replace(report, passed=judged.passed, verdict=judged.text)
    if as_json:
        sys.stdout.write(json.dumps(asdict(report), indent=2, sort_keys=True) + "\n")
    line = app_mod.describe(report)
    logs = f"its console: {report.console_log}; the agent's log: {report.agent_log}"
    if report.peer_log:
        logs += f"; the peer's log: {report.peer_log}"
    if not report.passed:
        raise VerifyError(line, logs)
    # with a peer, both logs are named in the line (the two halves of the verdict)
    console.step(
        f"{line}; the console: {report.console_log}; the peer's log: {report.peer_log}"
        if report.peer_log
        else line
    )
    return report


def _peer_report(report: ProbeReport, target: str, machine: str, as_json: bool) -> ProbeReport:
    """The run's verdict with a peer (already judged: report.passed); both logs named in the line."""
    if as_json:
        sys.stdout.write(json.dumps(asdict(report), indent=2, sort_keys=True) + "\n")
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
