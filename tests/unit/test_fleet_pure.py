"""`uros probe --instances N` (run/fleet.py), its pure parts: the checks of --instances and
--client-keys, what each board is told, the client keys read off the wire (serial frames, UDP in a
pcap), and the judgement of shared keys with its fix."""

from __future__ import annotations

import struct

import pytest

from uros_build.errors import ConfigError
from uros_build.run import fleet


def create_client(key: int, session: int = 0x81) -> bytes:
    """An XRCE message with one CREATE_CLIENT, as the client writes it (its header 4 bytes)."""
    payload = b"XRCE" + b"\x01\x00" + b"\x0f\x0f" + key.to_bytes(4, "big") + bytes([session, 0]) + b"\x00\x02"
    return bytes([session, 0x00, 0x00, 0x00, 0x00, 0x07]) + struct.pack("<H", len(payload)) + payload


def serial_frame(message: bytes) -> bytes:
    """The XRCE serial framing: flag, then source, destination, length, payload, CRC, escaped."""
    raw = bytes([0, 0]) + struct.pack("<H", len(message)) + message + b"\x12\x34"
    out = bytearray([0x7E])
    for byte in raw:
        out += bytes([0x7D, byte ^ 0x20]) if byte in (0x7E, 0x7D) else bytes([byte])
    return bytes(out)


def test_instances_from_one_to_the_limit() -> None:
    fleet.check_instances(1)
    fleet.check_instances(fleet.MAX_INSTANCES)
    for bad in (0, -1, fleet.MAX_INSTANCES + 1):
        with pytest.raises(ConfigError, match=f"--instances {bad}: must be 1 to {fleet.MAX_INSTANCES}"):
            fleet.check_instances(bad)


def test_client_keys_are_own_by_default_and_need_two_boards() -> None:
    assert fleet.check_keys(None, 1) == "own"
    assert fleet.check_keys("same", 2) == "same"
    with pytest.raises(ConfigError, match="must be one of own, same, drawn"):
        fleet.check_keys("random", 2)
    with pytest.raises(ConfigError, match="with --instances 2 or more"):
        fleet.check_keys("same", 1)


def test_only_arm_boards_are_told_who_they_are() -> None:
    fleet.check_board("arm", "mps2-an500")
    with pytest.raises(ConfigError, match="Arm semihosting"):
        fleet.check_board("riscv", "virt")


def test_each_board_its_own_id_the_same_one_or_none() -> None:
    own = fleet.uids(3, "own")
    assert len(set(own)) == 3
    assert fleet.uids(3, "same") == (own[0],) * 3
    assert fleet.uids(2, "drawn") == (None, None)


def test_the_board_is_told_on_its_semihosting_command_line() -> None:
    argv = ["qemu-system-arm", "-semihosting-config", "enable=on,target=native", "-kernel", "f.elf"]
    told = fleet.board_argv(argv, 3, 0x0B0A0D04)
    assert told[2] == "enable=on,target=native,arg=uros_probe,arg=uros-board=3,arg=uros-uid=0b0a0d04"
    assert fleet.board_argv(argv, 1, None)[2].endswith("arg=uros-board=1")
    assert argv[2] == "enable=on,target=native"  # the caller's list is left as it was


def test_one_agent_on_every_link() -> None:
    argv = fleet.agent_multiserial_argv("agent", ["/dev/pts/3", "/dev/pts/4"], "dds")
    assert argv[:4] == ["agent", "multiserial", "--devs", "/dev/pts/3 /dev/pts/4"]


def test_the_key_of_a_create_client_in_a_serial_frame_with_escapes() -> None:
    key = 0x7E7D0102  # two bytes the framing escapes
    message = fleet.unframe(serial_frame(create_client(key)))
    assert message == create_client(key)
    assert fleet.client_keys(message) == [key]
    assert fleet.unframe(serial_frame(create_client(key))[:9]) is None  # cut short


def test_no_key_in_other_messages() -> None:
    ping = bytes([0x80, 0, 0, 0, 0x0D, 0x07]) + struct.pack("<H", 8) + bytes(8)  # GET_INFO
    assert fleet.client_keys(ping) == []
    assert fleet.client_keys(b"") == []
    with_key = bytes([0x01, 0, 0, 0]) + (0x11223344).to_bytes(4, "big") + create_client(5)[4:]
    assert fleet.client_keys(with_key) == [5]  # a session id under 0x80: an 8-byte header


def _udp_record(payload: bytes, port: int) -> bytes:
    udp = struct.pack(">HHHH", 40000, port, 8 + len(payload), 0) + payload
    ip = bytes([0x45, 0]) + struct.pack(">H", 20 + len(udp)) + bytes(5) + bytes([17]) + bytes(10)
    frame = bytes(12) + b"\x08\x00" + ip + udp
    return struct.pack("<IIII", 0, 0, len(frame), len(frame)) + frame


def test_the_keys_a_board_sent_over_udp_from_its_pcap() -> None:
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
    arp = bytes(12) + b"\x08\x06" + bytes(28)
    data = (
        header
        + _udp_record(create_client(0xAABBCCDD), 8888)
        + struct.pack("<IIII", 0, 0, len(arp), len(arp))
        + arp
        + _udp_record(create_client(0x01020304), 7400)  # not the agent's port
    )
    payloads = fleet.pcap_payloads(data, 8888)
    assert [k for p in payloads for k in fleet.client_keys(p)] == [0xAABBCCDD]
    assert fleet.pcap_payloads(b"", 8888) == []


def test_boards_that_shared_a_key_fail_by_name_with_the_fix() -> None:
    sent = {0: (0x10, 0x10), 1: (0x10,), 2: (0x20,)}
    assert fleet.shared_keys(sent) == {0x10: (0, 1)}
    line = fleet.shared_line(sent)
    assert line is not None
    assert line.startswith("boards 0, 1 shared client key 0x00000010: the agent took them for one client")
    assert "rmw_uros_options_set_client_key" in line and "unique id" in line
    stage = fleet.key_stage(1, sent)
    assert (stage.name, stage.result) == ("client-key", "fail")
    assert "also board 0's" in stage.detail
    assert fleet.key_stage(2, sent).result == "pass"
    assert fleet.shared_line({0: (1,), 1: (2,)}) is None


def test_a_board_that_sent_no_key_fails_its_key_stage() -> None:
    stage = fleet.key_stage(0, {0: (), 1: (7,)})
    assert stage.result == "fail" and "no CREATE_CLIENT" in stage.detail


def test_the_agent_restarts_once_every_running_board_asked() -> None:
    assert not fleet.restart_due({}, [], 2, 0.0)
    assert not fleet.restart_due({0: 10.0}, [], 2, 11.0)
    assert fleet.restart_due({0: 10.0}, [1], 2, 11.0)  # the other board ended
    assert fleet.restart_due({0: 10.0, 1: 12.0}, [], 2, 12.0)
    assert fleet.restart_due({0: 10.0}, [], 2, 10.0 + fleet.RESTART_BARRIER + 1)
