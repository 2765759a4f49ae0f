"""MTU x history against the firmware's messages (issue 33, item 4), through the real CLI:
best-effort streams do not fragment and reliable ones carry only MTU x history
(micro-ROS-Agent#143, rmw_microxrcedds#247). `uros check LIB --for-firmware DIR` gives each message
type DIR uses its largest serialized size, from the library's own rosidl structs, and warns naming
the option and a value that fits."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fixture_ws import add_message_package
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def test_check_for_firmware_weighs_each_message_against_mtu_and_history(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    add_message_package(tmp_path)
    meta = tmp_path / "none.meta"
    meta.write_text('{"names": {}}\n', encoding="utf-8")
    firmware = tmp_path / "app"
    firmware.mkdir()
    (firmware / "main.c").write_text(
        "#include <fx_msgs/msg/small.h>\n#include <fx_msgs/msg/big.h>\n#include <fx_msgs/msg/text.h>\n"
        "// #include <fx_msgs/msg/bounded.h>: a comment is not a use\n"
        "void *ts(void) { return ROSIDL_GET_MSG_TYPE_SUPPORT(fx_msgs, msg, Huge); }\n",
        encoding="utf-8",
    )
    built = run_uros(
        "build", "--toolchain", "cortex-m7", "--workspace", str(tmp_path), "--meta", str(meta),
        "--for-firmware", str(firmware),
    )  # fmt: skip
    # the build summary: the warnings alone
    assert [line.split(":")[1].strip() for line in built.stderr.splitlines() if "fx_msgs/msg/" in line] == [
        "fx_msgs/msg/Big",
        "fx_msgs/msg/Huge",
    ]
    lib = str(tmp_path / "build" / "cortex-m7" / "libmicroros.a")
    checked = run_uros("check", lib, "--toolchain", "cortex-m7", "--for-firmware", str(firmware))
    lines = {line.split(":", 2)[1].strip() if line.startswith("warning:") else line.split(":")[0]: line
             for line in checked.stderr.splitlines() if "fx_msgs/msg/" in line}  # fmt: skip
    assert set(lines) == {"fx_msgs/msg/Small", "fx_msgs/msg/Big", "fx_msgs/msg/Text", "fx_msgs/msg/Huge"}
    assert "up to 4 bytes: fits one MTU (UCLIENT_CUSTOM_TRANSPORT_MTU=512)" in lines["fx_msgs/msg/Small"]
    big = lines["fx_msgs/msg/Big"]
    assert (
        big.startswith("warning: fx_msgs/msg/Big: up to 800 bytes")
        and "best-effort streams do not fragment" in big
    )
    assert "UCLIENT_CUSTOM_TRANSPORT_MTU=812" in big
    huge = lines["fx_msgs/msg/Huge"]
    assert huge.startswith("warning: fx_msgs/msg/Huge: up to 4096 bytes, more than even a reliable stream")
    assert "set RMW_UXRCE_STREAM_HISTORY=16 or UCLIENT_CUSTOM_TRANSPORT_MTU=1034" in huge
    assert lines["fx_msgs/msg/Text"].startswith("fx_msgs/msg/Text: unbounded (text)")

    report = json.loads(
        run_uros("check", lib, "--toolchain", "cortex-m7", "--for-firmware", str(firmware), "--json").stdout
    )
    assert {name: m["warning"] for name, m in report["messages"].items()} == {
        "fx_msgs/msg/Big": True,
        "fx_msgs/msg/Huge": True,
        "fx_msgs/msg/Small": False,
        "fx_msgs/msg/Text": False,
    }
