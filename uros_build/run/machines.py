"""`uros probe`'s data and pure pieces: which QEMU machine runs a target's probe firmware
(meta/probe/machines.yaml), the QEMU and agent command lines, QEMU's pty announcement, and what
the firmware's exit status means. The probe's steps (uros_build/probesteps/) run them.

The firmware (templates/probe/: portable main.c and transport.c, plus per machine an architecture's
start-up and linker sections, a UART driver and the machine's numbers) ends through semihosting (Arm,
RISC-V or Xtensa's simcall), so QEMU's own exit status is main()'s return value: no console parsing
decides the verdict.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from uros_build import loader, resources
from uros_build.errors import ConfigError

QEMU_PROGRAMS = ("qemu-system-arm", "qemu-system-riscv32", "qemu-system-xtensa")
ARCHES = ("arm", "riscv", "xtensa")  # folders under templates/probe/
# the C library's shared board files (templates/probe/<folder>/): newlib's are in arm/ itself
LIBC_FILES = {"riscv": "picolibc", "xtensa": "picolibc"}
UARTS = ("cmsdk", "nrf51", "ns16550")  # templates/probe/uart/<name>.c
STARTUPS = ("unaligned-trap",)  # what a machine's start-up may do more (templates/probe/<arch>/board.c)
_NAME = re.compile(r"[a-z0-9][a-z0-9.-]*")
_ENV = re.compile(r"UROS_[A-Z0-9_]+")
_ARG = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.,=-]*|-[A-Za-z0-9-]+")
_SIZE = re.compile(r"(\d+)([KM]?)")


@dataclass(frozen=True)
class Region:
    origin: int
    length: int


NICS = ("lan9118",)  # the NIC models the probe drives over UDP (templates/probe/net/<model>.c)


@dataclass(frozen=True)
class Nic:
    """The board's Ethernet controller the probe drives over UDP (meta/probe/machines.yaml: nic)."""

    model: str  # QEMU's -net nic,model=
    base: int  # its registers' address


@dataclass(frozen=True)
class Board:
    """One QEMU machine as the probe firmware sees it (meta/probe/machines.yaml: boards)."""

    name: str
    qemu: str  # the QEMU program
    machine: str  # its -M
    cpu: str | None  # its -cpu, when the machine's default is not the core
    qemu_args: tuple[str, ...]
    arch: str  # templates/probe/<arch>/
    uart: str  # templates/probe/uart/<uart>.c
    link: int  # the UART the agent talks to
    console: int | None  # the firmware's text; None: through semihosting (one-UART machines)
    console_stdout: bool  # the semihosting console is QEMU's standard output (Xtensa's simcall)
    reg_shift: int
    clock_hz: int
    rom: Region
    ram: Region
    stack: int
    nic: Nic | None = None  # None: no NIC the probe drives (the serial link only)
    qemu_env: str = ""  # the environment variable naming a QEMU build with the core ("" : PATH's qemu)
    # QEMU starts paused (-S, its monitor on a socket) until the agent holds the link, then `cont`
    start_paused: bool = False


@dataclass(frozen=True)
class Machine:
    """A target's probe machine: the board, what its start-up does more, and what uros says of it."""

    target: str
    machine: str  # the QEMU -M
    board: Board
    startup: tuple[str, ...] = ()
    note: str = ""
    others: tuple[Machine, ...] = ()  # boards `uros probe --board` may choose instead
    chosen: bool = False  # one of another machine's others (`--board`)


def _size(data: Mapping[str, Any], key: str, where: str) -> int:
    value = data.get(key)
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    found = _SIZE.fullmatch(value) if isinstance(value, str) else None
    if found is None:
        raise ConfigError(f"{where}: {key}: {value!r} is not a number of bytes (e.g. 0x20000000, 4M, 64K)")
    return int(found.group(1)) << {"": 0, "K": 10, "M": 20}[found.group(2)]


def _region(data: Mapping[str, Any], key: str, where: str) -> Region:
    item = loader.mapping(data.get(key), f"{where}: {key}", {"origin", "length"}, ("origin", "length"))
    region = Region(_size(item, "origin", f"{where}: {key}"), _size(item, "length", f"{where}: {key}"))
    if region.length == 0 or region.origin + region.length > 1 << 32:
        raise ConfigError(f"{where}: {key}: {region.length} bytes at {region.origin:#x} do not fit 32 bits")
    return region


_BOARD_KEYS = {
    "qemu", "machine", "cpu", "qemu_args", "arch", "uart", "console", "link", "reg_shift", "clock_hz",
    "rom", "ram", "stack", "sources", "nic", "qemu_env", "start_paused",
}  # fmt: skip


def parse_board(name: str, entry: Any, where: str) -> Board:
    item = loader.mapping(entry, where, _BOARD_KEYS, ("qemu", "machine", "arch", "uart", "link", "clock_hz"))
    machine = loader.string(item, "machine", where)
    cpu = item.get("cpu")
    for key, value in (("machine", machine), ("cpu", cpu)):
        if value is not None and not (isinstance(value, str) and _NAME.fullmatch(value)):
            raise ConfigError(f"{where}: {key}: {value!r} is not a QEMU {key} name")
    args = loader.string_list(item, "qemu_args", where)
    for arg in args:
        if not _ARG.fullmatch(arg):
            raise ConfigError(f"{where}: qemu_args: {arg!r} is not a plain QEMU argument")
    console = item.get("console")
    # QEMU 7.2's Xtensa simcall writes fd 1 to its own standard output, whatever -semihosting-config
    # chardev= says (measured): the session reads the console from QEMU's output then
    console_stdout = console == "stdout"
    if console_stdout:
        console = None
    rom, ram = _region(item, "rom", where), _region(item, "ram", where)
    stack = _size(item, "stack", where)
    if not 0 < stack < ram.length:
        raise ConfigError(f"{where}: stack: {stack} bytes do not fit the {ram.length} bytes of ram")
    if rom.origin < ram.origin + ram.length and ram.origin < rom.origin + rom.length:
        raise ConfigError(f"{where}: rom and ram overlap")
    clock = loader.integer(item, "clock_hz", where)
    if clock < 1000:
        raise ConfigError(f"{where}: clock_hz: {clock} is less than 1 kHz (the firmware counts milliseconds)")
    nic = None
    if item.get("nic") is not None:
        entry = loader.mapping(item.get("nic"), f"{where}: nic", {"model", "base"}, ("model", "base"))
        nic = Nic(loader.one_of(entry, "model", f"{where}: nic", NICS), _size(entry, "base", f"{where}: nic"))
    qemu_env = item.get("qemu_env", "")
    if not (isinstance(qemu_env, str) and (qemu_env == "" or _ENV.fullmatch(qemu_env))):
        raise ConfigError(
            f"{where}: qemu_env: {qemu_env!r} is not an environment variable name like UROS_X_QEMU"
        )
    return Board(
        start_paused=loader.boolean(item, "start_paused", where),
        qemu_env=qemu_env,
        nic=nic,
        name=name,
        qemu=loader.one_of(item, "qemu", where, QEMU_PROGRAMS),
        machine=machine,
        cpu=cpu,
        qemu_args=args,
        arch=loader.one_of(item, "arch", where, ARCHES),
        uart=loader.one_of(item, "uart", where, UARTS),
        link=_size(item, "link", where),
        console=None if console is None else _size(item, "console", where),
        console_stdout=console_stdout,
        reg_shift=loader.integer(item, "reg_shift", where, 0),
        clock_hz=clock,
        rom=rom,
        ram=ram,
        stack=stack,
    )


def parse_machines(data: Any, source: str) -> dict[str, Machine]:
    top = loader.mapping(data, source, {"boards", "machines"}, required=("boards", "machines"))
    boards = {
        str(name): parse_board(str(name), entry, f"{source}: boards.{name}")
        for name, entry in loader.mapping(top["boards"], f"{source}: boards").items()
    }
    table = loader.mapping(top["machines"], f"{source}: machines")
    out = {}
    for target, entry in table.items():
        where = f"{source}: machines.{target}"
        item = loader.mapping(entry, where, {"board", "startup", "note", "other_boards"}, required=("board",))
        others = loader.mapping(item.get("other_boards"), f"{where}: other_boards")
        alternatives = tuple(
            _other_board(str(target), str(name), other, boards, f"{where}: other_boards.{name}")
            for name, other in others.items()
        )
        out[str(target)] = _machine(str(target), loader.string(item, "board", where), item, boards, where)
        out[str(target)] = replace(out[str(target)], others=alternatives)
    return out


def _other_board(target: str, board: str, item: Any, boards: Mapping[str, Board], where: str) -> Machine:
    """One of a target's other boards (`--board NAME`): its startup and note only."""
    return replace(
        _machine(target, board, loader.mapping(item, where, {"startup", "note"}), boards, where), chosen=True
    )


def _machine(
    target: str, board: str, item: Mapping[str, Any], boards: Mapping[str, Board], where: str
) -> Machine:
    if board not in boards:
        raise ConfigError(f"{where}: board: {board!r} is not one of the boards ({', '.join(sorted(boards))})")
    startup = loader.string_list(item, "startup", where)
    for step in startup:
        if step not in STARTUPS:
            raise ConfigError(f"{where}: startup: {step!r} is not one of {', '.join(STARTUPS)}")
    note = item.get("note", "")
    if not isinstance(note, str):
        raise ConfigError(f"{where}: note: must be a string, got {note!r}")
    return Machine(target, boards[board].machine, boards[board], startup, note)


def load_machines() -> dict[str, Machine]:
    path = resources.meta_dir() / "probe" / "machines.yaml"
    return parse_machines(loader.load_yaml(path, str(path)), str(path))


def machine_for(target: str, machines: Mapping[str, Machine], board: str | None = None) -> Machine:
    """The target's machine, or (`--board NAME`) one of its other boards."""
    if target not in machines:
        raise ConfigError(
            f"uros probe: target {target} has no QEMU machine here (probed: {', '.join(sorted(machines))})",
            "meta/probe/machines.yaml names the targets QEMU can boot; test this target on its board",
        )
    machine = machines[target]
    if board is None or board == machine.board.name:
        return machine
    for other in machine.others:
        if other.board.name == board:
            return other
    boards = ", ".join([machine.board.name, *(o.board.name for o in machine.others)])
    raise ConfigError(
        f"--board {board}: {target} boots on {boards}", f"pass one of them: --board {machine.board.name}"
    )


def firmware_sources() -> Path:
    """The portable probe (main.c, transport.c, probe.h, CMakeLists.txt); board_files() adds a
    machine's start-up, UART and linker script."""
    return resources.templates_dir() / "probe"


def board_files(machine: Machine) -> dict[str, str]:
    """What a firmware's `board/` folder holds for `machine`: the architecture's start-up and linker
    sections, the UART model's driver, and the machine's numbers as a header and a MEMORY block
    (file name -> text; pure: the templates are read, nothing is written)."""
    board = machine.board
    probe = firmware_sources()
    files = {
        p.name: p.read_text(encoding="utf-8") for p in sorted((probe / board.arch).iterdir()) if p.is_file()
    }
    if board.arch in LIBC_FILES:
        libc = probe / LIBC_FILES[board.arch]
        files.update({p.name: p.read_text(encoding="utf-8") for p in sorted(libc.iterdir()) if p.is_file()})
    files[f"uart_{board.uart}.c"] = (probe / "uart" / f"{board.uart}.c").read_text(encoding="utf-8")
    files["probe_machine.h"] = machine_header(machine)
    files["probe.ld"] = memory_script(board)
    return files


def machine_header(machine: Machine) -> str:
    board = machine.board
    lines = [
        f"/* {board.name} for {machine.target}: generated by uros probe from meta/probe/machines.yaml. */",
        "#ifndef UROS_PROBE_MACHINE_H",
        "#define UROS_PROBE_MACHINE_H",
        f'#define PROBE_MACHINE "{board.machine}"',
        f"#define PROBE_CLOCK_HZ {board.clock_hz}u",
        f"#define PROBE_LINK_BASE {board.link:#010x}u",
        f"#define PROBE_UART_REG_SHIFT {board.reg_shift}",
    ]
    if board.console is None:
        lines.append("#define PROBE_CONSOLE_SEMIHOSTING 1")
    else:
        lines.append(f"#define PROBE_CONSOLE_BASE {board.console:#010x}u")
    if board.nic is not None:
        lines.append(f"#define PROBE_NIC_BASE {board.nic.base:#010x}u")
    lines += [f"#define PROBE_{step.upper().replace('-', '_')} 1" for step in machine.startup]
    return "\n".join([*lines, "#endif", ""])


def memory_script(board: Board) -> str:
    """The machine's MEMORY block; the architecture's sections.ld places the sections in it."""
    return (
        f"/* {board.name}: generated by uros probe from meta/probe/machines.yaml. */\n"
        "MEMORY {\n"
        f"  ROM (rx) : ORIGIN = {board.rom.origin:#010x}, LENGTH = {board.rom.length:#x}\n"
        f"  RAM (rwx) : ORIGIN = {board.ram.origin:#010x}, LENGTH = {board.ram.length:#x}\n"
        "}\n"
        f"probe_stack_size = {board.stack:#x};\n"
        "INCLUDE sections.ld\n"
    )


def qemu_argv(
    machine: Machine, elf: Path, console_log: Path, pcap: Path | None = None, monitor: Path | None = None
) -> list[str]:
    """The link UART on a new pseudo-terminal (the agent's end), the console to a file (a second UART,
    or semihosting's console on one-UART machines), and semihosting so that the firmware's exit
    status is QEMU's. ``pcap``: the probe over UDP, the board's NIC on QEMU's user network (no root;
    the guest reaches the host's loopback at 10.0.2.2) with its frames recorded in that file.
    ``monitor``: on a board that starts paused, the Unix socket of QEMU's monitor (the session says
    `cont` there once the agent holds the link)."""
    board = machine.board
    if pcap is not None and board.nic is not None:
        net = [
            "-netdev", "user,id=n0",
            "-net", f"nic,model={board.nic.model},netdev=n0",
            "-object", f"filter-dump,id=f0,netdev=n0,file={pcap}",
        ]  # fmt: skip
        return [*qemu_argv(machine, elf, console_log)[:-2], *net, "-kernel", str(elf)]
    argv = [board.qemu, "-M", board.machine, *(["-cpu", board.cpu] if board.cpu else []), *board.qemu_args]
    if board.start_paused and monitor is not None:
        argv += ["-S", "-nographic", "-monitor", f"unix:{monitor},server=on,wait=off"]
    else:
        argv += ["-nographic", "-monitor", "none"]
    if board.console_stdout:
        argv += [
            "-semihosting-config", "enable=on,target=native",
            "-chardev", "pty,id=link",
            "-serial", "chardev:link",
        ]  # fmt: skip
    elif board.console is None:
        argv += [
            "-chardev", f"file,id=console,path={console_log}",
            "-semihosting-config", "enable=on,target=native,chardev=console",
            "-chardev", "pty,id=link",
            "-serial", "chardev:link",
        ]  # fmt: skip
    else:
        argv += [
            "-semihosting-config", "enable=on,target=native",
            "-serial", f"file:{console_log}",
            "-chardev", "pty,id=link",
            "-serial", "chardev:link",
        ]  # fmt: skip
    return [*argv, "-kernel", str(elf)]


_RAM_OVERFLOW = re.compile(r"region `RAM' overflowed by (\d+) bytes")


def ram_overflow(link_output: str) -> int | None:
    """By how many bytes the linker found the firmware's RAM region too small, or None."""
    found = _RAM_OVERFLOW.search(link_output)
    return int(found.group(1)) if found else None


def qemu_hint(program: str, board: Board | None = None) -> str:
    """How to install a QEMU program on Debian (riscv32 and xtensa come in qemu-system-misc), or
    for a board whose core no packaged QEMU has, how to build one and name it."""
    if board is not None and board.qemu_env:
        return (
            f"set {board.qemu_env} to a {program} with the {board.cpu} CPU "
            f"(bash tests/esp32s3-qemu-env.sh DIR builds one: docs/esp32.md)"
        )
    package = "qemu-system-arm" if program == "qemu-system-arm" else "qemu-system-misc"
    return f"install {program} (Debian: apt-get install {package})"


def agent_argv(agent: str, pty: str, middleware: str = "dds") -> list[str]:
    """The Micro XRCE-DDS Agent on the firmware's serial link; -v6 logs every message in hex. `-m`
    names the middleware, dds (Fast DDS, the agent's default) or ced (no network)."""
    return [agent, "serial", "--dev", pty, "-b", "115200", "-m", middleware, "-v6"]


def agent_udp_argv(agent: str, port: int, middleware: str = "dds") -> list[str]:
    """The Micro XRCE-DDS Agent on UDP over IPv4 (`udp4 -p PORT`), for the probe over UDP."""
    return [agent, "udp4", "-p", str(port), "-m", middleware, "-v6"]


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
    7: "stage service failed",
    8: "stage time failed",
    9: "two tasks publishing at once lost or tore samples (FreeRTOS: a library without "
    "microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD=ON must not be called from two tasks)",
    10: "stage restart failed",
    11: "stage fragmentation failed",
    12: "stage parameters failed",
    13: "stage action failed",
    14: "stage best_effort failed",
    70: "the firmware crashed (hard fault)",
    71: "an unaligned access did not trap: the machine does not check ARMv6-M's alignment (CCR.UNALIGN_TRP)",
    72: "a FreeRTOS task overflowed its stack",
    73: "a FreeRTOS assertion failed (see the console)",
    74: "FreeRTOS did not start (allocator, task or scheduler: see the console)",
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
