"""Global symbols by member (output/symbols.py), over real nm text (LC_ALL=C).

``data/symbols-twins.nm.txt`` is GNU nm 2.40 ``-g --format=posix`` over libtwins.a, three objects
built with arm-none-eabi-gcc 12 -mcpu=cortex-m7 -O1: one.c and two.c both define twin_fn (T),
twin_data (D), twin_bss (B), twin_ro (R), a common twin_common (C) and a weak twin_weak (W); one.c
calls clock_gettime and provided_inside (which three.c defines); two.c calls strcpy,
uxr_write_serial_data_platform, something_unknown, a 64-bit __atomic_load_n (__atomic_load_8 on
an M7) and the weak reference maybe_there (w).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.output import symbols
from uros_build.output.symbols import Duplicate, NmSymbol

TWINS = (Path(__file__).parent / "data" / "symbols-twins.nm.txt").read_text(encoding="utf-8")


def test_parse_nm_names_each_symbols_member() -> None:
    found = symbols.parse_nm(TWINS, "libtwins.a")
    assert NmSymbol("one.c.obj", "clock_gettime", "U") in found
    assert NmSymbol("two.c.obj", "maybe_there", "w") in found
    assert NmSymbol("three.c.obj", "provided_inside", "T") in found
    assert len(found) == 22  # 9 + 12 + 1 lines


def test_parse_nm_headers_of_llvm_nm_and_of_paths_with_brackets_and_an_object_alone() -> None:
    text = "\nfirst.o:\nf T 0 4\n\n/tmp/odd [dir]/lib.a[second.o]:\ng D 0 4\n"
    assert symbols.parse_nm(text, "lib.a") == (NmSymbol("first.o", "f", "T"), NmSymbol("second.o", "g", "D"))
    # nm of one object prints no header: its symbols are the object's own
    assert symbols.parse_nm("provided_inside T 1 4\n", "three.c.obj") == (
        NmSymbol("three.c.obj", "provided_inside", "T"),
    )


def test_duplicates_are_the_strong_kinds_only() -> None:
    # T, D, B and R collide under --whole-archive; the common (C: merged by the linker) and the
    # weak definition (W: the linker keeps one) do not
    assert symbols.duplicate_globals(symbols.parse_nm(TWINS, "libtwins.a")) == tuple(
        Duplicate(name, ("one.c.obj", "two.c.obj"))
        for name in ("twin_bss", "twin_data", "twin_fn", "twin_ro")
    )


@pytest.mark.parametrize("kind", ["G", "S"])
def test_small_data_definitions_collide_too(kind: str) -> None:
    text = f"l.a[a.o]:\nx {kind} 0 4\nl.a[b.o]:\nx {kind} 0 4\nl.a[c.o]:\nx V 0 4\n"
    assert symbols.duplicate_globals(symbols.parse_nm(text, "l.a")) == (Duplicate("x", ("a.o", "b.o")),)


@pytest.mark.parametrize("kinds", ["CC", "CT", "WT", "VD", "uu", "TU"])
def test_no_duplicate_where_the_linker_merges_or_one_only_refers(kinds: str) -> None:
    text = f"l.a[a.o]:\nx {kinds[0]} 0 4\nl.a[b.o]:\nx {kinds[1]} 0 4\n"
    assert symbols.duplicate_globals(symbols.parse_nm(text, "l.a")) == ()


def test_the_same_member_name_twice_is_one_member() -> None:
    # two archives' members could share a name; libmicroros.a's never do (the merge renames them)
    text = "l.a[a.o]:\nx T 0 4\nl.a[a.o]:\nx T 0 4\n"
    assert symbols.duplicate_globals(symbols.parse_nm(text, "l.a")) == ()


def test_undefined_are_strong_references_no_member_defines() -> None:
    assert symbols.undefined_globals(symbols.parse_nm(TWINS, "libtwins.a")) == (
        "__atomic_load_8",
        "clock_gettime",
        "something_unknown",
        "strcpy",
        "uxr_write_serial_data_platform",
    )


def test_one_line_names_the_count_and_the_first_three() -> None:
    dups = [Duplicate(f"s{i}", ("a.o", "b.o")) for i in range(5)]
    line = symbols.describe_duplicates(dups, "libmicroros.a")
    assert line.startswith("libmicroros.a: 5 global symbols are defined in more than one member")
    assert "s0 (a.o, b.o); s1 (a.o, b.o); s2 (a.o, b.o); and 2 more" in line
    assert "\n" not in line
    assert "1 global symbol is" in symbols.describe_duplicates(dups[:1], "l.a")
    assert symbols.duplicate_lines(dups[:1]) == ["  s0: defined in a.o, b.o"]


def test_the_shipped_list_knows_what_the_firmware_provides() -> None:
    known = symbols.firmware_symbols()
    found = symbols.undefined_globals(symbols.parse_nm(TWINS, "libtwins.a"))
    lines = symbols.needed_lines(found, known)
    # by provider in the file's order (the firmware first), unknown names last
    assert [line.split()[0].rstrip(":") for line in lines] == [
        "clock_gettime",
        "uxr_write_serial_data_platform",
        "strcpy",
        "__atomic_load_8",
        "something_unknown",
    ]
    assert lines[0].startswith("  clock_gettime (your firmware or RTOS): the time micro-ROS")
    assert "libatomic" in lines[3]
    assert lines[-1] == "  something_unknown: not in uros's list (meta/firmware-symbols.yaml)"
    assert symbols.needed_json(["__aeabi_uldivmod", "zz"], known)["zz"] == {"provider": ""}
    assert symbols.needed_json(["__aeabi_uldivmod"], known)["__aeabi_uldivmod"]["provider"] == "runtime"


def test_an_exact_name_wins_over_a_pattern() -> None:
    known = symbols.parse_firmware_symbols(
        {
            "providers": {"a": "A", "b": "B"},
            "symbols": [
                {"name": "x*", "provider": "a", "meaning": "m"},
                {"name": "xy*", "provider": "b", "meaning": "m"},
                {"name": "xyz", "provider": "a", "meaning": "m"},
            ],
        },
        "f.yaml",
    )
    assert [known.lookup(n).provider if known.lookup(n) else None for n in ("xa", "xyq", "xyz", "q")] == [
        "a",
        "b",
        "a",
        None,
    ]


@pytest.mark.parametrize(
    ("entry", "says"),
    [
        ({"name": "x", "provider": "nobody", "meaning": "m"}, "provider: 'nobody' is not one of a"),
        ({"name": "x*y", "provider": "a", "meaning": "m"}, "a prefix ending in one '*'"),
        ({"name": "*", "provider": "a", "meaning": "m"}, "a prefix ending in one '*'"),
        ({"name": "x", "provider": "a", "meaning": "m", "menaing": "typo"}, "menaing: unknown key"),
    ],
)
def test_a_bad_entry_is_one_line_naming_it(entry: dict[str, str], says: str) -> None:
    with pytest.raises(ConfigError, match=r"f\.yaml: symbols") as caught:
        symbols.parse_firmware_symbols({"providers": {"a": "A"}, "symbols": [entry]}, "f.yaml")
    assert says in caught.value.message


def test_a_name_twice_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"symbols\[1\]: name 'x'"):
        symbols.parse_firmware_symbols(
            {"providers": {"a": "A"}, "symbols": [{"name": "x", "provider": "a", "meaning": "m"}] * 2},
            "f.yaml",
        )


def test_build_info_records_the_duplicates_and_reads_them_back() -> None:
    import json

    from uros_build.output.buildinfo import parse_build_info

    lib = {"file": "libmicroros.a", "sha256": "s", "duplicate_globals": {"f": ["a.o", "b.o"]}}
    info = parse_build_info({"generated_by": "uros", "target": "t", "library": lib}, "b")
    assert info.library.duplicate_globals == {"f": ("a.o", "b.o")}
    assert parse_build_info(json.loads(info.to_json()), "b") == info
    # written before the key existed: none
    older = parse_build_info(
        {"generated_by": "uros", "target": "t", "library": lib | {"duplicate_globals": None}}, "b"
    )
    assert older.library.duplicate_globals == {}
    with pytest.raises(ConfigError, match="duplicate_globals: f: must be a list of strings"):
        parse_build_info(
            {"generated_by": "u", "target": "t", "library": lib | {"duplicate_globals": {"f": 1}}}, "b"
        )
