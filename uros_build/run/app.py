"""`uros probe --app DIR`: a user's micro-ROS application run unchanged on the probe's board.

DIR holds C files written against rclc with micro_ros_setup's entry point, ``void appMain(void *arg)``
(its freertos_apps and zephyr_apps run apps that way, so existing apps need no change). The board
(templates/probe/: start-up, clock, heap, the serial link; app_main.c the runner) sets the custom
serial transport, makes its heap rcl's default allocator, waits for the agent and calls appMain. The
app ends the run with ``exit(status)`` (QEMU's exit status through semihosting), or the board ends it
``--duration`` seconds after appMain started.

DIR → its interface packages (its ``#include <pkg/msg|srv|action/...>``) checked against the
library's packages before anything is built → the firmware's CMakeLists rendered (every value
escaped) → built against the output like the probe → its size (the target's ``size``, LC_ALL=C) →
the QEMU + agent session → one verdict. The pure parts are the scan, the checks, the CMake text and
the verdicts; :func:`run_app` runs them.
"""

from __future__ import annotations

import math
import os
import re
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, resources, templating
from uros_build.colcon.fingerprint import digest
from uros_build.errors import ConfigError, StepFailed
from uros_build.output.sizes import Sizes, parse_berkeley
from uros_build.proc import Runner
from uros_build.run import freertos as freertos_mod
from uros_build.run import machines
from uros_build.run import network as network_mod
from uros_build.run.firmware import build_firmware
from uros_build.run.session import PeerRun, Session, SessionSpec, free_udp_port, middleware_for, run_session
from uros_build.target.toolsearch import bintools_beside

# app_main.c's and the board's own exit statuses (70, 71: run/machines.VERDICTS); an app's own should
# stay below 64.
CRASHED, NO_AGENT, RETURNED, DURATION_OVER = 70, 81, 82, 83
RUNNER_STATUSES: Mapping[int, str] = {
    CRASHED: "the app crashed (hard fault)",
    **{status: machines.VERDICTS[status] for status in (71, 72, 73, 74)},  # the ARMv6-M check, FreeRTOS's
    NO_AGENT: "no agent answered before appMain (is it running on the link? a library without the custom "
    "serial transport or stream framing never reaches it)",
    RETURNED: "appMain returned without exit(status): end the app with exit(0) when its job is done, or "
    "run it with --duration",
}
# How long uros waits for a --duration run before it stops QEMU itself: the runner's wait for the
# agent (20 s) and QEMU's start, and the board's clock running slow: it counts SysTick interrupts, and
# QEMU drops those a loaded host cannot deliver in time (--duration 3 took 12 s of wall time at load
# 13 on 2 cores), so the duration counts DURATION_SLOWDOWN times over.
DURATION_GRACE = 25.0
DURATION_SLOWDOWN = 4

_INCLUDE = re.compile(
    r'^[ \t]*#[ \t]*include[ \t]*[<"](?P<package>[A-Za-z][A-Za-z0-9_]*)/(?P<kind>msg|srv|action)/'
    r'(?P<rest>[A-Za-z0-9_./]+\.h)[>"]',
    re.MULTILINE,
)
_APP_MAIN = re.compile(r"^[ \t]*void[ \t\n]+appMain[ \t\n]*\([^;)]*\)[ \t\n]*\{", re.MULTILINE)
_DEFINE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_APP_HINT = "a folder of C files, one of which defines void appMain(void *arg) (micro_ros_setup's apps)"


@dataclass(frozen=True)
class AppSources:
    """An application folder: its C files and the interface packages they include."""

    folder: Path
    sources: tuple[Path, ...]  # DIR/*.c, sorted
    packages: Mapping[str, str]  # interface package -> where it is first included ("app.c:3")


@dataclass(frozen=True)
class AppPlan:
    """What `uros probe --app` runs: the app, its -D macros, --duration in ms (0: none)."""

    app: AppSources
    defines: tuple[str, ...]
    duration_ms: int


def app_work(base: Path, target: str, out: Path, folder: Path) -> Path:
    """The work folder of an app's runs against output ``out`` (beside the probe's, run/report.py)."""
    return base / "probe" / f"app-{target}-{digest(f'{out}|{folder}')[:10]}"


def interface_includes(text: str) -> list[tuple[str, int]]:
    """(package, line) of every ``#include <pkg/msg|srv|action/...h>`` in C text, in order."""
    return [(m.group("package"), text.count("\n", 0, m.start()) + 1) for m in _INCLUDE.finditer(text)]


def scan_app(folder: Path) -> AppSources:
    """DIR's C files and interface packages (pure: reads DIR's *.c and *.h, not its subfolders)."""
    if not folder.is_dir():
        raise ConfigError(f"--app {folder}: no such folder", f"give {_APP_HINT}")
    sources = tuple(sorted(p for p in folder.glob("*.c") if p.is_file()))
    if not sources:
        raise ConfigError(f"--app {folder}: holds no .c file", f"give {_APP_HINT}")
    texts = {p: p.read_text(encoding="utf-8", errors="replace") for p in sources}
    if not any(_APP_MAIN.search(text) for text in texts.values()):
        names = ", ".join(p.name for p in sources)
        raise ConfigError(
            f"--app {folder}: no C file defines void appMain(void *arg) ({names})",
            "the board calls appMain once the agent answers, as micro_ros_setup's freertos_apps do",
        )
    headers = sorted(p for p in folder.glob("*.h") if p.is_file())
    for header in headers:
        texts[header] = header.read_text(encoding="utf-8", errors="replace")
    packages: dict[str, str] = {}
    for path, text in texts.items():
        for package, line in interface_includes(text):
            packages.setdefault(package, f"{path.name}:{line}")
    return AppSources(folder, sources, dict(sorted(packages.items())))


def missing_packages(app: AppSources, library_packages: Iterable[str]) -> list[str]:
    have = set(library_packages)
    return [p for p in app.packages if p not in have]


def missing_packages_error(
    app: AppSources, missing: Sequence[str], out: Path, workspace: Path | None
) -> ConfigError:
    """One line: which packages the app includes that the library lacks, and the fix."""
    where = ", ".join(f"{p} ({app.packages[p]})" for p in missing)
    wanted = " ".join(app.packages)
    ws = f" -w {workspace}" if workspace is not None else ""
    return ConfigError(
        f"--app {app.folder}: the library {out} lacks {where}",
        f"add the interface package to the workspace (`uros add-package{ws} PATH|URL`, or `uros interface "
        f"new`), then build it in: `uros build{ws} --packages {wanted}`",
    )


def parse_defines(defines: Iterable[str]) -> tuple[str, ...]:
    """-D NAME or -D NAME=VALUE, as for a C compiler; NAME must be a C identifier."""
    out = []
    for define in defines:
        name = define.split("=", 1)[0]
        if not _DEFINE.fullmatch(name):
            raise ConfigError(
                f"--define {define!r}: {name!r} is not a C macro name",
                "e.g. -D HSB_STATE_PERIOD_MS=200 or -D HSB_LOOPBACK",
            )
        templating.cmake_quote(define)  # a control character is refused here, in one line
        out.append(define)
    return tuple(out)


def check_duration(duration: float | None) -> int:
    """--duration in whole milliseconds (0: none)."""
    if duration is None:
        return 0
    if not (math.isfinite(duration) and 0 < duration <= 86400):
        raise ConfigError(
            f"--duration {duration:g}: must be a number of seconds more than 0 (at most a day)",
            "e.g. --duration 10",
        )
    return max(1, round(duration * 1000))


def session_timeout(timeout: float, duration_ms: int) -> float:
    """How long uros lets QEMU run: --timeout, or with --duration that and the runner's start-up."""
    return timeout if duration_ms == 0 else DURATION_SLOWDOWN * duration_ms / 1000 + DURATION_GRACE


def app_cmake(app: AppSources, defines: Sequence[str], duration_ms: int) -> str:
    """The app firmware's CMakeLists.txt (paths and defines escaped as quoted arguments)."""
    for path in (app.folder, *app.sources):
        bad = templating.cmake_unusable(str(path))
        if bad is not None:
            raise ConfigError(
                f"--app {app.folder}: CMake cannot use a path containing {bad!r} ({path})",
                "copy the app to a folder whose path has no '\"', '\\', ';', '${' or '$('",
            )
    return templating.render(
        "probe-app.cmake.j2",
        app_dir=str(app.folder),
        sources=[str(p) for p in app.sources],
        defines=list(defines),
        duration_define=f"UROS_APP_DURATION_MS={duration_ms}",
    )


def verdict(status: int | None, duration_ms: int) -> tuple[bool, str]:
    """(passed, what QEMU's exit status says about the app)."""
    if status is None:
        if duration_ms:
            return False, "timeout: the board did not end the run at --duration (the app stopped its clock?)"
        return False, "timeout: the app neither exited nor crashed within --timeout"
    if status == DURATION_OVER and duration_ms:
        return True, (
            f"ran for the whole --duration ({duration_ms / 1000:g} s) without exiting or crashing (that it "
            "stayed up, not that it did its job: its console, or a ROS 2 peer, says that)"
        )
    if status in RUNNER_STATUSES:
        return False, RUNNER_STATUSES[status]
    if status == 0:
        return True, "exit(0)"
    return False, f"the app exited with {status}"


def elf_sizes(size_output: str) -> Sizes:
    """text/data/bss of one ELF from ``size`` (Berkeley format)."""
    found = list(parse_berkeley(size_output).values())
    if len(found) != 1:
        raise StepFailed("size of the app firmware: no text/data/bss line", size_output.strip()[:200] or None)
    return found[0]


@dataclass(frozen=True)
class AppRun:
    elf: Path
    sizes: Sizes
    session: Session
    heap_bytes: int | None
    stack_bytes: int | None


def run_app(
    runner: Runner,
    plan: AppPlan,
    out: Path,
    compiler_path: str | None,
    qemu_program: str,
    machine: machines.Machine,
    agent_program: str,
    work: Path,
    timeout: float,
    verbose: bool,
    peer: PeerRun | None = None,
    rtos: freertos_mod.FreeRtos | None = None,
    network: network_mod.Network | None = None,
    cmake_options: Mapping[str, Mapping[str, str]] | None = None,
) -> AppRun:
    """Build the app firmware against ``out``, measure it, run it against the agent (``network``:
    over UDP through lwIP, docs/network.md)."""
    app, defines, duration_ms = plan.app, plan.defines, plan.duration_ms
    staged = work / "app-src"
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(resources.templates_dir() / "probe", staged)
    (staged / "CMakeLists.txt").write_text(app_cmake(app, defines, duration_ms), encoding="utf-8")
    middleware = middleware_for(peer is not None, os.geteuid())
    port = network_mod.NAMESPACE_PORT if middleware == "dds" else free_udp_port()
    elf = build_firmware(
        runner, staged, work, out, "uros_app", verbose, machine,
        defines=[*freertos_mod.cmake_defines(rtos), *network_mod.cmake_defines(network, port)],
        folders=[*freertos_mod.firmware_folders(rtos), *network_mod.firmware_folders(network)],
    )  # fmt: skip
    size = runner.query([bintools_beside(compiler_path).size, str(elf)], step="size of the app firmware")
    sizes = elf_sizes(size)
    wait = session_timeout(timeout, duration_ms)
    # without root (no namespace to run DDS in) the agent's CED middleware, as for the built-in probe:
    # an app's topics need no DDS, its services do (said so)
    pcap = work / network_mod.PCAP if network is not None else None
    note = network_mod.default_address_note(cmake_options or {}, port) if network is not None else None
    if note:
        console.info(note)
    spec = SessionSpec(middleware=middleware, udp_port=port if network is not None else None, pcap=pcap)
    if spec.middleware == "ced":
        console.info(
            "not root: the agent runs its CED middleware (no network namespace): services cannot be created"
        )
    ran = run_session(runner, qemu_program, machine, elf, agent_program, work, wait, peer=peer, spec=spec)
    used = machines.resources_used(ran.console)
    return AppRun(elf, sizes, ran, used[0] if used else None, used[1] if used else None)


@dataclass(frozen=True)
class AppReport:
    """`uros probe --app`'s result (--json): what ran, its verdict, and what it costs."""

    target: str
    machine: str
    app: str
    sources: tuple[str, ...]
    rtos: str | None  # "freertos": appMain ran in a FreeRTOS task; None: bare metal
    packages: tuple[str, ...]  # the interface packages it includes
    defines: tuple[str, ...]
    duration: float | None  # --duration in seconds
    status: int | None  # QEMU's exit status (the app's, or the runner's 70-73); None: stopped by uros
    passed: bool
    verdict: str
    seconds: float
    flash_bytes: int  # text + data
    ram_bytes: int  # data + bss (static)
    size: Mapping[str, int]  # text/data/bss
    heap_bytes: int | None
    stack_bytes: int | None
    elf: str
    console_log: str
    agent_log: str
    run_log: str
    peer_status: int | None = None  # --peer: its exit status (None: none ran, or it did not finish)
    peer_log: str | None = None


def app_report(
    target: str, machine: str, plan: AppPlan, ran: AppRun, runner: Runner, rtos: str | None = None
) -> AppReport:
    app, duration_ms = plan.app, plan.duration_ms
    passed, said = verdict(ran.session.status, duration_ms)
    return AppReport(
        target=target,
        machine=machine,
        app=str(app.folder),
        sources=tuple(p.name for p in app.sources),
        rtos=rtos,
        packages=tuple(app.packages),
        defines=plan.defines,
        duration=duration_ms / 1000 if duration_ms else None,
        status=ran.session.status,
        passed=passed,
        verdict=said,
        seconds=round(ran.session.seconds, 2),
        flash_bytes=ran.sizes.text + ran.sizes.data,
        ram_bytes=ran.sizes.data + ran.sizes.bss,
        size=ran.sizes.as_dict(),
        heap_bytes=ran.heap_bytes,
        stack_bytes=ran.stack_bytes,
        elf=str(ran.elf),
        console_log=str(ran.session.console_log),
        agent_log=str(ran.session.agent_log),
        run_log=str(runner.log_path),
        peer_status=ran.session.peer_status,
        peer_log=str(ran.session.peer_log) if ran.session.peer_log else None,
    )


def describe(report: AppReport) -> str:
    """The one-line verdict: what happened, in how long, and what the app costs."""
    memory = f"flash {report.flash_bytes:,} B, RAM {report.ram_bytes:,} B static"
    if report.heap_bytes is not None and report.stack_bytes is not None:
        memory += f", heap {report.heap_bytes:,} B, stack {report.stack_bytes:,} B"
    head = "app passed" if report.passed else "app failed"
    on = " on FreeRTOS" if report.rtos else ""
    return (
        f"{head}: {report.app} on {report.target} in QEMU {report.machine}{on}: {report.verdict} "
        f"({report.seconds:.1f} s; {memory})"
    )
