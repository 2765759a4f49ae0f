"""Global symbols two members of libmicroros.a define (issue 33, item 2), through the real CLI: a
--whole-archive link (Arduino's precompiled libraries) fails on them with "multiple definition"
(micro_ros_arduino#910, #1300, #847). Every build warns, `uros check --whole-archive` and
`uros export arduino` fail; the plain fixture has none, and `uros check` lists what the firmware
must provide."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from fixture_ws import add_twin_packages
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

TWINS = "fx_twin_type_support (libfx_twin_a__fx_twin_a.c.obj, libfx_twin_b__fx_twin_b.c.obj)"


def _lines(text: str, what: str) -> list[str]:
    return [line for line in text.splitlines() if what in line]


def test_a_global_two_packages_define_warns_and_fails_whole_archive_links(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake", "nm")
    add_twin_packages(tmp_path)
    meta = tmp_path / "none.meta"
    meta.write_text('{"names": {}}\n', encoding="utf-8")
    built = run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(tmp_path), "--meta", str(meta))
    warned = _lines(built.stderr, "defined in more than one member")
    assert len(warned) == 1, built.stderr
    assert warned[0].startswith("warning: libmicroros.a: 1 global symbol is defined") and TWINS in warned[0]
    assert "fx_twin_hook" not in built.stderr  # a weak definition in both collides with nothing
    log = Path(re.findall(r"^log: (\S+)", built.stderr, re.M)[0])
    assert _lines(log.read_text(encoding="utf-8"), "fx_twin_type_support: defined in libfx_twin_a__")
    out = tmp_path / "build" / "cortex-m7"
    members = ["libfx_twin_a__fx_twin_a.c.obj", "libfx_twin_b__fx_twin_b.c.obj"]
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["library"]["duplicate_globals"] == {"fx_twin_type_support": members}

    lib = str(out / "libmicroros.a")
    listed = run_uros("check", lib, "--toolchain", "cortex-m7")  # a normal link: a warning
    assert _lines(listed.stderr, TWINS)
    failed = run_uros("check", lib, "--toolchain", "cortex-m7", "--whole-archive", check=False)
    assert failed.returncode == 5, failed.stderr
    (error,) = _lines(failed.stderr, "error:")
    assert TWINS in error and "--whole-archive" in error

    arduino = tmp_path / "arduino"
    exported = run_uros("export", "arduino", "--from", str(out), "--output", str(arduino), check=False)
    assert exported.returncode == 5, exported.stderr
    (error,) = _lines(exported.stderr, "error:")
    assert f"--from {out}:" in error and TWINS in error
    assert not arduino.exists()  # refused before anything is written


def test_the_plain_fixture_has_no_duplicates_and_names_what_the_firmware_provides(m7_snapshot: Path) -> None:
    out = m7_snapshot / "build" / "cortex-m7"  # read in place: `uros check` writes nothing beside it
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["library"]["duplicate_globals"] == {}
    lib = str(out / "libmicroros.a")
    checked = run_uros("check", lib, "--toolchain", "cortex-m7", "--whole-archive")
    assert "libmicroros.a: no global symbol is defined in more than one member" in checked.stderr
    # fx_time calls clock_gettime, as rcutils does on newlib
    (line,) = _lines(checked.stderr, "clock_gettime")
    assert line.startswith("  clock_gettime (your firmware or RTOS): the time micro-ROS")
    report = json.loads(run_uros("check", lib, "--toolchain", "cortex-m7", "--json").stdout)
    assert report["duplicate_globals"] == {}
    assert report["undefined"]["clock_gettime"]["provider"] == "firmware"
