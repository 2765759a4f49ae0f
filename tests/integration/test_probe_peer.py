"""`uros probe --peer SCRIPT` (issue 31, items 2 and 3): a host ROS 2 program (rclpy from PyPI's ros-*
wheels, in the ROS 2 environment uros makes and caches) runs beside the firmware in QEMU, over the
agent's DDS middleware, in a network namespace of the run's own; the verdict needs the firmware's
exit status and the peer's.

The runs need UROS_AGENT (a MicroXRCEAgent with Fast DDS), UROS_HUMBLE_WS (an already built humble
workspace whose cortex-m7 output has eic_demo_interface and demo_interfaces: a copy of
docs/real-humble.md's; the probe writes its work folder into it), UROS_ROS2_VENV (where the peer's
ROS 2 environment is cached: made on the first run, ~1 min of pip plus the interface packages'
host build) and root (unshare -n); without them they skip. The refusals before anything runs need
none of them and run in CI.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from uros_helpers import REPO, run_uros

pytestmark = pytest.mark.integration

AGENT = os.environ.get("UROS_AGENT")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
ROS2_VENV = os.environ.get("UROS_ROS2_VENV")
_RUNS = pytest.mark.skipif(
    not (AGENT and HUMBLE_WS and ROS2_VENV and shutil.which("qemu-system-arm") and os.geteuid() == 0),
    reason="set UROS_AGENT (a MicroXRCEAgent), UROS_HUMBLE_WS (a built humble workspace with cortex-m7) "
    "and UROS_ROS2_VENV (the peer's ROS 2 environment's cache), install qemu-system-arm, run as root",
)
SEED_001 = REPO / "examples" / "stm32h7-custom"
SEED_000 = REPO / "examples" / "esp32s3-idf" / "app"

# A peer of the built-in probe firmware: it publishes std_msgs/Int32 1000, 1001, ... on uros_probe.
PROBE_PEER = """
import sys, time
import rclpy
from std_msgs.msg import Int32
rclpy.init()
node = rclpy.create_node("uros_probe_peer")
got = []
node.create_subscription(Int32, "uros_probe", lambda m: got.append(m.data), 10)
end = time.monotonic() + 12
while time.monotonic() < end and len(got) < 3:
    rclpy.spin_once(node, timeout_sec=0.1)
print("peer: got", got, flush=True)
sys.exit(0 if len(got) >= 3 and all(v {op} 1000 for v in got) else 1)
"""


def _one_error(proc: subprocess.CompletedProcess[str]) -> str:
    assert "Traceback" not in proc.stderr, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


def _output() -> Path:
    assert HUMBLE_WS
    return Path(HUMBLE_WS) / "build" / "cortex-m7"


def _peer(tmp_path: Path, name: str, text: str) -> Path:
    script = tmp_path / name
    script.write_text(text, encoding="utf-8")
    return script


def _probe(*args: str) -> tuple[int, str, dict[str, object]]:
    proc = run_uros("probe", "--json", "--agent", str(AGENT), *args, check=False)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc.returncode, proc.stderr, json.loads(proc.stdout)


# -- before anything runs (CI) ----------------------------------------------------------------------


def test_a_missing_peer_is_one_line_before_anything_is_built(m7_build: Path, tmp_path: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    proc = run_uros("probe", str(out), "--peer", str(tmp_path / "nope.py"), check=False)
    assert proc.returncode == 2
    assert f"--peer {tmp_path / 'nope.py'}: no such file" in _one_error(proc)
    assert not list((m7_build / ".uros").glob("probe/*/build")), "nothing may be built"


# -- runs (real Humble, the agent, the peer's ROS 2 environment) --------------------------------


@_RUNS
def test_a_peer_sees_the_probe_firmware_s_samples_over_dds(tmp_path: Path) -> None:
    peer = _peer(tmp_path, "probe_peer.py", PROBE_PEER.format(op=">="))
    code, err, data = _probe(str(_output()), "--peer", str(peer))
    assert code == 0, err
    assert data["status"] == 0 and data["peer_status"] == 0
    line = next(x for x in err.splitlines() if "probe passed" in x)
    assert "a ROS 2 peer" in line and str(data["peer_log"]) in line and str(data["console_log"]) in line
    assert "peer: got [" in Path(str(data["peer_log"])).read_text()
    agent_log = Path(str(data["agent_log"])).read_text()
    assert "participant created" in agent_log  # the DDS middleware (CED creates no participant)
    assert float(str(data["seconds"])) <= 15


@_RUNS
def test_a_peer_that_fails_fails_the_verdict_though_the_firmware_passed(tmp_path: Path) -> None:
    """The negative control: the firmware exits 0, the peer's check (values below 1000) does not hold."""
    peer = _peer(tmp_path, "wrong_peer.py", PROBE_PEER.format(op="<"))
    code, err, data = _probe(str(_output()), "--peer", str(peer))
    assert code == 5, err
    assert data["status"] == 0 and data["peer_status"] == 1
    line = _one_error(subprocess.CompletedProcess([], code, "", err))
    assert "the peer failed (exit 1), though the firmware passed its own checks" in line
    assert str(data["peer_log"]) in err and str(data["console_log"]) in err


# -- the seeds' apps (examples/*/app.c, run by `uros probe --app`) and their peers -----------------

_APPS = pytest.mark.skipif(
    not ((SEED_001 / "app.c").is_file() and (SEED_000 / "app.c").is_file()),
    reason="the seeds' apps are not here",
)


def _seed_001(out: Path) -> tuple[int, str, dict[str, object]]:
    return _probe(
        str(out), "--app", str(SEED_001), "-D", "APP_PEER_REQUESTS=2", "--peer", str(SEED_001 / "peer.py")
    )


@_RUNS
@_APPS
def test_seed_001_s_app_and_its_peer_cmdvel_and_get_time() -> None:
    code, err, data = _seed_001(_output())
    assert code == 0, err
    peer_log = Path(str(data["peer_log"])).read_text()
    assert "peer: PASS" in peer_log and "get_time asked at" in peer_log, peer_log
    assert "app: PASS" in Path(str(data["console_log"])).read_text()


@_RUNS
@_APPS
def test_seed_000_s_hsb_node_follows_the_peer_s_commands() -> None:
    code, err, data = _probe(
        str(_output()), "--app", str(SEED_000), "-D", "HSB_EXIT_AFTER=2", "-D", "HSB_STATE_PERIOD_MS=200",
        "--peer", str(SEED_000 / "peer.py"),
    )  # fmt: skip
    assert code == 0, err
    peer_log = Path(str(data["peer_log"])).read_text()
    assert "peer: PASS every command was followed by the state" in peer_log, peer_log
    line = next(x for x in err.splitlines() if "app passed" in x)
    assert "the firmware and the peer both passed" in line
    assert str(data["peer_log"]) in line and str(data["console_log"]) in line


@_RUNS
@_APPS
def test_a_wrong_interface_definition_is_caught_by_the_peer_only(tmp_path: Path) -> None:
    """The negative control of a wrong type: the peer's CmdVel has int16 fields where the firmware's
    (the library's) has int32. DDS matches them by name; the firmware passes its own checks (exit 0)
    and only the peer sees that its CmdVel does not come right, so the verdict fails."""
    assert HUMBLE_WS
    ws = tmp_path / "ws"
    shutil.copytree(HUMBLE_WS, ws, symlinks=True, ignore=shutil.ignore_patterns("probe"))
    msg = ws / "mcu_ws" / "extra_packages" / "eic_demo_interface" / "msg" / "CmdVel.msg"
    msg.write_text("int16 left_rpm\nint16 right_rpm\n", encoding="utf-8")  # the library keeps int32
    code, err, data = _seed_001(ws / "build" / "cortex-m7")
    assert code == 5, err
    assert data["peer_status"] == 1
    assert "though the firmware passed its own checks" in _one_error(
        subprocess.CompletedProcess([], code, "", err)
    )
    # int16 fields: Fast DDS refuses the firmware's 8-byte payload for a 4-byte type ("cannot be
    # resized"), so nothing arrives; a same-size mismatch would arrive and fail the field checks
    peer_log = Path(str(data["peer_log"])).read_text()
    assert "peer: FAIL 0 of 5 CmdVel came" in peer_log or "CmdVel fields wrong" in peer_log, peer_log
    assert "app: PASS" in Path(str(data["console_log"])).read_text()  # the app had the peer's requests
