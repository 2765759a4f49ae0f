"""`uros probe`'s data and pure pieces: which QEMU machine runs a target's probe firmware
(meta/probe/machines.yaml), the QEMU and agent command lines, QEMU's pty announcement, and what
the firmware's exit status means. The command (commands/probe.py) runs them.

The firmware (templates/probe/) ends through Arm semihosting, so QEMU's own exit status is
main()'s return value: no console parsing decides the verdict.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import loader, resources
from uros_build.errors import ConfigError


@dataclass(frozen=True)
class Machine:
    target: str
    machine: str  # qemu-system-arm -M


def parse_machines(data: Any, source: str) -> dict[str, Machine]:
    top = loader.mapping(data, source, required=("machines",))
    table = loader.mapping(top["machines"], f"{source}: machines")
    out = {}
    for target, entry in table.items():
        where = f"{source}: machines.{target}"
        item = loader.mapping(entry, where, required=("machine",))
        machine = loader.string(item, "machine", where)
        if not re.fullmatch(r"[a-z0-9][a-z0-9.-]*", machine):
            raise ConfigError(f"{where}: machine: {machine!r} is not a QEMU machine name")
        out[str(target)] = Machine(str(target), machine)
    return out


def load_machines() -> dict[str, Machine]:
    path = resources.meta_dir() / "probe" / "machines.yaml"
    return parse_machines(loader.load_yaml(path, str(path)), str(path))


def machine_for(target: str, machines: Mapping[str, Machine]) -> Machine:
    if target not in machines:
        raise ConfigError(
            f"uros probe: target {target} has no QEMU machine here (probed: {', '.join(sorted(machines))})",
            "the probe boots Cortex-M3/M4/M7 firmware on QEMU's mps2 boards; test this target on its board",
        )
    return machines[target]


def firmware_sources() -> Path:
    return resources.templates_dir() / "probe"


def qemu_argv(machine: Machine, elf: Path, console_log: Path) -> list[str]:
    """UART0 to a file (the console), UART1 to a new pseudo-terminal (the agent's end), and
    semihosting so that the firmware's exit status is QEMU's."""
    return [
        "qemu-system-arm",
        "-M", machine.machine,
        "-nographic",
        "-monitor", "none",
        "-semihosting-config", "enable=on,target=native",
        "-serial", f"file:{console_log}",
        "-chardev", "pty,id=link",
        "-serial", "chardev:link",
        "-kernel", str(elf),
    ]  # fmt: skip


def agent_argv(agent: str, pty: str) -> list[str]:
    """The Micro XRCE-DDS Agent on the firmware's serial link; -v6 logs every message in hex."""
    return [agent, "serial", "--dev", pty, "-b", "115200", "-v6"]


_PTY = re.compile(r"char device redirected to (/dev/pts/\d+) \(label link\)")


def pty_of(qemu_output: str) -> str | None:
    """The pseudo-terminal QEMU opened for the link (it says so on stderr when it starts)."""
    found = _PTY.search(qemu_output)
    return found.group(1) if found else None


# main.c's exit statuses (templates/probe/main.c)
VERDICTS: Mapping[int, str] = {
    0: "pass",
    2: "no agent answered (is it running on the link? a library without the custom serial transport or "
    "stream framing never reaches it)",
    3: "no session: the agent answered, but the XRCE-DDS session could not be created",
    4: "an entity (node, publisher, subscription) could not be created: check RMW_UXRCE_MAX_* in colcon.meta",
    5: "samples lost: fewer came back through the agent than were published",
    6: "tearing down the entities failed",
    70: "the firmware crashed (hard fault)",
}


def verdict(status: int | None) -> str:
    if status is None:
        return "timeout: the firmware did not finish"
    return VERDICTS.get(status, f"the firmware exited with {status}")


_RESOURCES = re.compile(r"uros-probe: heap (\d+) B, stack (\d+) B")


def resources_used(console: str) -> tuple[int, int] | None:
    """(heap, stack) bytes the firmware reported using."""
    found = _RESOURCES.search(console)
    return (int(found.group(1)), int(found.group(2))) if found else None


_LIMIT = re.compile(r"uros-probe: limit (\w+) (-?\d+) (refused|unchecked)")


def limits_held(console: str) -> dict[str, tuple[int, bool]]:
    """kind -> (the library's RMW_UXRCE_MAX_* for it, whether one more was tried and refused): the
    firmware created that many of each and one more failed cleanly."""
    return {m.group(1): (int(m.group(2)), m.group(3) == "refused") for m in _LIMIT.finditer(console)}


def describe_limits(limits: Mapping[str, tuple[int, bool]]) -> str:
    if not limits:
        return ""
    parts = [
        f"{kind} {limit}" + ("" if refused else " (more not tried)")
        for kind, (limit, refused) in limits.items()
    ]
    return "limits held: " + ", ".join(parts) + " (one more of each refused)"
