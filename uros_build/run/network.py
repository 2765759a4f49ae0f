"""The probe over UDP (docs/network.md): a library whose UDP transport was compiled against an IP
stack (build-info.json's ``ip_stack``, written by ``uros build --ip-stack lwip``) runs the probe's
stages through that stack on an emulated NIC: lwIP on FreeRTOS over the board's LAN9118
(templates/probe/net/), QEMU's user network (no root: the guest reaches the host's loopback at
10.0.2.2), the agent on ``udp4 -p PORT``, the board's frames in a pcap beside console.log.

Which lwIP tree, the firmware's configure definitions and folders, and what the console says of the
network. Pure: nothing here starts a process.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import resources
from uros_build.errors import ConfigError
from uros_build.output.buildinfo import IpStackInfo
from uros_build.run.machines import Machine
from uros_build.target.rtos import headers_digest

AGENT_IP = "10.0.2.2"  # QEMU's user network: the host's loopback as the guest sees it
BOARD_IP = "10.0.2.15"  # templates/probe/net/udp.c: a static address in QEMU's 10.0.2.0/24
NAMESPACE_PORT = 8888  # the agent's port inside the run's own network namespace (nothing else there)
PCAP = "board.pcap"


@dataclass(frozen=True)
class StackTree:
    """What the probe firmware compiles of a stack (templates/probe/net/<cmake>)."""

    label: str  # as the console says it
    files: tuple[str, ...]  # under its tree: what says the tree is complete
    define: str  # the firmware's configure definition naming the tree (UROS_<define>: a CMake variable)
    config: str  # the probe's own config folder (templates/probe/<config>)
    hint: str


STACKS = {
    "lwip": StackTree(
        "lwIP",
        ("src/core/init.c", "contrib/ports/freertos/sys_arch.c"),
        "LWIP_DIR",
        "lwip",
        "give an lwIP tree (git clone --branch STABLE-2_2_1_RELEASE https://github.com/lwip-tcpip/lwip) "
        "with $UROS_LWIP",
    ),
    "freertos-tcp": StackTree(
        "FreeRTOS+TCP",
        ("source/FreeRTOS_IP.c", "source/portable/BufferManagement/BufferAllocation_2.c"),
        "FREERTOS_TCP_DIR",
        "freertos-tcp",
        "give a FreeRTOS+TCP tree (git clone --branch V4.4.1 https://github.com/FreeRTOS/FreeRTOS-Plus-TCP) "
        "with $UROS_FREERTOS_TCP",
    ),
}


@dataclass(frozen=True)
class Network:
    tree: Path  # the stack's tree the firmware compiles
    library_config: Path | None  # the folder of the stack config the library was compiled with
    stack: str = "lwip"  # a key of STACKS

    @property
    def label(self) -> str:
        return STACKS[self.stack].label


def check_tree(stack: str, folder: Path, where: str) -> Path:
    facts = STACKS[stack]
    missing = [name for name in facts.files if not (folder / name).is_file()]
    if missing:
        raise ConfigError(f"{where} {folder}: not a {facts.label} tree (no {missing[0]})", facts.hint)
    return folder


def choose(
    stack: IpStackInfo | None, machine: Machine, rtos: bool, env: str | None, env_tcp: str | None = None
) -> Network | None:
    """The network the probe runs over, or None (the serial link): ``stack`` is build-info.json's
    ``ip_stack`` (None: the library has none). ``rtos``: the probe runs on FreeRTOS (a library with
    an IP stack was built for it); ``env``/``env_tcp``: $UROS_LWIP/$UROS_FREERTOS_TCP, used only
    where the library's own tree is gone."""
    if stack is None:
        return None
    if stack.name not in STACKS:
        raise ConfigError(
            f"uros probe: the library's IP stack is {stack.name!r}; the probe runs {', '.join(STACKS)}"
        )
    facts = STACKS[stack.name]
    if machine.board.nic is None:
        raise ConfigError(
            f"uros probe: the library talks UDP and QEMU {machine.machine} has no NIC the probe drives",
            "probe it on a board with a LAN9118 (meta/probe/machines.yaml: nic): --board mps2-an500 "
            "or mps2-an385",
        )
    if not rtos:
        raise ConfigError(
            f"uros probe: the library talks UDP through {facts.label}, whose sockets need FreeRTOS",
            "build it with --rtos freertos (docs/network.md), or probe with --freertos KERNEL",
        )
    recorded = Path(stack.dir)
    given = env if stack.name == "lwip" else env_tcp
    variable = "$UROS_LWIP" if stack.name == "lwip" else "$UROS_FREERTOS_TCP"
    if all((recorded / name).is_file() for name in facts.files):
        tree = recorded
    elif given:
        tree = check_tree(stack.name, Path(given).expanduser(), variable)
    else:
        raise ConfigError(f"uros probe: the library's {facts.label} tree {recorded} is gone", facts.hint)
    return Network(tree, Path(stack.config), stack.name)


def cmake_defines(network: Network | None, port: int) -> list[str]:
    """The probe firmware's configure definitions for UDP: lwIP's tree, the agent's port."""
    if network is None:
        return []
    return [
        f"-DUROS_{STACKS[network.stack].define}={network.tree}",
        f"-DUROS_PROBE_NET_DEFINES=UROS_PROBE_AGENT_PORT_NUMBER={port}",
    ]


def firmware_folders(network: Network | None) -> list[str]:
    """The probe sources' sub-folders the UDP firmware needs: the netif and transport, lwipopts.h."""
    return ["net", STACKS[network.stack].config] if network is not None else []


def default_address_note(cmake_options: Mapping[str, Mapping[str, str]], port: int) -> str | None:
    """What an app finds when it calls rclc_support_init without rmw_uros_options_set_udp_address:
    the library's RMW_UXRCE_DEFAULT_UDP_IP/_PORT (meta/options.yaml); a note when that is not where
    the probe runs the agent (10.0.2.2:PORT), None when it is."""
    options = cmake_options.get("rmw_microxrcedds", {})
    ip = options.get("RMW_UXRCE_DEFAULT_UDP_IP", "127.0.0.1")
    default_port = options.get("RMW_UXRCE_DEFAULT_UDP_PORT", "8888")
    if ip == AGENT_IP and default_port == str(port):
        return None
    return (
        f"the agent is at udp {AGENT_IP}:{port}; the library's default address is {ip}:{default_port} "
        "(RMW_UXRCE_DEFAULT_UDP_IP/_PORT): an app that does not call rmw_uros_options_set_udp_address "
        f"finds no agent there (build with --set rmw_microxrcedds.RMW_UXRCE_DEFAULT_UDP_IP={AGENT_IP}, "
        "or set the address in the app: seed 000 takes -D CONFIG_UROS_AGENT_IP=... "
        "-D CONFIG_UROS_AGENT_PORT=...)"
    )


def probe_config(stack: str = "lwip") -> Path:
    """The probe's own stack config (lwIP: lwipopts.h and arch/cc.h; FreeRTOS+TCP: FreeRTOSIPConfig.h):
    a library for the probe over UDP is built with --ip-stack-config this folder."""
    return resources.templates_dir() / "probe" / STACKS[stack].config


def _config_digest(folder: Path) -> str:
    """The config folder's headers and its arch/ headers (lwIP's cc.h), by content."""
    return headers_digest([("config", folder, ()), ("arch", folder / "arch", ())])


def config_differs(network: Network) -> str | None:
    """A warning when the library was compiled with another stack config than the probe's stack runs
    with: the socket calls' structures (sockaddr, timeval) must agree."""
    if network.library_config is None:
        return None
    theirs, ours = network.library_config, probe_config(network.stack)
    if not any(theirs.glob("*.h")):
        return f"the library's {network.label} config ({theirs}) is gone: the probe's own is used"
    if _config_digest(theirs) == _config_digest(ours):
        return None
    return (
        f"the library was compiled with the {network.label} config in {theirs}, the probe's runs with its "
        f"own ({ours}): they must agree on the socket API's options (IPv4/IPv6, timeouts, structures)"
    )


_UP = re.compile(
    r"uros-probe: network up in (\d+) ms: (lwIP|FreeRTOS\+TCP) on the LAN9118 \(([0-9a-f:]+)\), (\S+), "
    r"agent at udp (\S+)"
)


def network_up(console: str) -> tuple[int, str, str, str, str] | None:
    """(ms to bring the network up, the stack, the board's MAC, its address, the agent's address:port)."""
    found = _UP.search(console)
    return (int(found[1]), found[2], found[3], found[4], found[5]) if found else None


def describe_run(console: str, pcap: Path) -> str:
    """What the UDP run adds to the verdict: the network as the firmware brought it up, the pcap."""
    up = network_up(console)
    if up is None:
        return f"UDP: the firmware did not bring its network up; the board's frames: {pcap}"
    ms, label, mac, ip, agent = up
    size = f" ({pcap.stat().st_size:,} B)" if pcap.is_file() else ""
    return (
        f"UDP: {label} on the LAN9118 ({mac}), {ip} -> agent {agent}, up in {ms} ms; "
        f"the board's frames: {pcap}{size}"
    )
