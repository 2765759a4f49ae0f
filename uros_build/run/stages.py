"""The probe firmware's stages, read from its console (pure). Every stage prints one line,

    uros-probe: stage <name> pass|fail|skip <detail>

(templates/probe/stages.h; an app or another firmware reuses the same form), and uros adds what only
the host can judge: the time stage's epoch against the host's clock at the moment its line appeared
(`ConsoleLine.seen`, read every run/session.WATCH_SECONDS), and for the restart stage the host's
time from the agent's restart to the node publishing again."""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from uros_build.errors import ConfigError

RESULTS = ("pass", "fail", "skip")
# The packages the probe firmware includes (templates/probe/*.c: rcl/, rclc/, rcutils/, rmw_microros/,
# uxr/, std_msgs/); example_interfaces is the service stage's, which says `skip` without it.
PACKAGES = ("microxrcedds_client", "rcl", "rclc", "rcutils", "rmw_microxrcedds", "std_msgs")
SERVICE_STATUS = 7  # templates/probe/stages.h PROBE_SERVICE
CED_SERVICE = (
    "the agent's CED middleware makes no XRCE repliers: the service stage needs its DDS middleware, which "
    "uros runs only as root, in a network namespace of its own"
)
TIME_LIMIT = 1.0  # seconds the firmware's epoch may be off the host's (issue 31)
RESTART_ASKED = "uros-probe: restart the agent"  # templates/probe/stage_restart.c
_STAGE = re.compile(r"^uros-probe: stage ([a-z][a-z0-9_-]*) (pass|fail|skip)\b ?(.*)$")
_EPOCH = re.compile(r"\bepoch (\d+)\.(\d{3}) s\b")
_BEST_EFFORT = re.compile(r"\bpublished (\d+), counted (\d+) back\b")


@dataclass(frozen=True)
class ConsoleLine:
    seen: float  # host time (time.time(), epoch seconds) the whole line was first read
    text: str


@dataclass(frozen=True)
class Stage:
    name: str
    result: str  # pass, fail or skip
    detail: str
    seconds: float | None = None  # time: the epoch's offset from the host; restart: seconds to reconnect


def parse(lines: Iterable[ConsoleLine]) -> list[Stage]:
    """The stages in the order they reported; a stage that reported twice counts its first line."""
    out: dict[str, Stage] = {}
    for line in lines:
        found = _STAGE.match(line.text.strip())
        if found and found[1] not in out:
            out[found[1]] = Stage(found[1], found[2], found[3].strip())
    return list(out.values())


def seen_at(lines: Iterable[ConsoleLine], name: str) -> float | None:
    """When the host first read the line of stage `name`."""
    return next((x.seen for x in lines if (m := _STAGE.match(x.text.strip())) and m[1] == name), None)


def judge_time(stage: Stage, seen: float | None) -> Stage:
    """A passed time stage passes only if its epoch is within TIME_LIMIT of the host's clock when its
    line appeared."""
    epoch = _EPOCH.search(stage.detail)
    if stage.result != "pass" or seen is None:
        return stage
    if epoch is None:
        return replace(stage, result="fail", detail=f"{stage.detail}: no epoch in the line")
    offset = round(int(epoch[1]) + int(epoch[2]) / 1000 - seen, 3)
    if abs(offset) > TIME_LIMIT:
        return replace(
            stage,
            result="fail",
            seconds=offset,
            detail=f"the firmware's epoch is {offset:+.3f} s off the host's clock (more than "
            f"{TIME_LIMIT:g} s): {stage.detail}",
        )
    return replace(stage, seconds=offset, detail=f"{stage.detail}, {offset:+.3f} s off the host's clock")


def judge_restart(stage: Stage, seen: float | None, restarts: Sequence[tuple[float, float]]) -> Stage:
    """The host's figure for a passed restart: from starting the agent again to the stage's line."""
    if stage.result != "pass" or seen is None or not restarts:
        return stage
    seconds = round(seen - restarts[0][1], 2)
    return replace(
        stage, seconds=seconds, detail=f"{stage.detail}; {seconds:.2f} s from the agent's restart (host)"
    )


def _way(link: Mapping[str, object], name: str) -> Mapping[str, object]:
    way = link.get(name)
    return way if isinstance(way, dict) else {}


def _count(way: Mapping[str, object], key: str) -> int:
    value = way.get(key, 0)
    return value if isinstance(value, int) else 0


def _lost(passed: int, sent: int) -> float:
    return round(1 - min(passed, sent) / sent, 3) if sent else 1.0


def best_effort_figures(link: Mapping[str, object]) -> dict[str, int | float]:
    """The best-effort samples as the relay counted them (run/relay.py Traffic): what the board
    sent, what reached the agent, what the agent sent back, what reached the board, and the share
    lost on the way there, on the way back (the link's) and end to end (the agent's too)."""
    up, down = _way(link, "board_to_agent"), _way(link, "agent_to_board")
    sent, back = _count(up, "best_effort"), _count(down, "best_effort")
    reached_agent, reached_board = _count(up, "best_effort_passed"), _count(down, "best_effort_passed")
    return {
        "board_sent": sent,
        "reached_agent": reached_agent,
        "agent_sent": back,
        "reached_board": reached_board,
        "loss_to_agent": _lost(reached_agent, sent),
        "loss_to_board": _lost(reached_board, back),
        "loss": _lost(reached_board, sent),
    }


def judge_best_effort(stage: Stage, link: Mapping[str, object] | None) -> Stage:
    """The best-effort stage's verdict and figures are the relay's counts: the firmware's line says
    what it published and counted back, and it may not count more than the relay delivered."""
    if stage.result != "pass" or link is None:
        return stage
    said = _BEST_EFFORT.search(stage.detail)
    if said is None:
        return replace(stage, result="fail", detail=f"{stage.detail}: no counts in the line")
    published, counted = int(said[1]), int(said[2])
    f = best_effort_figures(link)
    sent, reached_board = int(f["board_sent"]), int(f["reached_board"])
    figures = (
        f"the board sent {sent} best-effort samples, {f['reached_agent']} reached the agent "
        f"({f['loss_to_agent']:.0%} lost), the agent sent {f['agent_sent']} back, {reached_board} reached "
        f"the board ({f['loss_to_board']:.0%} lost): {f['loss']:.0%} lost end to end (the relay's counts; "
        f"the firmware said published {published}, counted {counted})"
    )
    if sent == 0:
        return replace(stage, result="fail", detail=f"the relay saw no best-effort sample: {figures}")
    if reached_board == 0:
        return replace(stage, result="fail", detail=f"no best-effort sample came back: {figures}")
    if counted > reached_board:
        return replace(
            stage,
            result="fail",
            detail=f"the firmware counted {counted} back, more than the relay delivered: {figures}",
        )
    return replace(stage, detail=figures)


def judge_time_link(stage: Stage, link: Mapping[str, object] | None) -> Stage:
    """The time requests the relay saw (every one of the run: the stage's are the only ones)."""
    if link is None:
        return stage
    asked = _count(_way(link, "board_to_agent"), "time")
    answered = _count(_way(link, "agent_to_board"), "time_passed")
    return replace(
        stage, detail=f"{stage.detail}; the link: {asked} time requests, {answered} answers reached the board"
    )


def sessions_opened(link: Mapping[str, object], since: float, until: float) -> list[str]:
    """The sessions the board opened from ``since`` to ``until`` (host times), as the relay saw them:
    a session is CREATE_CLIENT requests and the first STATUS_AGENT answer that reached the board;
    requests sent again before an answer came are retries of the same session, a request after an
    answer opens another. Each session by the client key of its first request."""
    found = link.get("sessions")
    opened: list[str] = []
    answered = True  # before the first request: nothing open
    for item in found if isinstance(found, list) else []:
        seen = item.get("seen") if isinstance(item, dict) else None
        if not isinstance(seen, float | int) or not since < seen <= until:
            continue
        if item.get("event") == "create" and answered:
            opened.append(str(item.get("client_key")))
            answered = False
        elif item.get("event") == "answered" and opened:
            answered = True
    return opened


def judge_flapping(stage: Stage, lines: Sequence[ConsoleLine], link: Mapping[str, object] | None) -> Stage:
    """The reconnect loop does not flap: one agent restart, one new session. Flapping, measured by
    the relay: the board opened more than one session from asking for the restart to the stage's
    line (a CREATE_CLIENT after an answer reached it); one sent again before an answer is a retry.
    (A later stage may open its own: FreeRTOS's two_tasks does.)"""
    asked = next((x.seen for x in lines if x.text.strip() == RESTART_ASKED), None)
    done = seen_at(lines, "restart")
    if stage.result != "pass" or link is None or asked is None or done is None:
        return stage
    keys = sessions_opened(link, asked, done)
    if len(keys) == 1:
        return replace(stage, detail=f"{stage.detail}; one session after the restart (the relay's count)")
    what = f"{len(keys)} sessions after one agent restart (client keys {', '.join(keys) or 'none'})"
    said = f"the reconnect flapped: the board opened {what}, the relay's count"
    return replace(stage, result="fail", detail=f"{said}: {stage.detail}")


def stages_of(
    lines: Sequence[ConsoleLine],
    restarts: Sequence[tuple[float, float]] = (),
    middleware: str = "dds",
    link: Mapping[str, object] | None = None,
) -> list[Stage]:
    """The console's stages with the host's judgement added. With the agent's CED middleware (uros
    without root) a failed service stage is the agent's doing, not the library's: skip, and why.
    ``link``: the relay's counts (--link), which judge the best-effort stage and the restart's
    flapping, and add the time requests it saw."""
    out = []
    for stage in parse(lines):
        if stage.name == "service" and stage.result == "fail" and middleware == "ced":
            stage = replace(stage, result="skip", detail=CED_SERVICE)
        elif stage.name == "time":
            stage = judge_time_link(judge_time(stage, seen_at(lines, "time")), link)
        elif stage.name == "restart":
            stage = judge_flapping(judge_restart(stage, seen_at(lines, "restart"), restarts), lines, link)
        elif stage.name == "best_effort":
            stage = judge_best_effort(stage, link)
        out.append(stage)
    return out


def failed(stages: Iterable[Stage]) -> Stage | None:
    return next((s for s in stages if s.result == "fail"), None)


def passed(status: int | None, stages: Sequence[Stage]) -> bool:
    """Whether the run passed: exit status 0 and no failed stage, or the service stage's status when
    uros skipped that stage (stages_of) and nothing else failed (the stages before it passed, or the
    firmware's first failure would be theirs; those after it report their own lines)."""
    if failed(stages) is not None:
        return False
    skipped = any(s.name == "service" and s.detail == CED_SERVICE for s in stages)
    return status == 0 or (status == SERVICE_STATUS and skipped)


def describe(stages: Iterable[Stage]) -> str:
    """`session pass, ..., service skip, time pass (+0.041 s), restart pass (1.21 s)`."""
    parts = []
    for s in stages:
        extra = ""
        if s.seconds is not None and s.result == "pass":
            extra = f" ({s.seconds:+.3f} s)" if s.name == "time" else f" ({s.seconds:.2f} s)"
        parts.append(f"{s.name} {s.result}{extra}")
    return ", ".join(parts)


def failure_line(stage: Stage) -> str:
    return f"stage {stage.name} failed: {stage.detail}"


def check_packages(library: Iterable[str], out: Path, target: str, workspace: Path | None) -> None:
    """The library holds what the probe firmware includes (build-info.json's packages), before
    anything is built: without them it failed in the compiler (`rcl/rcl.h: No such file`)."""
    have = set(library)
    missing = [p for p in PACKAGES if p not in have]
    if not missing:
        return
    ws = f" -w {workspace}" if workspace is not None else ""
    raise ConfigError(
        f"uros probe: the library {out} lacks {', '.join(missing)}, which the probe firmware uses",
        f"build a micro-ROS library with them: `uros build{ws} --toolchain {target} --packages std_msgs` "
        "(std_msgs and the core: rcl, rclc, the XRCE-DDS client and its rmw)",
    )
