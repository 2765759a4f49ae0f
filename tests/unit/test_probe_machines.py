"""meta/probe/machines.yaml (issue 32, item 3): the boards and the targets on them load into frozen
dataclasses and are checked on load; each machine's QEMU command line, its generated header and
memory map, and what `uros doctor` says of the QEMU programs."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from uros_build.commands import doctor
from uros_build.errors import ConfigError
from uros_build.run import machines

BOARD: dict[str, Any] = {
    "qemu": "qemu-system-arm",
    "machine": "mps2-an505",
    "arch": "arm",
    "uart": "cmsdk",
    "console": 0x50200000,
    "link": 0x50201000,
    "clock_hz": 20000000,
    "rom": {"origin": 0x10000000, "length": "4M"},
    "ram": {"origin": 0x38000000, "length": "2M"},
    "stack": "64K",
}
TABLE: dict[str, Any] = {"boards": {"an505": BOARD}, "machines": {"cortex-m33": {"board": "an505"}}}


def test_the_shipped_table() -> None:
    table = machines.load_machines()
    assert {t: m.machine for t, m in table.items()} == {
        "cortex-m7": "mps2-an500",
        "cortex-m7-sp": "mps2-an500",
        "cortex-m4f": "mps2-an386",
        "cortex-m4": "mps2-an386",
        "cortex-m3": "mps2-an385",
        "cortex-m33": "mps2-an505",
        "cortex-m55": "mps3-an547",
        "cortex-m0plus": "mps2-an385",
        "rv32imc": "virt",
        "rv32imac": "virt",
        "rv32imafc": "virt",
        "esp8266": "lx60-nommu",
        "esp32s3-bare": "lx60-nommu",
    }
    microbit = machines.machine_for("cortex-m0plus", table, "microbit")
    assert microbit.chosen and microbit.board.ram == machines.Region(0x20000000, 16 << 10)
    assert microbit.board.console is None and microbit.startup == ()  # a real M0 traps by itself
    m33 = table["cortex-m33"].board
    assert (m33.console, m33.link, m33.rom.origin, m33.ram.length) == (
        0x50200000,
        0x50201000,
        0x10000000,
        2 << 20,
    )
    assert table["cortex-m55"].board.console == 0x59303000
    m0plus = table["cortex-m0plus"]
    assert m0plus.startup == ("unaligned-trap",) and "M0+ code on an M3 core" in m0plus.note
    with pytest.raises(AttributeError):
        m0plus.note = "x"  # type: ignore[misc]


def test_every_machine_names_a_shipped_target_and_its_files_exist() -> None:
    from uros_build.target.profiles import shipped_profiles

    profiles = shipped_profiles()
    for target, machine in machines.load_machines().items():
        assert target in profiles, target
        files = machines.board_files(machine)
        assert {
            "board.c",
            "sections.ld",
            f"uart_{machine.board.uart}.c",
            "probe_machine.h",
            "probe.ld",
        } <= set(files)


def _broken(path: tuple[str, ...], value: Any) -> dict[str, Any]:
    data = copy.deepcopy(TABLE)
    at = data
    for key in path[:-1]:
        at = at[key]
    if value is None:
        del at[path[-1]]
    else:
        at[path[-1]] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (("boards",), None, "boards: is required"),
        (("boards", "an505", "machine"), "mps2 an505; rm", "is not a QEMU machine name"),
        (("boards", "an505", "qemu"), "qemu-system-x86_64", "is not one of qemu-system-arm"),
        (("boards", "an505", "arch"), "mips", "arch: 'mips' is not one of"),
        (("boards", "an505", "uart"), "pl011", "uart: 'pl011' is not one of"),
        (("boards", "an505", "link"), "UART1", "is not a number of bytes"),
        (("boards", "an505", "rom"), {"origin": 0xFFFF0000, "length": "1M"}, "do not fit 32 bits"),
        (("boards", "an505", "ram"), {"origin": 0x10100000, "length": "1M"}, "rom and ram overlap"),
        (("boards", "an505", "stack"), "4M", "do not fit the"),
        (("boards", "an505", "clock_hz"), 100, "less than 1 kHz"),
        (("boards", "an505", "qemu_args"), ["-bios", "none;rm"], "not a plain QEMU argument"),
        (("boards", "an505", "qemu_env"), "PATH", "not an environment variable name like UROS_X_QEMU"),
        (("boards", "an505", "qemu_env"), "UROS_Q; rm", "not an environment variable name"),
        (("boards", "an505", "start_paused"), "yes", "start_paused: must be true or false"),
        (("boards", "an505", "colour"), "red", "colour: unknown key"),
        (("machines", "cortex-m33", "board"), "an521", "'an521' is not one of the boards"),
        (("machines", "cortex-m33", "startup"), ["turbo"], "'turbo' is not one of unaligned-trap"),
        (("machines", "cortex-m33", "other_boards"), {"an521": {}}, "other_boards.an521: board: 'an521'"),
        (("machines", "cortex-m33", "other_boards"), {"an505": {"board": "x"}}, "board: unknown key"),
    ],
)
def test_a_bad_table_is_refused_in_one_line(path: tuple[str, ...], value: Any, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as caught:
        machines.parse_machines(_broken(path, value), "machines.yaml")
    assert "machines.yaml" in caught.value.message and "\n" not in caught.value.message


def test_another_board_is_chosen_by_name_or_refused() -> None:
    table = machines.load_machines()
    assert machines.machine_for("cortex-m0plus", table, "mps2-an385") is table["cortex-m0plus"]
    with pytest.raises(ConfigError, match="--board lx60: cortex-m0plus boots on mps2-an385, microbit"):
        machines.machine_for("cortex-m0plus", table, "lx60")


def test_a_firmware_too_big_for_the_ram_is_measured() -> None:
    line = "ld: region `RAM' overflowed by 408 bytes\ncollect2: error: ld returned 1 exit status"
    assert machines.ram_overflow(line) == 408
    assert machines.ram_overflow("collect2: error: ld returned 1 exit status") is None


def test_the_argv_of_a_two_uart_machine() -> None:
    m33 = machines.parse_machines(TABLE, "t")["cortex-m33"]
    argv = machines.qemu_argv(m33, Path("/w/fw.elf"), Path("/w/console.log"))
    assert argv == [
        "qemu-system-arm", "-M", "mps2-an505", "-nographic", "-monitor", "none",
        "-semihosting-config", "enable=on,target=native",
        "-serial", "file:/w/console.log", "-chardev", "pty,id=link", "-serial", "chardev:link",
        "-kernel", "/w/fw.elf",
    ]  # fmt: skip


def test_the_argv_of_every_shipped_machine() -> None:
    for target, machine in machines.load_machines().items():
        argv = machines.qemu_argv(machine, Path("/w/fw.elf"), Path("/w/console.log"))
        assert argv[:3] == [machine.board.qemu, "-M", machine.machine], target
        assert argv[-2:] == ["-kernel", "/w/fw.elf"] and "pty,id=link" in argv, target
        # the link is the last -serial: the agent's end
        assert argv[len(argv) - 1 - argv[::-1].index("-serial") + 1] == "chardev:link", target


def test_the_argv_of_a_one_uart_machine() -> None:
    """The microbit's only UART is the agent's link: the console goes through semihosting's chardev."""
    microbit = machines.machine_for("cortex-m0plus", machines.load_machines(), "microbit")
    argv = machines.qemu_argv(microbit, Path("/w/fw.elf"), Path("/w/console.log"))
    assert argv == [
        "qemu-system-arm", "-M", "microbit", "-nographic", "-monitor", "none",
        "-chardev", "file,id=console,path=/w/console.log",
        "-semihosting-config", "enable=on,target=native,chardev=console",
        "-chardev", "pty,id=link", "-serial", "chardev:link",
        "-kernel", "/w/fw.elf",
    ]  # fmt: skip
    assert "#define PROBE_CONSOLE_SEMIHOSTING 1" in machines.machine_header(microbit)


def test_the_argv_of_the_xtensa_machine() -> None:
    """QEMU 7.2's simcall writes the console to QEMU's standard output: no console chardev."""
    lx60 = machines.load_machines()["esp8266"]
    assert lx60.board.console_stdout and lx60.board.console is None
    argv = machines.qemu_argv(lx60, Path("/w/fw.elf"), Path("/w/console.log"))
    assert argv == [
        "qemu-system-xtensa", "-M", "lx60-nommu", "-cpu", "lx106", "-nographic", "-monitor", "none",
        "-semihosting-config", "enable=on,target=native",
        "-chardev", "pty,id=link", "-serial", "chardev:link",
        "-kernel", "/w/fw.elf",
    ]  # fmt: skip
    rv = machines.qemu_argv(machines.load_machines()["rv32imc"], Path("/w/fw.elf"), Path("/w/c.log"))
    assert rv[:5] == ["qemu-system-riscv32", "-M", "virt", "-bios", "none"]


def test_the_generated_header_and_memory_map() -> None:
    table = machines.parse_machines(_broken(("machines", "cortex-m33", "startup"), ["unaligned-trap"]), "t")
    header = machines.machine_header(table["cortex-m33"])
    assert "#define PROBE_CLOCK_HZ 20000000u" in header
    assert "#define PROBE_LINK_BASE 0x50201000u" in header
    assert "#define PROBE_CONSOLE_BASE 0x50200000u" in header
    assert "#define PROBE_UNALIGNED_TRAP 1" in header
    script = machines.memory_script(table["cortex-m33"].board)
    assert "ROM (rx) : ORIGIN = 0x10000000, LENGTH = 0x400000" in script
    assert "RAM (rwx) : ORIGIN = 0x38000000, LENGTH = 0x200000" in script
    assert "probe_stack_size = 0x10000;" in script and "INCLUDE sections.ld" in script


def test_doctor_says_which_qemu_runs_which_targets() -> None:
    table = machines.load_machines()
    qemus = {
        "qemu-system-arm": "/usr/bin/qemu-system-arm",
        "qemu-system-riscv32": None,
        "qemu-system-xtensa": None,
    }
    checks = doctor.eval_probe_tools(qemus, None, False, table)
    arm, riscv, xtensa, agent = checks
    assert arm.status == doctor.OK and "cortex-m33" in arm.detail and "cortex-m0plus" in arm.detail
    assert (
        riscv.status == doctor.SKIP
        and "cannot run rv32imac, rv32imafc, rv32imc" in riscv.detail
        and "qemu-system-misc" in riscv.fix
    )
    assert xtensa.status == doctor.SKIP and "cannot run esp8266" in xtensa.detail
    nothing = doctor.eval_probe_tools({"qemu-system-xtensa": "/usr/bin/qemu-system-xtensa"}, None, False, {})[
        0
    ]
    assert nothing.status == doctor.OK and "no target's probe runs on it yet" in nothing.detail
    arm = doctor.eval_probe_tools({"qemu-system-arm": None}, None, False, table)[0]
    assert (
        arm.status == doctor.SKIP
        and "cannot run cortex-m0plus" in arm.detail
        and "qemu-system-arm" in arm.fix
    )
    assert agent.status == doctor.SKIP
    checks = doctor.eval_probe_tools({}, "/a/MicroXRCEAgent", True, table)
    assert [c.status for c in checks] == [doctor.OK]
    assert doctor.eval_probe_tools({}, None, True, table)[0].status == doctor.WARN


def test_the_esp32s3_board_names_its_qemu_by_an_environment_variable() -> None:
    """No packaged QEMU has the S3 core: the board names the variable of the one built by
    tests/esp32s3-qemu-env.sh, and doctor counts it apart from PATH's qemu-system-xtensa."""
    table = machines.load_machines()
    s3 = table["esp32s3-bare"]
    board = s3.board
    assert (board.machine, board.cpu, board.qemu_env, board.clock_hz) == (
        "lx60-nommu",
        "esp32s3",
        "UROS_ESP32S3_QEMU",
        240_000_000,
    )
    assert (board.arch, board.uart, board.link, board.reg_shift, board.console_stdout) == (
        "xtensa",
        "ns16550",
        0x7D050020,
        2,
        True,
    )
    assert table["esp8266"].board.qemu_env == ""
    argv = machines.qemu_argv(s3, Path("/w/fw.elf"), Path("/w/console.log"))
    assert argv[:5] == ["qemu-system-xtensa", "-M", "lx60-nommu", "-cpu", "esp32s3"]
    assert "-S" not in argv and argv[argv.index("-monitor") + 1] == "none"  # no monitor socket: not paused
    paused = machines.qemu_argv(s3, Path("/w/fw.elf"), Path("/w/console.log"), None, Path("/t/monitor"))
    assert paused[5:9] == ["-S", "-nographic", "-monitor", "unix:/t/monitor,server=on,wait=off"]
    assert [a for a in paused if a not in {"-S", "unix:/t/monitor,server=on,wait=off", "none"}] == [
        a for a in argv if a != "none"
    ]
    # only the S3's board starts paused; every other board's command line is what it was
    assert board.start_paused and not any(
        m.board.start_paused for m in table.values() if m.board.name != "lx60-nommu-esp32s3"
    )
    lx106 = table["esp8266"]
    assert machines.qemu_argv(lx106, Path("/w/fw.elf"), Path("/w/c.log"), None, Path("/t/m")) == (
        machines.qemu_argv(lx106, Path("/w/fw.elf"), Path("/w/c.log"))
    )
    assert "UROS_ESP32S3_QEMU" in machines.qemu_hint(board.qemu, board)
    assert "qemu-system-misc" in machines.qemu_hint(board.qemu)
    assert "#define PROBE_CLOCK_HZ 240000000u" in machines.machine_header(s3)
    # PATH's qemu-system-xtensa runs the lx106 only; the S3 board is its own line
    xtensa = doctor.eval_probe_tools(
        {"qemu-system-xtensa": "/usr/bin/qemu-system-xtensa"}, None, False, table
    )[0]
    assert xtensa.detail.endswith("(uros probe runs: esp8266)")
    found = [
        doctor.BoardQemu("", False, False),
        doctor.BoardQemu("/q/qemu-system-xtensa", False, False),
        doctor.BoardQemu("/q/qemu-system-xtensa", True, False),
        doctor.BoardQemu("/q/qemu-system-xtensa", True, True),
    ]
    unset, missing, no_cpu, ok = (doctor.eval_board_qemu(s3, f) for f in found)
    assert unset.status == doctor.SKIP and "UROS_ESP32S3_QEMU unset" in unset.detail
    assert "tests/esp32s3-qemu-env.sh" in unset.fix
    assert missing.status == doctor.WARN and "no such program" in missing.detail
    assert no_cpu.status == doctor.WARN and "has no esp32s3 CPU" in no_cpu.detail
    assert ok.status == doctor.OK and "uros probe runs: esp32s3-bare" in ok.detail
    assert ok.name == "qemu-system-xtensa (esp32s3)"
