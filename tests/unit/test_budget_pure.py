"""`uros size --ram/--flash`'s pure parts: sizes with units, the RAM symbols of nm's text, the options
ranked by the pools they size, the verdict's arithmetic, the probe report's reading, a profile's chip."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from profile_data import minimal_profile

from uros_build.commands.listings import options_table
from uros_build.errors import ConfigError
from uros_build.output import budget, sizes
from uros_build.output.sizes import Sizes
from uros_build.run.report import REPORT, Measured, map_name, measured
from uros_build.sources.options import known_options
from uros_build.target.memsize import parse_bytes, show_bytes
from uros_build.target.profiles import find_profile, parse_profile


@pytest.mark.parametrize(
    ("text", "number"),
    [
        ("264K", 264 * 1024),
        ("264kb", 264 * 1024),
        ("512KiB", 512 * 1024),
        ("2M", 2 * 1024 * 1024),
        ("2 MB", 2 * 1024 * 1024),
        ("65536", 65536),
        ("100B", 100),
        ("0", None),
        ("0K", None),
        ("12X", None),
        ("-1", None),
        ("1.5M", None),
        ("", None),
        ("2G", None),
    ],
)
def test_sizes_with_units_are_1024_based(text: str, number: int | None) -> None:
    assert parse_bytes(text) == number


def test_a_size_is_shown_as_a_datasheet_would() -> None:
    assert (
        show_bytes(270336) == "264 KB" and show_bytes(2 * 1024**2) == "2 MB" and show_bytes(1000) == "1,000 B"
    )


def test_a_bad_budget_is_one_line_naming_the_flag() -> None:
    assert budget.budget_value(None, "--ram") is None and budget.budget_value("16K", "--ram") == 16384
    with pytest.raises(ConfigError) as caught:
        budget.budget_value("64X", "--flash")
    assert caught.value.message.startswith("--flash 64X: not a size") and "\n" not in caught.value.message


# nm -g --format=posix of the real Humble library (cortex-m7, generate_lib's preset: MAX_HISTORY 4,
# MTU 512, one publisher), cut to the pools and a member with the same names undefined
NM = """\
libmicroros.a[librmw_microxrcedds__types.c.obj]:
custom_clients B 000001f8 c8
custom_publishers B 00000000 d8
custom_sessions B 0 15a8
custom_static_buffers B 0 2100
custom_init_options B 0 84
rmw_uxrce_init_service_memory T 00000001 2c
libmicroros.a[libmicroxrcedds_client__custom_transport.c.obj]:
custom_sessions U
custom_static_buffers U
"""


def test_ram_symbols_and_their_sizes_from_nm() -> None:
    found = budget.symbol_sizes(NM)
    assert found["custom_sessions"] == 5544 and found["custom_static_buffers"] == 8448
    assert "rmw_uxrce_init_service_memory" not in found  # code, not RAM


def test_the_options_that_cost_most_ram_come_first_with_the_values_in_force() -> None:
    built = {"rmw_microxrcedds": {"RMW_UXRCE_MAX_HISTORY": "4", "RMW_UXRCE_MAX_PUBLISHERS": "1"}}
    costs = budget.option_costs(known_options(), built, "custom", budget.symbol_sizes(NM))
    names = [(c.option, c.value, c.bytes) for c in costs]
    assert names[:4] == [
        ("UCLIENT_CUSTOM_TRANSPORT_MTU", "512", 5544 + 8448),  # upstream's default: not in the meta
        ("RMW_UXRCE_STREAM_HISTORY", "4", 5544 + 8448),  # equal bytes: by package, then name
        ("RMW_UXRCE_MAX_HISTORY", "4", 8448),
        ("RMW_UXRCE_MAX_SESSIONS", "1", 5544 + 132),  # the sessions and their init options
    ]
    assert ("RMW_UXRCE_MAX_PUBLISHERS", "1", 216) in names
    # the MTU of another transport sizes nothing in this library; an absent pool is not "free"
    assert not {"UCLIENT_UDP_TRANSPORT_MTU", "RMW_UXRCE_MAX_NODES"} & {c.option for c in costs}
    listed = {row["option"]: row for row in options_table()}  # `uros meta options --json`
    assert listed["RMW_UXRCE_MAX_HISTORY"]["pools"] == ["custom_static_buffers"]
    udp = budget.option_costs(known_options(), built, "udp", budget.symbol_sizes(NM))
    assert "UCLIENT_UDP_TRANSPORT_MTU" in {c.option for c in udp}


# the configured headers of a library built once with MTU 256, then without the --set (CMake's cache
# kept 256; its build-info.json's meta names no MTU), cut to the lines that matter
RMW_CONFIG = """\
#define RMW_UXRCE_TRANSPORT_CUSTOM
    #define RMW_UXRCE_MAX_TRANSPORT_MTU UXR_CONFIG_CUSTOM_TRANSPORT_MTU
#define RMW_UXRCE_STREAM_HISTORY_INPUT 4
#define RMW_UXRCE_MAX_HISTORY 1
#define RMW_UXRCE_MAX_OPTIONS RMW_UXRCE_MAX_SESSIONS*3
#define RMW_UXRCE_MAX_TOPICS -1
"""
UXR_CONFIG = "#define UXR_CONFIG_UDP_TRANSPORT_MTU                  512\n#define UXR_CONFIG_CUSTOM_TRANSPORT_MTU               256\n"


def test_the_value_in_force_is_the_librarys_own_header_first() -> None:
    rmw = budget.header_defines(RMW_CONFIG)
    assert rmw == {
        "RMW_UXRCE_STREAM_HISTORY_INPUT": "4",
        "RMW_UXRCE_MAX_HISTORY": "1",
        "RMW_UXRCE_MAX_TOPICS": "-1",
    }
    headers = {"rmw_microxrcedds_c/config.h": rmw, "uxr/client/config.h": budget.header_defines(UXR_CONFIG)}
    meta = {"rmw_microxrcedds": {"RMW_UXRCE_MAX_HISTORY": "4", "RMW_UXRCE_MAX_PUBLISHERS": "1"}}
    costs = {
        c.option: c
        for c in budget.option_costs(known_options(), meta, "custom", budget.symbol_sizes(NM), headers)
    }
    assert (
        costs["UCLIENT_CUSTOM_TRANSPORT_MTU"].value,
        costs["UCLIENT_CUSTOM_TRANSPORT_MTU"].value_from,
    ) == ("256", "header")
    assert (costs["RMW_UXRCE_MAX_HISTORY"].value, costs["RMW_UXRCE_MAX_HISTORY"].value_from) == (
        "1",
        "header",
    )
    assert (costs["RMW_UXRCE_MAX_PUBLISHERS"].value, costs["RMW_UXRCE_MAX_PUBLISHERS"].value_from) == (
        "1",
        "meta",
    )
    assert (costs["RMW_UXRCE_STREAM_HISTORY"].value, costs["RMW_UXRCE_STREAM_HISTORY"].value_from) == (
        "4",
        "default",
    )


def test_a_count_option_names_the_value_that_alone_would_fit() -> None:
    built = {"rmw_microxrcedds": {"RMW_UXRCE_MAX_HISTORY": "4", "RMW_UXRCE_MAX_PUBLISHERS": "1"}}
    costs = budget.option_costs(known_options(), built, "custom", budget.symbol_sizes(NM))
    by_name = {c.option: c for c in costs}
    assert by_name["RMW_UXRCE_MAX_HISTORY"].each == 2112  # 8,448 B over 4 elements
    assert by_name["UCLIENT_CUSTOM_TRANSPORT_MTU"].each is None  # sizes elements, not their number
    fit = {(c.option, value, frees) for c, value, frees in budget.values_that_fit(costs, 4947)}
    # 4,947 B over: three buffers fewer (6,336 B); one publisher slot (216 B) cannot go below one
    assert fit == {("RMW_UXRCE_MAX_HISTORY", 1, 3 * 2112)}
    assert budget.values_that_fit(costs, 2112) == [(by_name["RMW_UXRCE_MAX_HISTORY"], 3, 2112)]
    assert budget.values_that_fit(costs, 0) == []


def test_need_adds_the_library_the_rest_and_what_the_probe_measured() -> None:
    need = budget.Need(Sizes(40_000, 300, 16_000), Sizes(1000, 20, 80), heap=2920, stack=2112)
    assert need.static_ram == 300 + 16_000 + 20 + 80
    assert need.ram == need.static_ram + 2920 + 2112
    assert need.flash == 40_000 + 300 + 1000 + 20


def test_the_verdict_says_by_how_much() -> None:
    need = budget.Need(Sizes(40_000, 300, 16_000), heap=2920, stack=2112)  # RAM 21,332, flash 40,300
    fits, line = budget.verdict(need, 64 * 1024, 128 * 1024, None)
    assert fits and line == "fits: RAM 21,332 of 65,536 B (33%), flash 40,300 of 131,072 B (31%)"
    fits, line = budget.verdict(need, 16 * 1024, None, None)
    assert not fits
    assert line == (
        "does not fit: RAM needs 21,332 B: 4,948 B over 16 KB (16,384 B), flash 40,300 B (no budget: --flash N)"
    )
    assert budget.over_by(need, 16 * 1024, 32 * 1024) == {"ram": 4948, "flash": 40_300 - 32_768}
    static = budget.Need(Sizes(40_000, 300, 16_000))
    fits, line = budget.verdict(static, 20_000, None, "not measured: run uros probe")
    assert fits and line.endswith("(static RAM only; heap and stack not measured: run uros probe)")


AA, BB = "a" * 64, "b" * 64  # the sha256 of two libraries


def _report(**change: object) -> bytes:
    data = {"status": 0, "verdict": "pass", "heap_bytes": 2920, "stack_bytes": 2112, "library_sha256": AA}
    return json.dumps({**data, "map_sha256": "mm", **change}).encode()


def test_only_a_passed_probe_of_this_very_library_is_counted() -> None:
    work = Path("/ws/.uros/probe/cortex-m7-0123456789")
    assert measured(None, AA, None, work) == "not measured: run uros probe"
    assert measured(_report(), BB, "mm", work).startswith("not measured for this library")
    assert measured(_report(), None, "mm", work).startswith("not measured for this library")
    failed = measured(_report(status=3, verdict="no session", heap_bytes=None), AA, "mm", work)
    assert failed == "not measured: the last probe did not pass (no session; run uros probe)"
    assert measured(b"{cut", AA, None, work).startswith("not measured: the probe's report.json")
    got = measured(_report(), AA, "mm", work)
    assert got == Measured(2920, 2112, str(work / REPORT), str(work / map_name(None)))
    assert got.run == "uros probe, bare metal"
    # a map file another build replaced is not that run's: heap and stack still count, its map not
    assert measured(_report(), AA, "other", work) == Measured(2920, 2112, str(work / REPORT), None)
    # the probe's own judgement of every stage counts over the firmware's status: a time stage the
    # host failed (status 0) is no pass; the service stage skipped without root (status 7) is
    host_failed = measured(_report(passed=False, verdict="stage time failed: ..."), AA, "mm", work)
    assert host_failed == "not measured: the last probe did not pass (stage time failed: ...; run uros probe)"
    assert measured(_report(status=7, passed=True), AA, "mm", work) == got


@pytest.mark.parametrize(
    ("change", "why"),
    [
        ({"heap_bytes": -100000}, "has heap_bytes -100000, not a byte count"),
        ({"stack_bytes": True}, "has stack_bytes true, not a byte count"),
        ({"heap_bytes": 2.5}, "has heap_bytes 2.5, not a byte count"),
        ({"heap_bytes": 2**40}, "not a byte count"),
        ({"heap_bytes": "2920"}, 'has heap_bytes "2920", not a byte count'),
        ({"passed": "false"}, "did not pass"),
        ({"passed": 1}, "did not pass"),
        ({"status": False}, "did not pass"),
        ({"rtos": "freertos"}, "not measured on bare metal: the probe's report.json is of a run on FreeRTOS"),
        ({"verdict": "x\x1b[31m" * 50, "passed": False}, "did not pass (x?[31m"),
    ],
)
def test_a_report_is_typed_and_ranged(change: dict[str, object], why: str) -> None:
    """round 5: a negative heap gave negative RAM, true counted as 1 B, "false" as passed."""
    got = measured(_report(**change), AA, "mm", Path("/w"))
    assert isinstance(got, str) and why in got, got
    assert "\x1b" not in got


def test_a_report_that_is_no_report_is_not_measured() -> None:
    for raw, why in (
        (b"\xff\xfe{}", "is not UTF-8 text"),
        (b"[" * 100_000, "is not JSON"),
        (b"[1, 2]", "is not a report"),
        (b'{"heap_bytes": 1' + b"0" * 5000 + b"}", "is not JSON"),
    ):
        got = measured(raw, AA, None, Path("/w"))
        assert isinstance(got, str) and why in got, (raw[:20], got)
    # a FreeRTOS run is kept apart and counts only for the FreeRTOS variant
    freertos = measured(_report(rtos="freertos", machine="mps2-an500"), AA, "mm", Path("/w"), "freertos")
    assert isinstance(freertos, Measured) and freertos.report == "/w/report-freertos.json"
    assert freertos.run == "uros probe, FreeRTOS in QEMU mps2-an500"


def test_an_elf_is_a_linked_firmware_of_the_librarys_target() -> None:
    def head(machine: int, flags: int = 0x5000400, e_type: int = 2, cls: int = 1) -> bytes:
        ident = b"\x7fELF" + bytes([cls, 1, 1]) + bytes(9)
        rest = e_type.to_bytes(2, "little") + machine.to_bytes(2, "little") + bytes(16)
        return ident + rest + flags.to_bytes(4, "little") + bytes(24)

    assert sizes.elf_problem(head(40), "ARM", "ELF32", "hard") is None
    assert "an archive" in str(sizes.elf_problem(b"!<arch>\n" + bytes(60), "ARM"))
    assert "not an ELF file" in str(sizes.elf_problem(b"hello", "ARM"))
    assert "relocatable object" in str(sizes.elf_problem(head(40, e_type=1), "ARM"))
    assert "for RISC-V (ELF32), not for the library's ARM" in str(sizes.elf_problem(head(243), "ARM"))
    assert "soft-float" in str(sizes.elf_problem(head(40, flags=0x5000200), "ARM", "ELF32", "hard"))
    assert sizes.elf_problem(head(243, flags=1), "RISC-V", "ELF32", "soft") is None


def test_a_profile_names_its_chip_and_a_bad_size_names_the_key() -> None:
    rp2040 = find_profile("rp2040").chip
    assert (rp2040.name, rp2040.ram_bytes, rp2040.flash_bytes) == ("RP2040", 264 * 1024, 2 * 1024**2)
    assert not find_profile("cortex-m7").chip.known  # a core, many chips: no default
    with pytest.raises(ConfigError, match=r"board.yaml: chip.ram: '264 kilobytes' is not a size"):
        parse_profile({**minimal_profile(), "chip": {"name": "X", "ram": "264 kilobytes"}}, "board.yaml")
