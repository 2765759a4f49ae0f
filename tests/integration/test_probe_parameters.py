"""The probe's parameters and action stages (issue 41, item 2) on real Humble libraries built here from
a copy of a built workspace (UROS_HUMBLE_WS) with rclc_parameter and example_interfaces: with room for
a parameter server's 5 services and an action server's and client's entities (the --set below, the
rest generate_lib's values) the firmware's own clients get, set and list its three typed parameters and
a Fibonacci goal gets its feedback and result through the agent, and both stages pass; on
generate_lib's one service and one client both say `skip` and name the options, never `pass`; and
`uros check --for-firmware` says the same of the parameters stage's source before any run.
Env-gated: the workspace, UROS_AGENT and qemu-system-arm; each build takes minutes."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from uros_helpers import run_uros

AGENT = os.environ.get("UROS_AGENT")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
PACKAGES = ("rclc_parameter", "std_msgs", "example_interfaces")
pytestmark = [
    pytest.mark.integration,
    pytest.mark.colcon,  # each test builds a real Humble library
    pytest.mark.skipif(
        not (
            HUMBLE_WS
            and AGENT
            and shutil.which("qemu-system-arm")
            and (Path(HUMBLE_WS) / "mcu_ws").is_dir()
            and (Path(HUMBLE_WS) / "build" / "cortex-m7" / "build-info.json").is_file()
        ),
        reason="set UROS_HUMBLE_WS (a copy of a built humble workspace with rclc in mcu_ws) and UROS_AGENT, "
        "and install qemu-system-arm",
    ),
]
REPO = Path(__file__).resolve().parents[2]
STAGE_SOURCE = REPO / "templates" / "probe" / "stage_parameters.c"
EXAMPLE = REPO / "examples" / "parameter-server"


def _build(out: Path, *, services: int, clients: int, publishers: int, subscriptions: int) -> None:
    assert HUMBLE_WS
    packages = [x for p in PACKAGES for x in ("--packages", p)]
    sets = {
        "SERVICES": services,
        "CLIENTS": clients,
        "PUBLISHERS": publishers,
        "SUBSCRIPTIONS": subscriptions,
    }
    more = [x for k, v in sets.items() for x in ("--set", f"rmw_microxrcedds.RMW_UXRCE_MAX_{k}={v}")]
    run_uros("build", "--toolchain", "cortex-m7", "-w", HUMBLE_WS, "--output", str(out), *packages, *more)


def _check(out: Path, tmp_path: Path) -> tuple[int, str]:
    """`uros check --for-firmware` of the stage's source alone (the whole probe's stages run one
    after another: a static count would add them up)."""
    firmware = tmp_path / "stage"
    firmware.mkdir()
    shutil.copy(STAGE_SOURCE, firmware / "main.c")
    lib = str(out / "libmicroros.a")
    checked = run_uros("check", lib, "--toolchain", "cortex-m7", "--for-firmware", str(firmware), check=False)
    return checked.returncode, checked.stderr


def _stages(out: Path, **room: int) -> tuple[int, dict[str, dict[str, str]]]:
    """The library built into ``out`` with ``room`` (services=, clients=, ...), then probed."""
    _build(out, **room)
    proc = run_uros("probe", "--json", str(out), check=False)
    data = json.loads(proc.stdout)
    stages = data["stages"]
    assert isinstance(stages, dict), proc.stderr
    return proc.returncode, stages


def test_a_parameter_server_and_an_action_work_through_the_agent_with_room_for_them(tmp_path: Path) -> None:
    out = tmp_path / "room"
    code, stages = _stages(out, services=5, clients=3, publishers=2, subscriptions=2)
    assert code == 0 and stages["parameters"]["result"] == "pass", stages
    assert (
        "3 parameters (bool, int, double) got, set (the server's callback saw uros_count=7) and listed"
        in stages["parameters"]["detail"]
    )
    action = stages["action"]
    assert action["result"] == "pass" and "the result [0, 1, 1, 2, 3] through the agent" in action["detail"]
    # the stage's source fits the library it passed on: 5 services, 1 publisher, 6 handles given 6
    code, said = _check(out, tmp_path)
    assert code == 0, said
    assert "services: 5 (5 for a parameter server at main.c:" in said and "RMW_UXRCE_MAX_SERVICES=5" in said
    assert "executor is initialised for 6 handles and given 6" in said


def test_one_service_skips_the_stages_naming_the_options_and_check_predicts_it(tmp_path: Path) -> None:
    out = tmp_path / "one"
    code, stages = _stages(out, services=1, clients=1, publishers=1, subscriptions=1)
    stage = stages["parameters"]
    assert code == 0 and stage["result"] == "skip", stages
    assert stages["action"]["result"] == "skip" and "RMW_UXRCE_MAX_SERVICES=1, _CLIENTS=1" in str(
        stages["action"]["detail"]
    )
    assert str(stage["detail"]) == (
        "a parameter server takes 5 services and the library has RMW_UXRCE_MAX_SERVICES=1 "
        "(uros build --set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5)"
    )
    code, said = _check(out, tmp_path)
    assert code == 5, said
    assert "--set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5 fits" in said


def _app(out: Path, app: Path) -> tuple[int, dict[str, object]]:
    proc = run_uros("probe", "--json", str(out), "--app", str(app), check=False)
    return proc.returncode, json.loads(proc.stdout)


def test_the_example_runs_and_an_executor_too_small_for_it_is_caught_before_and_fails_by_name(
    tmp_path: Path,
) -> None:
    """examples/parameter-server on a library with room: six parameters added and read back through
    the agent. The negative control: the same app with its executor initialised for 4 handles, which
    `uros check --for-firmware` names (file:line, the add that fails) before it runs, and which fails at
    run time in that very call."""
    out = tmp_path / "room"
    _build(out, services=5, clients=1, publishers=1, subscriptions=1)
    code, data = _app(out, EXAMPLE)
    assert code == 0 and data["status"] == 0, data
    assert "app: every parameter added and read back" in Path(str(data["console_log"])).read_text()

    small = tmp_path / "small"
    shutil.copytree(EXAMPLE, small)
    text = (small / "app.c").read_text()
    define = "#define APP_HANDLES RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES"
    assert define in text
    (small / "app.c").write_text(text.replace(define, "#define APP_HANDLES 4"))
    checked = run_uros(
        "check", str(out / "libmicroros.a"), "--toolchain", "cortex-m7", "--for-firmware", str(small)
    )
    warned = [line for line in checked.stderr.splitlines() if "executor is initialised for 4 handles" in line]
    assert len(warned) == 1 and warned[0].startswith("warning: app.c:"), checked.stderr
    assert "given 5: rclc_executor_add_parameter_server at app.c:" in warned[0]
    code, data = _app(out, small)
    assert code == 5 and data["status"] == 3, data
    console = Path(str(data["console_log"])).read_text()
    assert "app: rclc_executor_add_parameter_server returned 1: the executor (4 handles)" in console


@pytest.mark.skipif(
    not (os.environ.get("UROS_ROS2_VENV") and os.geteuid() == 0),
    reason="set UROS_ROS2_VENV (the peer's ROS 2 environment's cache) and run as root (the run's namespace)",
)
def test_a_ros2_peer_lists_gets_describes_and_sets_the_example_s_parameters(tmp_path: Path) -> None:
    """examples/parameter-server with its peer.py (rclpy through the agent, what `ros2 param` does): in
    full mode list, get, describe, set param_0=123 and read it back all pass; in rclc's low-memory mode
    the set is never answered (humble's rclc_parameter leaves the set request's string_value without
    room), and the peer says so by name."""
    out = tmp_path / "room"
    _build(out, services=5, clients=1, publishers=1, subscriptions=1)
    peer = ["--peer", str(EXAMPLE / "peer.py"), "--timeout", "300", "-D", "APP_PEER_WAIT_MS=60000"]
    proc = run_uros("probe", "--json", str(out), "--app", str(EXAMPLE), *peer, check=False)
    data = json.loads(proc.stdout)
    assert proc.returncode == 0 and data["peer_status"] == 0, proc.stderr
    log = Path(str(data["peer_log"])).read_text()
    assert "peer: PASS listed, got, described, set param_0=123 and read it back" in log
    assert "app: the peer set param_0 (now 123)" in Path(str(data["console_log"])).read_text()

    low = [*peer, "-D", "APP_LOW_MEM=1"]
    proc = run_uros("probe", "--json", str(out), "--app", str(EXAMPLE), *low, check=False)
    data = json.loads(proc.stdout)
    assert proc.returncode == 5 and data["peer_status"] == 1, proc.stderr
    log = Path(str(data["peer_log"])).read_text()
    assert "peer: get_parameters: 6 values right, one name a request" in log
    assert "peer: FAIL set: no answer in 20 s" in log
