"""The probe's stages from its console (run/stages.py, pure) and the live console reader of
run/session.py: what `uros probe` reports per stage, and the one-line verdict."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.run import stages
from uros_build.run.session import RESTART_ASKED, ConsoleReader
from uros_build.run.stages import ConsoleLine, Stage

CONSOLE = """uros-probe: boot
uros-probe: stage session pass session, node, publisher and subscription created
uros-probe: stage samples pass 10 of 10 came back in 649 ms (10 published)
uros-probe: stage limits pass nodes 1, publishers 1, subscriptions 1
uros-probe: stage fragmentation pass 773 B (1.5 x MTU 512) came back whole
uros-probe: stage service skip the library has no example_interfaces/srv/AddTwoInts
uros-probe: stage time pass epoch 1795656679.921 s (synced in 32 ms)
uros-probe: restart the agent
uros-probe: stage restart pass reconnected in 367 ms after the agent answered again
uros-probe: stage samples fail a second line of a stage does not count
uros-probe: stage Bad pass not a stage name
uros-probe: stage limits maybe not a result
"""


def _lines(text: str, seen: float = 1795656679.95) -> list[ConsoleLine]:
    return [ConsoleLine(seen, x) for x in text.splitlines()]


def test_stage_lines_are_read_in_order_first_line_wins() -> None:
    found = stages.parse(_lines(CONSOLE))
    assert [(s.name, s.result) for s in found] == [
        ("session", "pass"),
        ("samples", "pass"),
        ("limits", "pass"),
        ("fragmentation", "pass"),
        ("service", "skip"),
        ("time", "pass"),
        ("restart", "pass"),
    ]
    assert found[4].detail == "the library has no example_interfaces/srv/AddTwoInts"
    assert stages.parse(_lines("uros-probe: stage service pass\r")) == [Stage("service", "pass", "")]


def test_the_time_stage_is_judged_against_the_host_clock_when_its_line_appeared() -> None:
    line = "uros-probe: stage time pass epoch 1795656679.921 s (synced in 32 ms)"
    near = stages.stages_of(_lines(line, seen=1795656679.957))[0]
    assert near.result == "pass" and near.seconds == -0.036
    assert near.detail.endswith("-0.036 s off the host's clock")
    far = stages.stages_of(_lines(line, seen=1795656681.5))[0]
    assert far.result == "fail" and far.seconds == -1.579
    assert far.detail.startswith("the firmware's epoch is -1.579 s off the host's clock (more than 1 s)")
    ahead = stages.judge_time(stages.parse(_lines(line))[0], 1795656678.0)
    assert ahead.result == "fail" and ahead.seconds == 1.921
    no_epoch = stages.judge_time(Stage("time", "pass", "synced"), 1.0)
    assert no_epoch.result == "fail" and "no epoch" in no_epoch.detail
    failed = Stage("time", "fail", "rmw_uros_sync_session: no answer")
    assert stages.judge_time(failed, 1.0) == failed


def test_the_restart_stage_gets_the_hosts_time_to_reconnect() -> None:
    text = "uros-probe: stage restart pass reconnected in 367 ms"
    done = stages.stages_of(_lines(text, seen=110.5), restarts=[(100.0, 108.25)])[0]
    assert done.seconds == 2.25 and done.detail.endswith("2.25 s from the agent's restart (host)")
    assert stages.stages_of(_lines(text))[0].seconds is None  # no restart was made: nothing to add


def test_the_verdict_line_names_every_stage_and_the_first_failure() -> None:
    found = stages.stages_of(_lines(CONSOLE, seen=1795656679.957), restarts=[(1795656678.0, 1795656678.5)])
    line = stages.describe(found)
    assert line.startswith("session pass, samples pass, limits pass, fragmentation pass, service skip, ")
    assert "time pass (-0.036 s)" in line and "restart pass (1.46 s)" in line
    assert stages.failed(found) is None
    bad = [*found, Stage("service2", "fail", "no answer to 20 AddTwoInts requests in 5000 ms")]
    failure = stages.failed(bad)
    assert failure is not None
    assert (
        stages.failure_line(failure)
        == "stage service2 failed: no answer to 20 AddTwoInts requests in 5000 ms"
    )


def test_the_console_is_read_line_by_line_as_it_grows(tmp_path: Path) -> None:
    """run/session.py stamps each whole line when it first sees it; a half-written line waits."""
    log = tmp_path / "console.log"
    console = ConsoleReader(log)
    assert console.read() == []  # QEMU has not made the file yet
    log.write_bytes(b"uros-probe: boot\r\nuros-probe: resta")
    first = console.read()
    assert [x.text for x in first] == ["uros-probe: boot"]
    with log.open("ab") as f:
        f.write(b"rt the agent\r\n")
    second = console.read()
    assert [x.text for x in second] == [RESTART_ASKED]
    assert second[0].seen >= first[0].seen
    assert console.read() == []


def test_without_root_the_ced_middleware_skips_the_service_stage_and_says_why() -> None:
    """uros runs the agent's DDS middleware only as root (a network namespace); with CED the
    firmware's service stage fails by the agent's doing: skip, not a verdict on the library."""
    text = (
        "uros-probe: stage samples pass 10 of 10 came back\n"
        "uros-probe: stage service fail the AddTwoInts service could not be created (rclc_service_init_default"
        " returned 1; RMW_UXRCE_MAX_SERVICES=1)\n"
        "uros-probe: stage restart pass reconnected\n"
    )
    ced = stages.stages_of(_lines(text), middleware="ced")
    assert [(s.name, s.result) for s in ced] == [
        ("samples", "pass"),
        ("service", "skip"),
        ("restart", "pass"),
    ]
    assert ced[1].detail == stages.CED_SERVICE
    assert stages.passed(stages.SERVICE_STATUS, ced) and stages.passed(0, ced)
    dds = stages.stages_of(_lines(text))
    assert dds[1].result == "fail" and not stages.passed(stages.SERVICE_STATUS, dds)
    # another failure is never waived, nor another status
    worse = stages.stages_of(_lines(text + "uros-probe: stage time fail no answer\n"), middleware="ced")
    assert not stages.passed(stages.SERVICE_STATUS, worse)
    assert not stages.passed(10, ced) and not stages.passed(None, ced)


def test_the_agents_middleware_is_chosen_in_one_place() -> None:
    """DDS in a namespace needs root; `uros probe --app` as a user made the namespace anyway and
    failed, while the built-in probe fell back to CED. Both ask session.middleware_for now."""
    from uros_build.run.session import middleware_for

    assert middleware_for(peer=False, euid=0) == "dds"
    assert middleware_for(peer=False, euid=1000) == "ced"
    assert middleware_for(peer=True, euid=0) == "dds"


def test_the_probe_firmware_s_packages_are_checked_in_the_library() -> None:
    """Issue 43: a library without rcl/rclc/std_msgs failed in the compiler; named before building."""
    stages.check_packages([*stages.PACKAGES, "example_interfaces"], Path("/o"), "cortex-m7", None)
    with pytest.raises(ConfigError, match=r"the library /o lacks rclc, std_msgs, which") as caught:
        stages.check_packages(
            [p for p in stages.PACKAGES if p not in ("rclc", "std_msgs")], Path("/o"), "m7", None
        )
    assert "uros build --toolchain m7 --packages std_msgs" in str(caught.value.hint)


# --link (issue 40 item 4): the relay's counts judge the best-effort stage and the restart's flapping


def _link(
    up_sent: int, up_passed: int, down_sent: int, down_passed: int, events: list[tuple[str, float]]
) -> dict[str, object]:
    """The relay's summary; events: ("create KEY" or "answered", host time)."""
    return {
        "transport": "serial",
        "board_to_agent": {"best_effort": up_sent, "best_effort_passed": up_passed, "time": 2},
        "agent_to_board": {"best_effort": down_sent, "best_effort_passed": down_passed, "time_passed": 1},
        "sessions": [{"event": e.split()[0], "client_key": e[7:], "seen": t} for e, t in events],
    }


BEST = Stage("best_effort", "pass", "published 50, counted 40 back in 3120 ms")


def test_the_best_effort_figures_are_the_relay_s_not_the_firmware_s() -> None:
    judged = stages.judge_best_effort(BEST, _link(50, 45, 45, 40, []))
    assert judged.result == "pass"
    assert judged.detail == (
        "the board sent 50 best-effort samples, 45 reached the agent (10% lost), the agent sent 45 back, 40 "
        "reached the board (11% lost): 20% lost end to end (the relay's counts; the firmware said published "
        "50, counted 40)"
    )
    figures = stages.best_effort_figures(_link(50, 45, 45, 40, []))
    assert (figures["loss_to_agent"], figures["loss_to_board"], figures["loss"]) == (0.1, 0.111, 0.2)


@pytest.mark.parametrize(
    ("link", "why"),
    [
        (_link(50, 45, 45, 39, []), "the firmware counted 40 back, more than the relay delivered"),
        (_link(0, 0, 0, 0, []), "the relay saw no best-effort sample"),
        (_link(50, 45, 0, 0, []), "no best-effort sample came back"),
    ],
)
def test_a_best_effort_count_the_relay_does_not_back_fails(link: dict[str, object], why: str) -> None:
    judged = stages.judge_best_effort(BEST, link)
    assert judged.result == "fail" and judged.detail.startswith(why), judged.detail


def test_a_reconnect_that_opens_two_sessions_after_one_restart_flapped() -> None:
    restart = Stage("restart", "pass", "reconnected in 367 ms after the agent answered again")
    lines = [
        ConsoleLine(100.0, RESTART_ASKED),
        ConsoleLine(110.0, f"uros-probe: stage restart pass {restart.detail}"),
    ]
    first = [("create aa", 50.0), ("answered", 50.3)]
    # a request sent again before the answer came is a retry (over UDP the key stays the same)
    once = [*first, ("create aa", 101.0), ("create aa", 102.0), ("answered", 102.2), ("answered", 102.3)]
    judged = stages.judge_flapping(restart, lines, _link(0, 0, 0, 0, once))
    assert judged.result == "pass" and judged.detail.endswith(
        "one session after the restart (the relay's count)"
    )
    later = [*once, ("create cc", 111.0), ("answered", 111.1)]  # a later stage's own session
    assert stages.judge_flapping(restart, lines, _link(0, 0, 0, 0, later)).result == "pass"
    twice = [*once, ("create bb", 103.5), ("answered", 103.8)]
    judged = stages.judge_flapping(restart, lines, _link(0, 0, 0, 0, twice))
    assert judged.result == "fail"
    assert judged.detail.startswith(
        "the reconnect flapped: the board opened 2 sessions after one agent restart (client keys aa, bb)"
    )
    none = stages.judge_flapping(restart, lines, _link(0, 0, 0, 0, first))
    assert none.result == "fail" and "opened 0 sessions" in none.detail
    assert stages.judge_flapping(restart, lines, None) == restart  # no relay, no count


def test_the_time_stage_says_the_requests_the_relay_saw() -> None:
    time = Stage("time", "pass", "epoch 1795656679.921 s (synced in 1032 ms, 2 attempts)")
    judged = stages.judge_time_link(time, _link(0, 0, 0, 0, []))
    assert judged.detail.endswith("; the link: 2 time requests, 1 answers reached the board")
