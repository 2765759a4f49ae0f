"""uros size's parsers, on text generated here from the fixture workspace's cortex-m7 build with
arm-none-eabi-size and a firmware (examples/cmake-firmware, an app calling fx_core_add and
fx_flat_sum, with one initialised and one zeroed variable) linked with --gc-sections -Map."""

from __future__ import annotations

from pathlib import Path

from uros_build.output import sizes
from uros_build.output.sizes import Sizes

DATA = Path(__file__).parent / "data"
INPUTS = ("libfx_core.a", "libfx_dup.a", "libfx_flat.a", "libfx_time.a", "libfx_util.a")
PACKAGES = ("fx_core", "fx_dup", "fx_flat", "fx_time", "fx_util")


def test_size_of_the_library_per_member_and_package() -> None:
    members = sizes.parse_berkeley((DATA / "size-libmicroros.txt").read_text())
    assert len(members) == 8 and members["libfx_time__time.c.obj"] == Sizes(44, 0, 0)
    assert members["libfx_dup__2_common.c.obj"] == Sizes(4, 0, 0)  # a renamed duplicate
    packages = sizes.by_package(members, INPUTS, PACKAGES, {})
    assert packages["fx_util"] == (Sizes(16, 0, 0), 2) and packages["fx_dup"] == (Sizes(8, 0, 0), 2)
    assert sum((s for s, _n in packages.values()), Sizes()).text == 96


def test_the_map_counts_what_the_link_kept() -> None:
    entries = sizes.parse_map((DATA / "firmware-fx_core.map").read_text())
    linked, rest = sizes.linked_members(entries, "libmicroros.a")
    # fx_core_add's object, and fx_flat_sum's with what it calls; fx_time and fx_core's util.c
    # were never pulled out of the archive
    assert linked == {
        "libfx_core__core.c.obj": Sizes(4, 0, 0),
        "libfx_flat__flat.c.obj": Sizes(20, 0, 0),
        "libfx_util__util.c.obj": Sizes(6, 0, 0),
        "libfx_dup__1_common.c.obj": Sizes(4, 0, 0),
        "libfx_dup__2_common.c.obj": Sizes(4, 0, 0),
    }
    assert sizes.by_package(linked, INPUTS, PACKAGES, {})["fx_flat"] == (Sizes(20, 0, 0), 1)
    # the app's own data and zeroed buffer, libc's: the rest of the firmware (size says 1060/112/172)
    assert rest.data >= 4 and rest.bss >= 64
    assert rest.text + sum(s.text for s in linked.values()) <= 1060
    # nothing from "Discarded input sections" or debug sections is counted
    assert all(sizes.section_kind(e.section) != "bss" or e.size for e in entries)


def test_long_section_names_wrap_onto_the_next_line() -> None:
    text = "\n".join(
        [
            "Discarded input sections",
            " .text.unused   0x00000000       0x20 /w/libmicroros.a(libfx_core__core.c.obj)",
            "Linker script and memory map",
            ".text           0x08000000      0x100",
            " .text.a_very_long_function_name",
            "                0x08000000       0x10 /w/libmicroros.a(librcl__rcl.c.obj)",
            "                0x08000000                a_very_long_function_name",
            " *fill*         0x08000010        0x2 ",
            " .bss.buffer    0x20000000       0x40 /w/libmicroros.a(librcl__rcl.c.obj)",
            " COMMON         0x20000040        0x8 /w/libmicroros.a(librcl__init.c.obj)",
            " .debug_info    0x00000000      0x999 /w/libmicroros.a(librcl__rcl.c.obj)",
            " .rodata.str1.4 0x08000012        0x6 app.c.obj",
        ]
    )
    linked, rest = sizes.linked_members(sizes.parse_map(text), "libmicroros.a")
    assert linked == {"librcl__rcl.c.obj": Sizes(0x10, 0, 0x40), "librcl__init.c.obj": Sizes(0, 0, 8)}
    assert rest == Sizes(6, 0, 0)


def test_archives_lead_to_packages() -> None:
    archives = ("librcl.a", "librcl_action.a", "libstd_msgs__rosidl_generator_c.a", "libmicrocdr.a")
    assert sizes.member_archive("librcl_action__goal_handle.c.obj", archives) == "librcl_action.a"
    assert sizes.member_archive("librcl__node.c.obj", archives) == "librcl.a"
    assert sizes.member_archive("other.o", archives) is None
    packages = ("rcl", "rcl_action", "std_msgs", "microcdr")
    assert sizes.archive_package("libstd_msgs__rosidl_generator_c.a", packages, {}) == "std_msgs"
    assert sizes.archive_package("librcl_action.a", packages, {}) == "rcl_action"
    assert sizes.archive_package("libmicrocdr.a", packages, {"libmicrocdr.a": "microcdr"}) == "microcdr"
    manifests = {"std_msgs": "/i/lib/libstd_msgs__rosidl_typesupport_c.a\n/i/include/std_msgs/msg/bool.h\n"}
    assert sizes.manifest_archives(manifests) == {"libstd_msgs__rosidl_typesupport_c.a": "std_msgs"}
