"""`uros probe --app`'s run judged: the runner's end line, QEMU's exit status, the verdict, and the
report's record (`AppReport`, filled by uros_build/probesteps/report.py) with its one line.

What the app cannot forge: the verdict comes from the runner's end line (templates/probe/app_main.c),
marked with a random nonce made for each run and compiled into the runner alone (run/app.py builds
it), which carries the app's whole exit status and the board's heap and stack figures, and from
QEMU's exit status, which the runner chooses and which must agree with that line
(:func:`expected_code`); `--duration` passes only when uros's own clock saw that long since appMain
started. Everything here is pure.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from uros_build import templating
from uros_build.run import machines
from uros_build.run.stages import ConsoleLine

# QEMU's exit statuses the runner chooses (app_main.c's probe_exit_status): the app's own 0-63 as
# they are, any other OUT_OF_RANGE (its end line has it whole); the runner's and the board's 70 and up.
OUT_OF_RANGE, CRASHED, NO_AGENT, RETURNED, DURATION_OVER, NO_HEAP, ENDED_TWICE = 64, 70, 81, 82, 83, 84, 126
RUNNER_STATUSES: Mapping[int, str] = {
    CRASHED: "the app crashed (hard fault)",
    **{status: machines.VERDICTS[status] for status in (71, 72, 73, 74)},  # the ARMv6-M check, FreeRTOS's
    NO_AGENT: "no agent answered before appMain (is it running on the link? a library without the custom "
    "serial transport or stream framing never reaches it)",
    RETURNED: "appMain returned without exit(status): end the app with exit(0) when its job is done, or "
    "run it with --duration",
    NO_HEAP: "the board's heap could not become rcl's default allocator",
}
# The end line's kinds (app_main.c): who ended the run
_RUNNER_KINDS: Mapping[str, int] = {"no-agent": NO_AGENT, "returned": RETURNED, "duration": DURATION_OVER}
# How much later than the board uros's own clock may see the end of a --duration run: the console is
# read every 10 ms, and QEMU writes a line some ms after the firmware did
DURATION_SLACK = 0.5


@dataclass(frozen=True)
class RunEnd:
    """The runner's end line: who ended the run, with what status (the app's whole int), the board's
    figures, and when uros saw it."""

    kind: str  # exit (the app's), fault, board, no-agent, returned, duration
    status: int
    heap_bytes: int
    stack_bytes: int
    seen: float


def _end_line(nonce: str) -> re.Pattern[str]:
    return re.compile(
        rf"^uros-probe-{nonce}: end (exit|fault|board|no-agent|returned|duration) (-?\d{{1,11}}) "
        rf"heap (\d{{1,10}}) B stack (\d{{1,10}}) B$"
    )


def run_end(lines: Sequence[ConsoleLine], nonce: str) -> RunEnd | None:
    """The runner's end line among the console's (pure); more than one (a fault while it was
    written, or a console the app wrote into) is none: the run did not end cleanly."""
    pattern = _end_line(nonce)
    found = [(m, line.seen) for line in lines if (m := pattern.match(line.text.strip()))]
    if len(found) != 1:
        return None
    m, seen = found[0]
    return RunEnd(m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(4)), seen)


def app_started(lines: Sequence[ConsoleLine], nonce: str) -> float | None:
    """When uros saw the runner call appMain (pure)."""
    start = f"uros-probe-{nonce}: start"
    return next((line.seen for line in lines if line.text.strip() == start), None)


def expected_code(end: RunEnd) -> int:
    """QEMU's exit status the runner chooses for its end line (app_main.c's probe_exit_status)."""
    if end.kind == "exit":
        return end.status if 0 <= end.status <= 63 else OUT_OF_RANGE
    if end.kind == "fault":
        return CRASHED
    if end.kind == "board":
        return end.status if 64 < end.status < 128 else 127
    return _RUNNER_KINDS[end.kind]


def verdict(
    status: int | None, end: RunEnd | None, duration_ms: int, started: float | None = None
) -> tuple[bool, str]:
    """(passed, what the run says about the app): QEMU's exit status, the runner's end line (None:
    it did not come) and, for --duration, when uros saw appMain start (host time)."""
    if status is None:
        if duration_ms:
            return False, "timeout: the board did not end the run at --duration (the app stopped its clock?)"
        return False, "timeout: the app neither exited nor crashed within --timeout"
    if end is None:
        return False, (
            f"the run ended (QEMU's exit status {status}) without the runner's end line: the app left "
            "outside the board's exit path (a semihosting call of its own?), or wrote over its console"
        )
    if status != expected_code(end):
        return False, (
            f"QEMU's exit status {status} is not the one the runner chose for its end line ({end.kind} "
            f"{end.status}): something else ended the run"
        )
    if end.kind == "duration":
        if not duration_ms:
            return False, "the board ended the run at a --duration that was not asked for"
        ran = end.seen - started if started is not None else None
        if ran is None or ran + DURATION_SLACK < duration_ms / 1000:
            seen = f"{ran:.1f} s" if ran is not None else "no start of appMain"
            return False, (
                f"the board said --duration ({duration_ms / 1000:g} s) was over, but uros's clock saw "
                f"{seen}: the board's clock was tampered with"
            )
        return True, (
            f"ran for the whole --duration ({duration_ms / 1000:g} s) without exiting or crashing (that it "
            "stayed up, not that it did its job: its console, or a ROS 2 peer, says that)"
        )
    if end.kind == "exit":
        if end.status == 0:
            return True, "exit(0)"
        return False, f"the app exited with {end.status}"
    code = expected_code(end)
    return False, RUNNER_STATUSES.get(code, f"the board ended the run with {end.status}")


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
    status: int | None  # QEMU's exit status, as the runner chose it; None: stopped by uros
    exit_status: int | None  # the app's exit(status), whole, from the runner's end line (None: no exit)
    ended_by: str | None  # the end line's kind: exit, duration, fault, board, no-agent, returned; None: none
    passed: bool
    verdict: str
    seconds: float
    flash_bytes: int  # text + data
    ram_bytes: int  # data + bss (static)
    size: Mapping[str, int]  # text/data/bss
    heap_bytes: int | None  # the board's figures, from the runner's end line
    stack_bytes: int | None
    elf: str
    console_log: str
    agent_log: str
    run_log: str
    peer_status: int | None = None  # --peer: its exit status (None: none ran, or it did not finish)
    peer_log: str | None = None


def describe(report: AppReport) -> str:
    """The one-line verdict: what happened, in how long, and what the app costs."""
    memory = f"flash {report.flash_bytes:,} B, RAM {report.ram_bytes:,} B static"
    if report.heap_bytes is not None and report.stack_bytes is not None:
        memory += f", heap {report.heap_bytes:,} B, stack {report.stack_bytes:,} B"
    head = "app passed" if report.passed else "app failed"
    on = " on FreeRTOS" if report.rtos else ""
    return (
        f"{head}: {templating.cmake_comment(report.app)} on {report.target} in QEMU {report.machine}{on}: "
        f"{report.verdict} ({report.seconds:.1f} s; {memory})"
    )
