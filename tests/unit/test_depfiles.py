"""depfiles: ninja's record of what each object read, reduced to the headers outside the workspace
and their content."""

from __future__ import annotations

from pathlib import Path

from uros_build.colcon import depfiles

_DEPS = """CMakeFiles/fx_core.dir/src/core.c.obj: #deps 4, deps mtime 1795549807108232768 (VALID)
    /ws/mcu_ws/src/fx_core/src/core.c
    /ws/.uros/targets/cortex-m7/uros_clock_gettime.h
    /usr/include/newlib/sys/types.h
    include/generated.h

CMakeFiles/fx_core.dir/src/util.c.obj: #deps 2, deps mtime 1795549807108232768 (VALID)
    /usr/include/newlib/sys/types.h
    /opt/board/board_config.h
"""


def test_parse_and_keep_only_what_is_outside() -> None:
    paths = depfiles.parse_ninja_deps(_DEPS)
    assert "include/generated.h" in paths and len(paths) == 5
    assert depfiles.outside(paths, [Path("/ws")]) == [
        "/opt/board/board_config.h",
        "/usr/include/newlib/sys/types.h",
    ]


def test_a_changed_header_names_the_packages_that_read_it(tmp_path: Path) -> None:
    a, b = tmp_path / "a.h", tmp_path / "b.h"
    a.write_text("one\n")
    b.write_text("same\n")
    snap = depfiles.snapshot({"fx_core": [str(a), str(b)], "fx_util": [str(b)]})
    assert depfiles.read_record(tmp_path / "none.json") == {}
    (tmp_path / depfiles.RECORD).write_text(depfiles.record_text(snap))
    record = depfiles.read_record(tmp_path / depfiles.RECORD)
    assert record == snap
    unchanged, digest = depfiles.changed_packages(record)
    assert unchanged == []
    a.write_text("two\n")
    changed, other = depfiles.changed_packages(record)
    assert changed == ["fx_core"] and other != digest
    a.unlink()
    assert depfiles.changed_packages(record)[0] == ["fx_core"]  # a header gone is a change too
