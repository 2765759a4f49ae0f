"""`uros probe` (issue 17): a uros-built library, booted in QEMU on the target's mps2 board, talks to
a real Micro XRCE-DDS Agent over an emulated UART. Real Humble sources (UROS_MIRROR) and a built
agent (UROS_AGENT) are needed for the runs; without them those tests skip, and CI runs only the
checks that need neither."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import filelock
import pytest
from uros_helpers import Background, humble_mirror_args, run_uros, run_uros_here

from uros_build.run import stages

pytestmark = pytest.mark.integration

MIRROR = os.environ.get("UROS_MIRROR")
AGENT = os.environ.get("UROS_AGENT")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
_RUNS = pytest.mark.skipif(
    not (MIRROR and AGENT and shutil.which("qemu-system-arm")),
    reason="set UROS_MIRROR (upstream clones) and UROS_AGENT (a MicroXRCEAgent), and install qemu-system-arm",
)


# A built real Humble workspace (UROS_HUMBLE_WS, a copy of one such as /work/rt/ws: its cortex-m7
# output has example_interfaces): the stage tests probe it without rebuilding micro-ROS; the negative
# controls build other libraries in it (into tmp outputs, which rebuilds its colcon tree: a copy).
_BUILT = pytest.mark.skipif(
    not (
        HUMBLE_WS
        and AGENT
        and shutil.which("qemu-system-arm")
        and (Path(HUMBLE_WS) / "build" / "cortex-m7" / "build-info.json").is_file()
    ),
    reason="set UROS_HUMBLE_WS (a copy of a built humble workspace with a cortex-m7 output) and UROS_AGENT, "
    "and install qemu-system-arm",
)


def _stage(data: dict[str, object], name: str) -> dict[str, object]:
    stages = data["stages"]
    assert isinstance(stages, dict)
    stage = stages[name]
    assert isinstance(stage, dict)
    return stage


def _histories(input_history: int) -> tuple[str, str]:
    return (f"RMW_UXRCE_STREAM_HISTORY_INPUT={input_history}", "RMW_UXRCE_STREAM_HISTORY_OUTPUT=4")


STAGES = (
    "session",
    "samples",
    "limits",
    "fragmentation",
    "service",
    "parameters",
    "action",
    "time",
    "restart",
)


def _room(output: Path) -> dict[str, str]:
    """The parameters and action stages' results on a library: pass with their packages and room for
    their entities, else skip (tests/integration/test_probe_parameters.py proves both)."""
    packages = json.loads((output / "build-info.json").read_text())["packages"]
    config = (output / "include" / "rmw_microxrcedds_c" / "config.h").read_text()
    have = {m[1]: int(m[2]) for m in re.finditer(r"#define RMW_UXRCE_MAX_(\w+) (\d+)", config)}
    action = {"SERVICES": 3, "CLIENTS": 3, "PUBLISHERS": 2, "SUBSCRIPTIONS": 2, "GUARD_CONDITION": 1}
    return {
        "parameters": "pass" if "rclc_parameter" in packages and have["SERVICES"] >= 5 else "skip",
        "action": "pass"
        if "example_interfaces" in packages and all(have[k] >= n for k, n in action.items())
        else "skip",
    }


def _results(data: dict[str, object] | None) -> dict[str, str]:
    assert data is not None
    stages = data["stages"]
    assert isinstance(stages, dict)
    return {name: str(stage["result"]) for name, stage in stages.items()}


@pytest.fixture(scope="module")
def humble(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real Humble workspace (std_msgs and the core only: what the probe firmware uses)."""
    assert MIRROR
    fw = tmp_path_factory.mktemp("probe") / "fw"
    run_uros("create-firmware", "--distro", "humble", "-w", str(fw), *humble_mirror_args(MIRROR))
    return fw


def _probe(*args: str) -> tuple[int, str, dict[str, object] | None]:
    proc = run_uros("probe", "--json", *args, check=False)
    data = json.loads(proc.stdout) if proc.stdout.strip() else None
    return proc.returncode, proc.stderr, data


@_RUNS
@pytest.mark.parametrize(
    ("target", "machine"),
    [("cortex-m7", "mps2-an500"), ("cortex-m4f", "mps2-an386"), ("cortex-m3", "mps2-an385")],
)
def test_the_library_runs_against_the_agent(humble: Path, target: str, machine: str) -> None:
    run_uros("build", "--toolchain", target, "-w", str(humble), "--packages", "std_msgs")
    code, err, data = _probe("--toolchain", target, "-w", str(humble))
    assert code == 0, err
    assert data is not None and data["status"] == 0 and data["machine"] == machine
    assert data["limits"] == {"nodes": 1, "publishers": 1, "subscriptions": 1}  # generate_lib's preset
    # std_msgs only: no service type, and the stage says so rather than passing
    assert _results(data) == {
        **dict.fromkeys(STAGES, "pass"),
        "service": "skip",
        "parameters": "skip",
        "action": "skip",
    }
    assert "--packages example_interfaces" in str(_stage(data, "service")["detail"])
    assert float(data["seconds"]) < 10  # type: ignore[arg-type]
    assert "probe passed" in err
    assert "uros-probe: PASS" in Path(str(data["console_log"])).read_text()
    agent_log = Path(str(data["agent_log"])).read_text()
    assert ("session established" in agent_log and "create_datawriter" in agent_log.replace(" ", "_")) or (
        "datawriter created" in agent_log
    )


@_RUNS
def test_the_probe_creates_as_many_entities_as_the_meta_allows(humble: Path, tmp_path: Path) -> None:
    """Issue 17, item 2: what a colcon.meta really permits, seen at run time (and one more refused)."""
    out = tmp_path / "more"
    run_uros(
        "build", "--toolchain", "cortex-m7", "-w", str(humble), "--packages", "std_msgs", "--output", str(out),
        "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=3", "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2",
    )  # fmt: skip
    code, err, data = _probe(str(out))
    assert code == 0, err
    assert data is not None and data["limits"] == {"nodes": 2, "publishers": 3, "subscriptions": 1}
    assert "limits held: nodes 2, publishers 3, subscriptions 1 (one more of each refused)" in err


@_RUNS
def test_a_library_without_stream_framing_links_and_fails(humble: Path, tmp_path: Path) -> None:
    """The negative control: it links, so a link check passes; at run time it never reaches the agent."""
    out = tmp_path / "no-framing"
    run_uros(
        "build", "--toolchain", "cortex-m7", "-w", str(humble), "--packages", "std_msgs", "--output", str(out),
        "--set", "microxrcedds_client.UCLIENT_PROFILE_STREAM_FRAMING=OFF",
    )  # fmt: skip
    code, err, data = _probe(str(out), "--timeout", "60")
    assert code == 5, err
    assert "uros probe cortex-m7 (mps2-an500): no agent answered" in err
    assert data is not None and data["status"] == 2


@_RUNS
def test_no_agent_on_the_link_is_a_clear_error(humble: Path) -> None:
    run_uros("build", "--toolchain", "cortex-m7", "-w", str(humble), "--packages", "std_msgs")
    code, err, _ = _probe("--toolchain", "cortex-m7", "-w", str(humble), "--agent", "/bin/true")
    assert code == 5 and "no agent answered" in err
    code, err, _ = _probe(
        "--toolchain", "cortex-m7", "-w", str(humble), "--agent", "/bin/true", "--timeout", "3"
    )
    assert code == 5 and "timeout: the firmware did not finish" in err


def _probeable(m7_build: Path, dest: Path) -> Path:
    """A copy of the fixture workspace whose output's build-info.json lists the packages the probe
    firmware uses (run/stages.PACKAGES; the fixture's own are fx_*): a library uros would go on to
    probe, for the checks that come after that one. Returns the copy's output."""
    ws = dest / "ws"
    shutil.copytree(m7_build, ws, symlinks=True)
    info = ws / "build" / "cortex-m7" / "build-info.json"
    data = json.loads(info.read_text(encoding="utf-8"))
    data["packages"] = sorted({*data["packages"], *stages.PACKAGES})
    info.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return ws / "build" / "cortex-m7"


def test_a_library_without_what_the_probe_firmware_uses_is_named_before_building(m7_build: Path) -> None:
    """Issue 43: a library without rcl, rclc or std_msgs failed in the compiler (`rcl/rcl.h: No such
    file`); build-info.json's packages say so before anything runs, in one line with the fix."""
    out = m7_build / "build" / "cortex-m7"
    proc = run_uros_here("probe", str(out), check=False)
    assert proc.returncode == 2, proc.stderr
    line = _one_error(proc)
    assert (
        f"the library {out.resolve()} lacks microxrcedds_client, rcl, rclc, rcutils, rmw_microxrcedds, std_msgs"
        in line
    )
    assert f"uros build -w {m7_build.resolve()} --toolchain cortex-m7 --packages std_msgs" in proc.stderr
    assert not list((m7_build / ".uros").glob("probe/cortex-m7-*/build")), "nothing may be built"


def test_an_empty_freertos_is_refused_not_bare_metal(m7_build: Path) -> None:
    """Issue 43: `--freertos ''` probed bare metal without a word."""
    proc = run_uros_here("probe", str(m7_build / "build" / "cortex-m7"), "--freertos", "", check=False)
    assert proc.returncode == 2, proc.stderr
    assert "--freertos '': names no FreeRTOS-Kernel folder" in _one_error(proc)


def _as_nobody() -> list[str]:
    """The argv prefix that runs this Python as nobody: with CAP_DAC_READ_SEARCH kept where it can be
    (this venv may be in root's home), else without; skipped where neither runs."""
    base = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
    caps = ["--inh-caps=+dac_read_search", "--ambient-caps=+dac_read_search"]
    if shutil.which("setpriv") is None:
        pytest.skip("setpriv (util-linux) is not installed")
    for prefix in ([*base, *caps], base):
        if (
            subprocess.run(
                [*prefix, sys.executable, "-c", "import uros_build"], capture_output=True
            ).returncode
            == 0
        ):
            return prefix
    pytest.skip("this Python cannot run as nobody here")


def test_a_workspace_this_user_cannot_write_is_one_line(m7_build: Path) -> None:
    """Issue 43: a non-root user probing a root-owned workspace got an internal error (PermissionError
    on .uros/probe/locks). As root the test probes as nobody; otherwise the workspace's .uros is made
    read-only."""
    folder = Path(tempfile.mkdtemp(prefix="uros-perm-"))
    state = folder / "ws" / ".uros"
    try:
        folder.chmod(0o755)
        out = _probeable(m7_build, folder)
        state.mkdir(exist_ok=True)
        for root, dirs, files in os.walk(folder):  # readable by all, as a workspace usually is
            for name in dirs:
                (Path(root) / name).chmod(0o755)
            for name in files:
                (Path(root) / name).chmod((Path(root) / name).stat().st_mode | 0o444)
        argv = [sys.executable, "-m", "uros_build", "probe", str(out), "--agent", "/no/such/agent"]
        if os.geteuid() == 0:
            argv = [*_as_nobody(), *argv]
        else:
            for root, dirs, _ in os.walk(state):
                for name in dirs:
                    (Path(root) / name).chmod(0o555)
            state.chmod(0o555)
        proc = subprocess.run(argv, capture_output=True, text=True, env={**os.environ, "HOME": str(folder)})
        assert proc.returncode == 2, proc.stderr
        line = _one_error(proc)
        assert "uros probe: cannot write " in line and "Permission denied" in line, line
        assert "sudo" in proc.stderr or "chmod" in proc.stderr
    finally:
        if state.is_dir():
            state.chmod(0o755)
        for root, dirs, _ in os.walk(state):
            for name in dirs:
                (Path(root) / name).chmod(0o755)
        shutil.rmtree(folder, ignore_errors=True)


def test_without_an_agent_or_qemu_the_probe_says_what_to_install(m7_build: Path, tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "UROS_AGENT"}
    env["UROS_ROS2_VENV"] = str(tmp_path / "ros2")  # where `uros agent build` would have put one: none
    proc = run_uros("probe", str(_probeable(m7_build, tmp_path)), env=env, check=False)
    assert proc.returncode == 3, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and ("qemu-system-arm" in errors[0] or "no Micro XRCE-DDS Agent" in errors[0])
    assert "Traceback" not in proc.stderr


def _one_error(proc: subprocess.CompletedProcess[str]) -> str:
    assert "Traceback" not in proc.stderr, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


@pytest.mark.parametrize("timeout", ["0", "-1", "nan", "1e-09", "0.5"])
def test_a_timeout_that_is_no_time_is_refused(m7_build: Path, timeout: str) -> None:
    """Issue 34, item 7: `--timeout 0`/`-1` ran the firmware and then gave a false "the firmware
    did not finish" verdict about a good library; issue 43: `--timeout 1e-9` started QEMU."""
    proc = run_uros_here("probe", str(m7_build / "build" / "cortex-m7"), "--timeout", timeout, check=False)
    assert proc.returncode == 2, proc.stderr
    assert f"--timeout {timeout}: must be a number of seconds, at least 1" in _one_error(proc)


def test_an_output_and_a_toolchain_that_names_another_target_are_refused(m7_build: Path) -> None:
    """Issue 34, item 7: `uros probe OUTPUT --toolchain other` probed OUTPUT and ignored --toolchain."""
    out = m7_build / "build" / "cortex-m7"
    proc = run_uros_here("probe", str(out), "--toolchain", "cortex-m4", check=False)
    assert proc.returncode == 2, proc.stderr
    assert f"--toolchain cortex-m4: OUTPUT {out} is the output of cortex-m7, not cortex-m4" in _one_error(
        proc
    )


def test_a_second_probe_of_a_target_waits_for_the_first(m7_build: Path, tmp_path: Path) -> None:
    """Issue 34, item 7: two probes at once shared one work folder (one removed the other's
    firmware and console log) and blamed a good library. A probe holds a lock per target; the
    second waits and says for whom (here the first is this test, holding the lock; after it the
    second goes on, and stops at the agent it was given, which does not exist)."""
    out = _probeable(m7_build, tmp_path)
    lock = out.parents[1] / ".uros" / "probe" / "locks" / "cortex-m7" / ".lock"
    lock.parent.mkdir(parents=True, exist_ok=True)
    with filelock.FileLock(str(lock)):
        (lock.parent / ".lock.owner").write_text(f"{os.getpid()}\n")
        run = Background("probe", str(out), "--agent", "/no/such/agent")
        run.wait_for("waiting for another uros probe of cortex-m7")
        assert any(f"(pid {os.getpid()})" in line for line in run.lines)
        assert not any(line.startswith("error:") for line in run.lines)  # waiting, not failing
    assert run.end(60) == 3, "".join(run.lines)
    assert any(x.startswith("error:") and ("/no/such/agent" in x or "qemu" in x) for x in run.lines)


@_BUILT
def test_every_stage_passes_on_a_built_humble_library() -> None:
    """Issue 31, item 4: a service round trip, time sync, agent restart and fragmentation, each by
    name in --json and in the one-line verdict."""
    assert HUMBLE_WS
    output = Path(HUMBLE_WS) / "build" / "cortex-m7"
    code, err, data = _probe(str(output))
    assert code == 0, err
    assert data is not None and data["status"] == 0
    expected = {**dict.fromkeys(STAGES, "pass"), **_room(output)}
    assert _results(data) == expected
    assert "AddTwoInts answered 1001" in str(_stage(data, "service")["detail"])
    assert abs(float(str(_stage(data, "time")["seconds"]))) <= 1.0
    assert 0 < float(str(_stage(data, "restart")["seconds"])) < 10
    fragmentation = str(_stage(data, "fragmentation")["detail"])
    assert (
        "773 B (1.5 x MTU 512) came back whole" in fragmentation
        and "RMW_UXRCE_STREAM_HISTORY" in fragmentation
    )
    # 15 s before the parameters and action stages; they add 1-3 s (parameters 0.1-0.2 s of calls, the
    # entities made and destroyed), measured 12.7-17.2 s with both passing at a load of 14
    assert float(data["seconds"]) <= 20  # type: ignore[arg-type]
    line = next(x for x in err.splitlines() if "probe passed" in x)
    assert all(f"{name} {result}" in line for name, result in expected.items()), line
    restarted = Path(str(data["agent_log"])).with_name("agent-restarted.log").read_text()
    assert "session established" in restarted  # the firmware's new session, on the agent started again


@_BUILT
@pytest.mark.parametrize(
    ("options", "stage", "status", "named"),
    [
        # the stream histories named in both: an option one build set and the next leaves out stays in
        # the workspace's CMake cache (found here: the service control built after the fragmentation one
        # still had input streams of one MTU)
        (("RMW_UXRCE_MAX_SERVICES=0", *_histories(4)), "service", 7, "RMW_UXRCE_MAX_SERVICES=0"),
        # input streams of one MTU (496 B a sample): 1.5 x MTU cannot come back (the output's history
        # stays 4: with RMW_UXRCE_STREAM_HISTORY=1 not even a publisher is created)
        (_histories(1), "fragmentation", 11, "RMW_UXRCE_STREAM_HISTORY"),
    ],
)
def test_a_library_that_cannot_do_a_stage_fails_it_by_name(
    tmp_path: Path, options: tuple[str, ...], stage: str, status: int, named: str
) -> None:
    """The negative controls: the library links, the other stages pass, the one it cannot do fails by
    name, with the firmware's own exit status."""
    assert HUMBLE_WS
    out = tmp_path / stage
    sets = [x for option in options for x in ("--set", f"rmw_microxrcedds.{option}")]
    run_uros("build", "--toolchain", "cortex-m7", "-w", HUMBLE_WS, "--output", str(out), *sets)
    code, err, data = _probe(str(out))
    assert code == 5, err
    assert data is not None and data["status"] == status
    assert _results(data) == {**dict.fromkeys(STAGES, "pass"), **_room(out), stage: "fail"}
    error = _one_error(subprocess.CompletedProcess([], code, "", err))
    assert f"uros probe cortex-m7 (mps2-an500): stage {stage} failed: " in error and named in error, error
