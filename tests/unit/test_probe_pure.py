"""uros probe's pure pieces: the machine table, QEMU's and the agent's command lines, QEMU's pty
line, the verdicts of the firmware's exit statuses, and the shipped firmware sources."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.probesteps import plan as probe_plan
from uros_build.run import machines as probe


def test_the_shipped_machine_table() -> None:
    machines = probe.load_machines()
    assert machines["cortex-m7"].machine == "mps2-an500"
    assert machines["cortex-m4f"].machine == "mps2-an386"
    assert machines["cortex-m3"].machine == "mps2-an385"
    assert "esp32s3" not in machines


def test_a_target_without_a_machine_says_so() -> None:
    with pytest.raises(ConfigError, match="target esp32s3 has no QEMU machine here"):
        probe.machine_for("esp32s3", probe.load_machines())


def test_the_agent_argv() -> None:
    assert probe.agent_argv("/a/MicroXRCEAgent", "/dev/pts/7") == [
        "/a/MicroXRCEAgent", "serial", "--dev", "/dev/pts/7", "-b", "115200", "-m", "dds", "-v6",
    ]  # fmt: skip
    assert probe.agent_argv("/a/MicroXRCEAgent", "/dev/pts/7", "ced")[-3:] == ["-m", "ced", "-v6"]


def test_the_pty_qemu_announces() -> None:
    text = "qemu-system-arm: -chardev pty,id=link: char device redirected to /dev/pts/12 (label link)\n"
    assert probe.pty_of(text) == "/dev/pts/12"
    assert probe.pty_of("nothing yet") is None


def test_verdicts_and_resources() -> None:
    assert probe.verdict(0) == "pass"
    assert probe.verdict(2).startswith("no agent answered")
    assert probe.verdict(None).startswith("timeout")
    assert probe.verdict(99) == "the firmware exited with 99"
    assert probe.resources_used("uros-probe: heap 2608 B, stack 2096 B\n") == (2608, 2096)
    assert probe.resources_used("") is None


def test_the_firmware_sources_ship_and_name_every_verdict() -> None:
    src = probe.firmware_sources()
    assert {p.name for p in src.iterdir()} >= {"CMakeLists.txt", "main.c", "transport.c", "probe.h"}
    # the FreeRTOS variant's statuses are its own files' (templates/probe/freertos/)
    assert {"stages.h", "stage_service.c", "stage_time.c", "stage_fragmentation.c", "stage_restart.c"} <= {
        p.name for p in src.iterdir()
    }
    # the stages' statuses are stages.h's; the FreeRTOS variant's its own files' (templates/probe/freertos/)
    main = "".join(p.read_text() for p in (src / "stages.h", *sorted((src / "freertos").glob("*.c"))))
    for status in probe.VERDICTS:
        if status not in (0, 70, 71):
            assert any(f in main for f in (f" = {status},", f"return {status};", f"_exit({status});")), status


def test_limits_from_the_console() -> None:
    text = "uros-probe: limit nodes 2 refused\nuros-probe: limit publishers 3 refused\nuros-probe: limit subscriptions 40 unchecked\n"
    limits = probe.limits_held(text)
    assert limits == {"nodes": (2, True), "publishers": (3, True), "subscriptions": (40, False)}
    line = probe.describe_limits(limits)
    assert line.startswith("limits held: nodes 2, publishers 3, subscriptions 40 (more not tried)")
    assert probe.describe_limits({}) == ""


@pytest.mark.parametrize("timeout", [0.0, -1.0, float("nan"), float("inf"), 1e-9, 0.999])
def test_a_timeout_is_some_seconds(timeout: float) -> None:
    """`--timeout 0`/`-1` gave a false "did not finish" verdict (issue 34, item 7); `1e-9` started
    QEMU for nothing (issue 43)."""
    with pytest.raises(ConfigError, match="must be a number of seconds, at least 1"):
        probe_plan.check_timeout(timeout)
    probe_plan.check_timeout(1.0)


def test_a_toolchain_beside_an_output_must_name_its_target() -> None:
    """`uros probe OUTPUT --toolchain other` ignored --toolchain (issue 34, item 7)."""
    out = Path("/ws/build/cortex-m7")
    probe_plan.check_toolchain_matches("cortex-m7", "cortex-m7", out, "cortex-m7")
    with pytest.raises(ConfigError, match=r"--toolchain cortex-m4: OUTPUT /ws/build/cortex-m7 is the output"):
        probe_plan.check_toolchain_matches("cortex-m4", "cortex-m4", out, "cortex-m7")
