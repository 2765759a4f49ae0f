"""Many boards on one agent (issue 40 item 3): `uros probe --instances N` boots N copies of the probe
image against one agent (multiserial), each board judged apart, the client key of each read off the
wire; boards forced to share a key fail by name with the fix; Ctrl-C stops every QEMU and the agent.

The refusals of bad --instances and --client-keys run everywhere, CI included, in process (nothing
starts). The runs need a built humble workspace with cortex-m7 (UROS_HUMBLE_WS, a copy: the probe
writes into it), an agent (UROS_AGENT, or UROS_ROS2_VENV with one `uros agent build` made) and
qemu-system-arm; without them they skip.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from uros_helpers import default_sigint, run_uros, run_uros_here

from uros_build.run import fleet
from uros_build.run.report import probe_base, probe_work

pytestmark = pytest.mark.integration

HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
ROS2_VENV = os.environ.get("UROS_ROS2_VENV")
AGENT = os.environ.get("UROS_AGENT")
_BUILT = ROS2_VENV is not None and (Path(ROS2_VENV).expanduser() / "agent" / "current.json").is_file()
_RUNS = pytest.mark.skipif(
    not (HUMBLE_WS and shutil.which("qemu-system-arm") and (AGENT or _BUILT)),
    reason="set UROS_HUMBLE_WS (a built humble workspace with cortex-m7) and an agent (UROS_AGENT, or "
    "UROS_ROS2_VENV with one `uros agent build` made); install qemu-system-arm",
)


def _one_error(stderr: str) -> str:
    assert "Traceback" not in stderr, stderr
    errors = [x for x in stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1, stderr
    return errors[0]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--instances", "0"), f"--instances 0: must be 1 to {fleet.MAX_INSTANCES}"),
        (("--instances", "-2"), f"--instances -2: must be 1 to {fleet.MAX_INSTANCES}"),
        (("--instances", "17"), f"--instances 17: must be 1 to {fleet.MAX_INSTANCES}"),
        (
            ("--instances", "2", "--client-keys", "random"),
            "--client-keys random: must be one of own, same, drawn",
        ),
        (("--client-keys", "same"), "--client-keys same: with --instances 2 or more"),
        (
            ("--instances", "2", "--app", "app"),
            "--instances 2 with --app: many boards run the built-in probe alone",
        ),
        (("--instances", "2", "--graph"), "--instances 2 with --graph"),
    ],
)
def test_bad_instances_are_one_line_before_anything_runs(
    tmp_path: Path, args: tuple[str, ...], message: str
) -> None:
    proc = run_uros_here("probe", str(tmp_path / "no-output"), *args, check=False)
    assert proc.returncode == 2, proc.stderr
    assert message in _one_error(proc.stderr)


def _out() -> Path:
    assert HUMBLE_WS
    return Path(HUMBLE_WS) / "build" / "cortex-m7"


@_RUNS
def test_two_boards_with_their_own_keys_pass_on_one_agent() -> None:
    proc = run_uros("probe", str(_out()), "--instances", "2", "--json", check=False)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert (report["instances"], report["client_keys"], report["transport"]) == (2, "own", "multiserial")
    assert report["passed"] and report["verdict"] == "every board passed"
    keys = [board["client_keys"] for board in report["boards"]]
    assert all(len(k) == 1 for k in keys) and keys[0] != keys[1], keys  # the same key again at the restart
    for board in report["boards"]:
        stages = board["stages"]
        assert board["passed"] and board["status"] == 0, board
        for name in ("session", "samples", "restart", "client-key"):
            assert stages[name]["result"] == "pass", (board["index"], name, stages[name])
        # each board's samples are its own (its namespace): 10 back, no more than it published
        assert "10 of 10 came back" in stages["samples"]["detail"]
    assert "probe passed: 2 boards of cortex-m7" in proc.stderr


@_RUNS
def test_boards_forced_to_share_a_client_key_fail_by_name_with_the_fix() -> None:
    proc = run_uros("probe", str(_out()), "--instances", "2", "--client-keys", "same", "--json", check=False)
    assert proc.returncode == 5, proc.stderr
    line = _one_error(proc.stderr)
    assert "boards 0, 1 shared client key 0x" in line and "the agent took them for one client" in line
    assert "rmw_uros_options_set_client_key" in line and "unique id" in line
    report = json.loads(proc.stdout)
    assert not report["passed"]
    assert report["boards"][0]["client_keys"] == report["boards"][1]["client_keys"]
    assert all(b["stages"]["client-key"]["result"] == "fail" for b in report["boards"])


def _marked(owner_prefix: bytes) -> list[int]:
    """Processes whose UROS_OWNER starts with ``owner_prefix`` (a probe of this workspace's)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            environ = (entry / "environ").read_bytes()
        except OSError:
            continue
        if any(v.startswith(b"UROS_OWNER=" + owner_prefix) for v in environ.split(b"\0")):
            found.append(int(entry.name))
    return found


@_RUNS
def test_ctrl_c_stops_every_board_and_the_agent() -> None:
    out = _out()
    work = probe_work(probe_base(out, "cortex-m7"), "cortex-m7", out)
    prefix = f"uros probe {out.parents[1]}".encode()
    consoles = [fleet.board_work(work, i) / "console.log" for i in range(3)]
    for old in consoles:  # an earlier run's
        old.unlink(missing_ok=True)
    uros = subprocess.Popen(
        [sys.executable, "-m", "uros_build", "probe", str(out), "--instances", "3"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint,
    )  # fmt: skip
    try:
        end = time.monotonic() + 240  # the firmware is built first
        while time.monotonic() < end and uros.poll() is None:
            texts = [c.read_text(errors="replace") if c.is_file() else "" for c in consoles]
            if all("agent answered" in text for text in texts):  # every board talks to the agent
                break
            time.sleep(0.1)
        assert uros.poll() is None, uros.communicate()
        assert len(_marked(prefix)) >= 4  # three QEMUs and the agent
        uros.send_signal(signal.SIGINT)
        _, stderr = uros.communicate(timeout=60)
    finally:
        if uros.poll() is None:
            uros.kill()
    assert uros.returncode == 130, stderr
    assert _marked(prefix) == [], stderr
