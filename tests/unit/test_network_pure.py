"""The probe over UDP, its pure parts: the boards' NICs (meta/probe/machines.yaml), QEMU's and the
agent's argv, which lwIP tree the firmware compiles (run/network.py), the console's network line."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.output.buildinfo import IpStackInfo
from uros_build.run import machines, network


def _machine(board: str) -> machines.Machine:
    return machines.machine_for("cortex-m7", machines.load_machines(), board)


def _lwip(root: Path) -> Path:
    for name in ("src/core/init.c", "contrib/ports/freertos/sys_arch.c"):
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("/* stand-in */\n")
    return root


def test_the_mps2_boards_name_their_lan9118() -> None:
    boards = {m.board.name: m.board for m in machines.load_machines().values()}
    an500 = _machine("mps2-an500").board
    assert an500.nic == machines.Nic("lan9118", 0xA0000000)
    assert boards.get("mps2-an385") is None or boards["mps2-an385"].nic == machines.Nic("lan9118", 0x40200000)
    assert "#define PROBE_NIC_BASE 0xa0000000u" in machines.machine_header(_machine("mps2-an500"))


def test_an_unknown_nic_model_is_refused() -> None:
    entry = {
        "qemu": "qemu-system-arm", "machine": "m", "arch": "arm", "uart": "cmsdk", "link": 0x40005000,
        "clock_hz": 25000000, "rom": {"origin": 0, "length": "4M"}, "ram": {"origin": 0x20000000, "length": "4M"},
        "stack": "64K", "nic": {"model": "e1000", "base": 0x40200000},
    }  # fmt: skip
    with pytest.raises(ConfigError, match="e1000"):
        machines.parse_board("b", entry, "machines.yaml: boards.b")


def test_qemu_puts_the_nic_on_the_user_network_with_a_pcap(tmp_path: Path) -> None:
    machine = _machine("mps2-an500")
    plain = machines.qemu_argv(machine, Path("fw.elf"), tmp_path / "console.log")
    udp = machines.qemu_argv(machine, Path("fw.elf"), tmp_path / "console.log", tmp_path / "board.pcap")
    assert "-netdev" not in plain
    assert udp[-2:] == ["-kernel", "fw.elf"] and udp[: len(plain) - 2] == plain[:-2]
    assert "user,id=n0" in udp and "nic,model=lan9118,netdev=n0" in udp
    assert f"filter-dump,id=f0,netdev=n0,file={tmp_path / 'board.pcap'}" in udp
    assert machines.agent_udp_argv("A", 8888, "ced") == ["A", "udp4", "-p", "8888", "-m", "ced", "-v6"]


def _stack(tmp: Path) -> IpStackInfo:
    return IpStackInfo("lwip", str(_lwip(tmp / "lwip")), str(tmp / "cfg"), "LwIP", "0" * 64)


def test_a_library_without_an_ip_stack_runs_over_the_serial_link(tmp_path: Path) -> None:
    assert network.choose(None, _machine("mps2-an500"), True, None) is None
    assert network.cmake_defines(None, 8888) == [] and network.firmware_folders(None) == []


def test_a_udp_library_runs_over_its_lwip_on_freertos(tmp_path: Path) -> None:
    chosen = network.choose(_stack(tmp_path), _machine("mps2-an500"), True, None)
    assert chosen is not None and chosen.tree == tmp_path / "lwip"
    assert network.cmake_defines(chosen, 40000) == [
        f"-DUROS_LWIP_DIR={tmp_path / 'lwip'}",
        "-DUROS_PROBE_NET_DEFINES=UROS_PROBE_AGENT_PORT_NUMBER=40000",
    ]
    assert network.firmware_folders(chosen) == ["net", "lwip"]


def test_without_freertos_or_with_the_tree_gone_it_says_so(tmp_path: Path) -> None:
    stack = _stack(tmp_path)
    with pytest.raises(ConfigError, match="sockets need FreeRTOS"):
        network.choose(stack, _machine("mps2-an500"), False, None)
    gone = IpStackInfo("lwip", str(tmp_path / "gone"), str(tmp_path / "cfg"), "LwIP", "0" * 64)
    with pytest.raises(ConfigError, match=r"lwIP tree .* is gone"):
        network.choose(gone, _machine("mps2-an500"), True, None)
    found = network.choose(gone, _machine("mps2-an500"), True, str(tmp_path / "lwip"))
    assert found is not None and found.tree == tmp_path / "lwip"


def test_the_probe_s_own_lwip_config_is_shipped() -> None:
    folder = network.probe_config()
    assert (folder / "lwipopts.h").is_file() and (folder / "arch" / "cc.h").is_file()
    assert "#define LWIP_SO_RCVTIMEO 1" in (folder / "lwipopts.h").read_text()


def test_the_console_s_network_line_is_read(tmp_path: Path) -> None:
    text = (
        "uros-probe: boot\nuros-probe: network up in 3 ms: lwIP on the LAN9118 (52:54:00:12:34:56), "
        "10.0.2.15, agent at udp 10.0.2.2:8888\n"
    )
    assert network.network_up(text) == (3, "lwIP", "52:54:00:12:34:56", "10.0.2.15", "10.0.2.2:8888")
    assert "up in 3 ms" in network.describe_run(text, tmp_path / "board.pcap")
    assert "did not bring its network up" in network.describe_run("uros-probe: boot\n", tmp_path / "x.pcap")


def test_an_app_without_an_address_is_told_where_the_library_looks() -> None:
    note = network.default_address_note({}, 8888)
    assert note is not None and "127.0.0.1:8888" in note and "RMW_UXRCE_DEFAULT_UDP_IP=10.0.2.2" in note
    ours = {"rmw_microxrcedds": {"RMW_UXRCE_DEFAULT_UDP_IP": "10.0.2.2"}}
    assert network.default_address_note(ours, 8888) is None
    assert network.default_address_note(ours, 40000) is not None


def test_the_agent_s_port_fits_rmw_microxrcedds_s_four_digits() -> None:
    """rmw_uros_options_set_udp_address keeps MAX_PORT_LEN - 1 = 4 characters (53055 became 5305)."""
    from uros_build.run import session

    assert len(str(session.LARGEST_PORT)) == 4 and len(str(network.NAMESPACE_PORT)) <= 4
