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
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from uros_helpers import REPO, Background, run_uros, run_uros_here

from uros_build.run import peerenv

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


# -- issue 43: the verdict, the run's processes, the ROS 2 environment ------------------------------

# An agent whose CLOCK_REALTIME is SHIFT seconds ahead (LD_PRELOAD): the time it gives the firmware is
# wrong, which only the host can see (the firmware's own checks pass, exit 0).
CLOCK_SHIM = """
#define _GNU_SOURCE
#include <dlfcn.h>
#include <time.h>
int clock_gettime(clockid_t id, struct timespec *tp) {
  static int (*real)(clockid_t, struct timespec *);
  if (!real) real = (int (*)(clockid_t, struct timespec *))dlsym(RTLD_NEXT, "clock_gettime");
  int r = real(id, tp);
  if (r == 0 && id == CLOCK_REALTIME) tp->tv_sec += SHIFT;
  return r;
}
"""
OK_PEER = "print('peer: ok', flush=True)\n"


def _agent_ahead(tmp_path: Path, seconds: int) -> Path:
    if shutil.which("gcc") is None:
        pytest.skip("no host gcc to build the clock shim")
    assert AGENT
    source, shim, agent = tmp_path / "shift.c", tmp_path / "shift.so", tmp_path / "agent.sh"
    source.write_text(CLOCK_SHIM, encoding="utf-8")
    subprocess.run(
        ["gcc", "-shared", "-fPIC", f"-DSHIFT={seconds}", "-o", str(shim), str(source), "-ldl"], check=True
    )
    agent.write_text(f'#!/bin/sh\nLD_PRELOAD={shim} exec {AGENT} "$@"\n', encoding="utf-8")
    agent.chmod(0o755)
    return agent


@_RUNS
def test_a_stage_the_host_judges_fails_the_run_with_a_peer_too(tmp_path: Path) -> None:
    """Issue 43, item 1: with the agent's clock 5 s ahead the probe alone fails its time stage (exit 5),
    but with a peer that exits 0 it said `probe passed ... and a ROS 2 peer` (exit 0) while its own
    --json said `passed: false`: the peer's verdict read the firmware's exit status, not the stages."""
    agent = _agent_ahead(tmp_path, 5)
    peer = _peer(tmp_path, "ok.py", OK_PEER)
    proc = run_uros(
        "probe", "--json", "--agent", str(agent), str(_output()), "--peer", str(peer), check=False
    )
    data = json.loads(proc.stdout)
    assert proc.returncode == 5, proc.stderr
    assert data["status"] == 0 and data["peer_status"] == 0  # both exited 0: the host's judgement fails it
    assert data["passed"] is False and data["stages"]["time"]["result"] == "fail"  # type: ignore[index]
    line = _one_error(proc)
    assert "with a peer: stage time failed: the firmware's epoch is +" in line, line
    assert line.endswith("; the peer passed"), line
    assert "probe passed" not in proc.stderr


def _running(argv: list[str]) -> list[int]:
    """The processes whose command line is ``argv`` (zombies have none)."""
    want = ("\0".join(argv) + "\0").encode()
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and (entry / "cmdline").read_bytes() == want:
                found.append(int(entry.name))
        except OSError:
            continue
    return found


def _in_namespace(namespace: str) -> list[int]:
    return [
        int(e.name)
        for e in Path("/proc").iterdir()
        if e.name.isdigit() and _readlink(e / "ns" / "net") == namespace
    ]


def _readlink(path: Path) -> str | None:
    try:
        return os.readlink(path)
    except OSError:
        return None


@pytest.fixture
def sleepers() -> Iterator[list[list[str]]]:
    """The `sleep` command lines a test's peer leaves; whatever is left of them is killed after it."""
    left: list[list[str]] = []
    yield left
    for argv in left:
        for pid in _running(argv):
            os.kill(pid, 9)


# A peer that leaves a plain child (its process group, its UROS_OWNER mark) and a double-forked
# daemon that cleared its environment (only the run's network namespace holds it), then exits 0.
LEAVING_PEER = """
import os, subprocess, sys
with open(sys.argv[0] + ".ns", "w") as f:
    f.write(os.readlink("/proc/self/ns/net"))
subprocess.Popen(["sleep", "4313.1"])
if os.fork() == 0:
    os.setsid()
    if os.fork() == 0:
        os.execve("/bin/sleep", ["sleep", "4313.2"], {})
    os._exit(0)
os.wait()
print("peer: left two behind", flush=True)
"""


@_RUNS
def test_what_a_peer_leaves_running_ends_with_the_run(tmp_path: Path, sleepers: list[list[str]]) -> None:
    """Issue 43, item 7: a peer's plain child ran on after the run, and a double-forked daemon kept
    the run's network namespace alive. Everything the run started, in its namespace or carrying its
    mark, ends with it."""
    sleepers += [["sleep", "4313.1"], ["sleep", "4313.2"]]
    peer = _peer(tmp_path, "leaving.py", LEAVING_PEER)
    proc = run_uros("probe", "--agent", str(AGENT), str(_output()), "--peer", str(peer), check=False)
    assert proc.returncode == 0, proc.stderr
    assert "stopped 2 processes the run's programs left running" in proc.stderr
    assert not _running(["sleep", "4313.1"]) and not _running(["sleep", "4313.2"])
    namespace = (tmp_path / "leaving.py.ns").read_text(encoding="utf-8")
    assert namespace.startswith("net:[") and _in_namespace(namespace) == []  # the namespace is gone


@_RUNS
def test_a_killed_run_s_peer_children_are_stopped_by_the_next_probe(
    tmp_path: Path, sleepers: list[list[str]]
) -> None:
    """Issue 43, item 7: after SIGKILL of uros (no cleanup of its own can run), a peer's child ran on
    for ever. The next probe of the target stops it, as `uros build` does with a killed build's."""
    child = ["sleep", "4313.3"]
    sleepers.append(child)
    peer = _peer(
        tmp_path,
        "stays.py",
        "import subprocess, time\nsubprocess.Popen(['sleep', '4313.3'])\ntime.sleep(120)\n",
    )
    run = Background("probe", "--agent", str(AGENT), str(_output()), "--peer", str(peer))
    deadline = time.monotonic() + 300
    while not _running(child):
        assert run.proc.poll() is None and time.monotonic() < deadline, "".join(run.lines)
        time.sleep(0.2)
    run.proc.kill()
    run.end(30)
    time.sleep(1)
    assert _running(child), "the parent-death signal reaches uros's own children only"
    proc = run_uros("probe", "--agent", "/no/such/agent", str(_output()), check=False)
    assert proc.returncode == 3, proc.stderr
    assert "left running by an earlier uros probe that was killed" in proc.stderr
    assert not _running(child)


def _linked_cache(tmp_path: Path, interfaces: bool = True) -> tuple[Path, Path]:
    """UROS_ROS2_VENV's environment (and host-built interface packages) under a new root, every file
    hard-linked: damage is done by unlinking, never by writing into a shared file. (root, venv)."""
    assert ROS2_VENV
    source = peerenv.venv_path(Path(ROS2_VENV), peerenv.load_spec(), peerenv.python_version())
    if not (source / peerenv.READY).is_file():
        pytest.skip(f"{source}: no ROS 2 environment made yet (run a --peer test once)")
    root = tmp_path / "ros2"
    for name in (source.name, "interfaces") if interfaces else (source.name,):
        if (Path(ROS2_VENV) / name).is_dir():
            shutil.copytree(Path(ROS2_VENV) / name, root / name, symlinks=True, copy_function=os.link)
    return root, root / source.name


@_RUNS
@pytest.mark.parametrize("damage", ["a deleted module", "a truncated library", "no python"])
def test_a_damaged_ros2_environment_is_named_not_blamed_on_the_peer(tmp_path: Path, damage: str) -> None:
    """Issue 43, item 9: a deleted module, a truncated .so or a missing python in the cached
    environment showed as "the peer failed (exit 1 / -7 / 127)". The environment is checked before
    use (its Python imports rclpy, the middleware and the messages) and named with its removal."""
    root, venv = _linked_cache(tmp_path)
    site = venv / "lib" / f"python{peerenv.python_version()}" / "site-packages"
    if damage == "a deleted module":
        shutil.rmtree(site / "rclpy")
    elif damage == "a truncated library":
        library = next((site / "rclpy").glob("_rclpy_pybind11*.so"))
        data = library.read_bytes()
        library.unlink()  # a link of the shared file: the new one is the test's own
        library.write_bytes(data[: len(data) // 3])
    else:
        (venv / "bin" / "python3").unlink()
    peer = _peer(tmp_path, "ok.py", "import rclpy\n" + OK_PEER)
    env = {**os.environ, "UROS_ROS2_VENV": str(root)}
    proc = run_uros("probe", "--agent", str(AGENT), str(_output()), "--peer", str(peer), env=env, check=False)
    assert proc.returncode == 4, proc.stderr
    line = _one_error(proc)
    assert f"the ROS 2 peer environment {venv} is damaged" in line, line
    assert f"rm -rf {venv}" in proc.stderr
    assert "the peer failed" not in proc.stderr and "qemu-system-arm -" not in proc.stderr  # nothing ran


def test_a_ros2_venv_that_is_a_file_is_one_line(m7_build: Path, tmp_path: Path) -> None:
    """Issue 43, item 9: UROS_ROS2_VENV naming a file was an internal error."""
    if os.geteuid() != 0:
        pytest.skip("--peer needs root (refused before UROS_ROS2_VENV is read)")
    (tmp_path / "ros2").write_text("", encoding="utf-8")
    peer = _peer(tmp_path, "ok.py", OK_PEER)
    out = m7_build / "build" / "cortex-m7"
    proc = run_uros_here(
        "probe", str(out), "--peer", str(peer), env={"UROS_ROS2_VENV": str(tmp_path / "ros2")}, check=False
    )
    assert proc.returncode == 2, proc.stderr
    assert f"UROS_ROS2_VENV {tmp_path / 'ros2'}: is not a folder" in _one_error(proc)


@_RUNS
def test_a_ros2_venv_folder_uros_cannot_write_is_one_line(tmp_path: Path) -> None:
    """Issue 43, item 9: an empty folder uros cannot write (immutable: read-only even for root) as
    UROS_ROS2_VENV was an internal error."""
    root = tmp_path / "ros2"
    root.mkdir()
    if subprocess.run(["chattr", "+i", str(root)], capture_output=True).returncode != 0:
        pytest.skip("chattr +i does not work here")
    try:
        peer = _peer(tmp_path, "ok.py", OK_PEER)
        env = {**os.environ, "UROS_ROS2_VENV": str(root)}
        proc = run_uros(
            "probe", "--agent", str(AGENT), str(_output()), "--peer", str(peer), env=env, check=False
        )
        assert proc.returncode == 2, proc.stderr
        line = _one_error(proc)
        assert f"UROS_ROS2_VENV {root}: cannot write {root}" in line and "Operation not permitted" in line, (
            line
        )
    finally:
        subprocess.run(["chattr", "-i", str(root)], check=True)


@_RUNS
def test_a_relative_ros2_venv_gives_a_peer_that_sees_the_samples(tmp_path: Path) -> None:
    """Issue 43, item 9: a relative UROS_ROS2_VENV gave a peer that never saw a sample (here: the host
    build of the workspace's interface packages, given relative folders, failed to configure: "No
    'rosidl_typesupport_c' found"). uros makes it absolute; the interface packages are built afresh
    under it (minutes)."""
    root, _ = _linked_cache(tmp_path, interfaces=False)
    peer = _peer(tmp_path, "probe_peer.py", PROBE_PEER.format(op=">="))
    env = {**os.environ, "UROS_ROS2_VENV": root.name}
    proc = subprocess.run(
        [sys.executable, "-m", "uros_build", "probe", "--agent", str(AGENT), str(_output()), "--peer", str(peer)],
        cwd=root.parent, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert f"ROS 2 peer environment: {root}/" in proc.stderr  # made absolute
    passed = next(x for x in proc.stderr.splitlines() if "probe passed" in x)
    assert "peer: got [" in Path(passed.split("the peer's log: ")[1].strip()).read_text()
