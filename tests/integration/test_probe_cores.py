"""`uros probe` on every core QEMU runs here (issue 32, item 3): a real Humble std_msgs library per
target, booted on its machine from meta/probe/machines.yaml (Cortex-M33 on mps2-an505 in Secure state,
Cortex-M55 on mps3-an547, ARMv6-M code on an M3 that traps unaligned accesses, RV32IMC on RISC-V virt,
the ESP8266's lx106 on Xtensa lx60), talks to a real Micro XRCE-DDS Agent. Needs UROS_MIRROR (upstream
clones) and UROS_AGENT (a MicroXRCEAgent), and the machine's QEMU program; UROS_HUMBLE_WS names an
already-built Humble workspace (a copy of one) so that only the target's library is built. Without
them each test skips."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from uros_helpers import humble_mirror_args, run_uros

from uros_build.run import machines

pytestmark = pytest.mark.integration

MIRROR = os.environ.get("UROS_MIRROR")
AGENT = os.environ.get("UROS_AGENT")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")


@pytest.fixture(scope="module")
def humble(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not (MIRROR and AGENT):
        pytest.skip("set UROS_MIRROR (upstream clones) and UROS_AGENT (a MicroXRCEAgent)")
    if HUMBLE_WS:
        return Path(HUMBLE_WS)
    fw = tmp_path_factory.mktemp("cores") / "fw"
    run_uros("create-firmware", "--distro", "humble", "-w", str(fw), *humble_mirror_args(MIRROR))
    return fw


def _needs(target: str) -> machines.Machine:
    machine = machines.machine_for(target, machines.load_machines())
    if not shutil.which(machine.board.qemu):
        pytest.skip(f"{machine.board.qemu} is not installed")
    return machine


def _probe(ws: Path, target: str, *more: str) -> tuple[int, str, dict[str, object]]:
    run_uros("build", "--toolchain", target, "-w", str(ws), "--packages", "std_msgs", *more)
    proc = run_uros("probe", "--json", "--toolchain", target, "-w", str(ws), check=False)
    assert proc.stdout.strip(), proc.stderr
    return proc.returncode, proc.stderr, json.loads(proc.stdout)


@pytest.mark.parametrize(
    ("target", "machine"),
    [
        ("cortex-m33", "mps2-an505"),
        ("cortex-m55", "mps3-an547"),
        ("cortex-m0plus", "mps2-an385"),
    ],
)
def test_the_probe_passes_on_the_core(humble: Path, target: str, machine: str) -> None:
    assert _needs(target).machine == machine
    code, err, data = _probe(humble, target)
    assert code == 0, err
    assert data["status"] == 0 and data["machine"] == machine
    assert data["limits"] == {"nodes": 1, "publishers": 1, "subscriptions": 1}  # generate_lib's preset
    assert "probe passed" in err
    console = Path(str(data["console_log"])).read_text()
    assert "uros-probe: PASS" in console and "10 came back" in console
    if target == "cortex-m0plus":
        assert "M0+ code on an M3 core" in err  # said, not hidden
        # the start-up's own unaligned load trapped before main(): ARMv6-M's alignment faults hold
        assert console.index("unaligned access trapped") < console.index("uros-probe: boot")
