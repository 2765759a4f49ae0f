"""The probe over UDP (issue 39 item 2): a library whose UDP transport was compiled against lwIP
(`uros build --transport udp --rtos freertos ... --ip-stack lwip ...`) runs every probe stage through
lwIP on the LAN9118 of QEMU's mps2-an500, QEMU's user network carrying the board's frames to an agent
on `udp4 -p PORT` (the board's frames kept in board.pcap); the seeds' apps run over it too.

Real Humble (UROS_HUMBLE_WS, a built Humble workspace, copied here; or UROS_MIRROR to create one), a
real FreeRTOS-Kernel (UROS_FREERTOS, V11.x), a real lwIP tree (UROS_LWIP, STABLE-2_2_1_RELEASE) and a
real Micro XRCE-DDS Agent (UROS_AGENT); without them every test skips. One library is built (the probe's
FreeRTOSConfig.h and lwipopts.h, 2 publishers and 2 subscriptions, the multithread profile, the agent's
address as the default one, which seed 001's app uses)."""

from __future__ import annotations

import json
import os
import shutil
import struct
from pathlib import Path

import pytest
from uros_helpers import humble_copy, run_uros

from uros_build.run import freertos, network

pytestmark = pytest.mark.integration

MIRROR = os.environ.get("UROS_MIRROR")
AGENT = os.environ.get("UROS_AGENT")
KERNEL = os.environ.get("UROS_FREERTOS")
LWIP = os.environ.get("UROS_LWIP")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
FREERTOS_TCP = os.environ.get("UROS_FREERTOS_TCP")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
_RUNS = pytest.mark.skipif(
    not ((MIRROR or HUMBLE_WS) and AGENT and KERNEL and LWIP and shutil.which("qemu-system-arm")),
    reason="set UROS_FREERTOS (a FreeRTOS-Kernel V11 checkout), UROS_LWIP (an lwIP STABLE-2_2_1 tree), "
    "UROS_AGENT (a MicroXRCEAgent) and UROS_HUMBLE_WS (a built Humble workspace) or UROS_MIRROR, and "
    "install qemu-system-arm",
)
# the seeds' agent address is the probe's fixed one in the run's own namespace: root only
_ROOT = pytest.mark.skipif(os.geteuid() != 0, reason="the agent's port is fixed only in a namespace (root)")


@pytest.fixture(scope="module")
def humble(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return humble_copy(tmp_path_factory.mktemp("probe-udp") / "fw", HUMBLE_WS, MIRROR)


@pytest.fixture(scope="module")
def udp_library(humble: Path) -> Path:
    return _build(humble, "lwip", str(LWIP))


def _build(fw: Path, stack: str, tree: str) -> Path:
    out = fw.parent / stack
    run_uros(
        "build", "--toolchain", "cortex-m7", "-w", str(fw), "-j", "2", "--output", str(out),
        "--packages", "std_msgs", "--packages", "example_interfaces",
        "--transport", "udp",
        "--rtos", "freertos", "--rtos-dir", str(KERNEL), "--rtos-config", str(freertos.probe_config().parent),
        "--ip-stack", stack, "--ip-stack-dir", tree, "--ip-stack-config", str(network.probe_config(stack)),
        "--set", "microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD=ON",
        "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=2",
        "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_SUBSCRIPTIONS=2",
        "--set", f"rmw_microxrcedds.RMW_UXRCE_DEFAULT_UDP_IP={network.AGENT_IP}",
    )  # fmt: skip
    return out


def _udp_frames(pcap: Path, port: int) -> int:
    """The IPv4 UDP frames to or from ``port`` in a pcap file (libpcap's format, Ethernet)."""
    data, offset, found = pcap.read_bytes(), 24, 0
    while offset + 16 <= len(data):
        length = struct.unpack("<I", data[offset + 8 : offset + 12])[0]
        frame = data[offset + 16 : offset + 16 + length]
        offset += 16 + length
        if frame[12:14] == b"\x08\x00" and frame[23] == 17:
            ihl = (frame[14] & 15) * 4
            ports = struct.unpack(">HH", frame[14 + ihl : 18 + ihl])
            found += port in ports
    return found


@_RUNS
def test_every_stage_runs_over_udp(udp_library: Path) -> None:
    _every_stage(udp_library, "lwIP")


@_RUNS
@pytest.mark.skipif(not FREERTOS_TCP, reason="set UROS_FREERTOS_TCP (a FreeRTOS-Plus-TCP V4.4 tree)")
def test_every_stage_runs_over_freertos_plus_tcp(humble: Path) -> None:
    assert FREERTOS_TCP
    _every_stage(_build(humble, "freertos-tcp", FREERTOS_TCP), "FreeRTOS+TCP")


def _every_stage(library: Path, label: str) -> None:
    proc = run_uros("probe", str(library), "--json", "--agent", str(AGENT), check=False)
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["passed"], proc.stderr
    stages = report["stages"]
    for name in ("session", "samples", "limits", "fragmentation", "service", "time", "restart", "two_tasks"):
        assert stages[name]["result"] == "pass", (name, stages[name])
    console = Path(report["console_log"]).read_text()
    assert f"{label} on the LAN9118" in console and "agent at udp 10.0.2.2:" in console
    agent_log = Path(report["agent_log"]).read_text()
    assert "UDPv4AgentLinux" in agent_log and "[==>> UDP <<==]" in agent_log
    pcap = Path(report["pcap"])
    port = int(console.split("agent at udp 10.0.2.2:")[1].split()[0])
    assert _udp_frames(pcap, port) > 100  # the session's every message went through the board's NIC
    assert f"UDP: {label} on the LAN9118" in proc.stderr


@_RUNS
@_ROOT
def test_seed_000_s_app_sets_the_agent_s_address_at_run_time(udp_library: Path) -> None:
    """examples/esp32s3-idf/app/app.c unchanged: menuconfig's CONFIG_UROS_AGENT_IP/PORT as -D."""
    proc = run_uros(
        "probe", str(udp_library), "--json", "--agent", str(AGENT), "--app", str(EXAMPLES / "esp32s3-idf" / "app"),
        "-D", "HSB_LOOPBACK", "-D", "HSB_EXIT_AFTER=2", "-D", "HSB_STATE_PERIOD_MS=200",
        "-D", f'CONFIG_UROS_AGENT_IP="{network.AGENT_IP}"', "-D", f'CONFIG_UROS_AGENT_PORT="{network.NAMESPACE_PORT}"',
        check=False,
    )  # fmt: skip
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["passed"], proc.stderr


@_RUNS
@_ROOT
def test_seed_001_s_app_finds_the_agent_at_the_library_s_default_address(udp_library: Path) -> None:
    proc = run_uros(
        "probe", str(udp_library), "--json", "--agent", str(AGENT), "--app", str(EXAMPLES / "stm32h7-custom"),
        check=False,
    )  # fmt: skip
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["passed"], proc.stderr


@_RUNS
def test_no_agent_on_the_port_fails_as_no_agent_answered(udp_library: Path) -> None:
    """A negative control: nothing answers on the agent's port (the agent program exits at once), so
    the firmware's pings over UDP go unanswered and the session stage fails by name."""
    true = shutil.which("true")
    assert true
    proc = run_uros("probe", str(udp_library), "--json", "--agent", true, "--timeout", "600", check=False)
    report = json.loads(proc.stdout)
    assert proc.returncode == 5 and not report["passed"]
    assert report["stages"]["session"]["result"] == "fail", report["stages"]
    assert "no agent answered" in report["stages"]["session"]["detail"]
    assert "stage session failed: no agent answered" in proc.stderr


@_RUNS
def test_two_boards_over_udp_on_one_agent_pass_with_their_own_keys(udp_library: Path) -> None:
    """Many boards on one agent (issue 40 item 3) over UDP: two QEMUs of one image, each its own user
    network, to one `udp4` agent; each board's client key read from the CREATE_CLIENT in its pcap."""
    proc = run_uros(
        "probe", str(udp_library), "--json", "--agent", str(AGENT), "--instances", "2", "--timeout", "600",
        check=False,
    )  # fmt: skip
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["passed"], proc.stderr
    assert report["transport"] == "udp4"
    keys = [board["client_keys"] for board in report["boards"]]
    assert all(len(k) == 1 for k in keys) and keys[0] != keys[1], keys
    for board in report["boards"]:
        assert board["stages"]["samples"]["result"] == "pass", board["stages"]
        assert board["stages"]["client-key"]["result"] == "pass"


@_RUNS
def test_reliable_samples_arrive_whole_over_udp_that_loses_one_datagram_in_ten(udp_library: Path) -> None:
    """--link over UDP (issue 40 item 4): the relay is a proxy on the firmware's port, the agent on
    another; the reliable stages pass at 10 % loss and 100-300 ms round trip, the best-effort loss is
    the relay's count, the reconnect does not flap."""
    plan = "loss=10%,delay=50-150,seed=8"
    proc = run_uros("probe", str(udp_library), "--json", "--agent", str(AGENT), "--link", plan, check=False)
    report = json.loads(proc.stdout)
    link = report["link"]
    assert link["transport"] == "udp"
    for way in ("board_to_agent", "agent_to_board"):
        assert link[way]["frames"] > 50 and 0 < link[way]["lost"] < link[way]["frames"] / 4, link
    _reliable_whole_and_loss_counted(report["stages"], link)
    assert "board to agent" in proc.stderr and "datagrams:" in proc.stderr


def _reliable_whole_and_loss_counted(stages: dict[str, dict[str, object]], link: dict[str, object]) -> None:
    for name in ("session", "samples", "fragmentation", "time", "restart"):  # reliable streams retransmit
        assert stages[name]["result"] == "pass", (name, stages[name])
    best = link["best_effort"]
    assert isinstance(best, dict) and 0 < best["reached_board"] <= best["agent_sent"] <= best["reached_agent"]
    assert best["reached_agent"] <= best["board_sent"] and best["board_sent"] >= 50, best
    assert stages["best_effort"]["result"] == "pass" and "(the relay's counts;" in str(
        stages["best_effort"]["detail"]
    )
    assert "one session after the restart (the relay's count)" in str(stages["restart"]["detail"])
    assert "time requests" in str(stages["time"]["detail"])
