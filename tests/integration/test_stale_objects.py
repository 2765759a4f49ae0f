"""A library that never lies (issue 8, item 6): libmicroros.a holds exactly the packages of this
build, compiled with the flags build-info.json records, whatever an earlier build left in the
target's trees. Real CLI, colcon, CMake and arm-none-eabi-gcc on the fixture workspace."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml
from fixture_ws import FIXTURE_MEMBERS, make_fixture_workspace
from uros_helpers import REPO, build_fixture, defined_globals, need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _members(lib: Path) -> list[str]:
    out = subprocess.run(["arm-none-eabi-ar", "t", str(lib)], capture_output=True, text=True, check=True)
    return out.stdout.split()


def _info(out: Path) -> dict[str, object]:
    return json.loads((out / "build-info.json").read_text())  # type: ignore[no-any-return]


def _headers(out: Path) -> set[str]:
    return {p.relative_to(out / "include").parts[0] for p in (out / "include").rglob("*") if p.is_file()}


def test_a_package_removed_from_the_workspace_leaves_the_library(m7_build: Path) -> None:
    ws = m7_build
    out = ws / "build" / "cortex-m7"
    assert defined_globals(out / "libmicroros.a")["fx_flat_sum"] == 1
    shutil.rmtree(ws / "mcu_ws" / "src" / "fx_flat")  # nothing depends on it
    proc = build_fixture(ws)
    assert "(no longer in the workspace): fx_flat" in proc.stderr
    assert "fx_flat_sum" not in defined_globals(out / "libmicroros.a")
    assert not [m for m in _members(out / "libmicroros.a") if m.startswith("libfx_flat")]
    info = _info(out)
    assert info["packages"] == ["fx_core", "fx_dup", "fx_time", "fx_util"]
    assert "libfx_flat.a" not in info["library"]["inputs"]  # type: ignore[index]
    assert "fxflat" not in _headers(out)
    trees = ws / ".uros" / "targets" / "cortex-m7"
    assert not (trees / "install" / "lib" / "libfx_flat.a").exists()
    assert not (trees / "install" / "include" / "fxflat").exists()
    assert not (trees / "build" / "fx_flat").exists()


def test_a_renamed_package_is_in_the_library_once_under_its_new_name(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    out = ws / "build" / "cortex-m7"
    # fx_flat becomes fx_level: another package name, library and header folder, same sources
    old, new = ws / "mcu_ws" / "src" / "fx_flat", ws / "mcu_ws" / "src" / "fx_level"
    old.rename(new)
    for name in ("package.xml", "CMakeLists.txt"):
        path = new / name
        path.write_text(path.read_text().replace("fx_flat", "fx_level"))
    # fx_time is renamed fx_clock in package.xml only: the new package installs the very
    # libfx_time.a the old one did
    clock = ws / "mcu_ws" / "src" / "fx_time" / "package.xml"
    clock.write_text(clock.read_text().replace("<name>fx_time</name>", "<name>fx_clock</name>"))
    meta = tmp_path / "renamed.meta"
    meta.write_text(json.dumps({"names": {"fx_clock": {"cmake-args": ["-DFX_TIME_ENABLE=ON"]}}}))
    proc = build_fixture(ws, meta=meta)
    assert "(no longer in the workspace): fx_flat, fx_time" in proc.stderr
    symbols = defined_globals(out / "libmicroros.a")
    assert symbols["fx_flat_sum"] == 1 and symbols["fx_time_now_ns"] == 1
    assert len(_members(out / "libmicroros.a")) == FIXTURE_MEMBERS
    info = _info(out)
    assert info["packages"] == ["fx_clock", "fx_core", "fx_dup", "fx_level", "fx_util"]
    assert "libfx_flat.a" not in info["library"]["inputs"]  # type: ignore[index]
    assert {"libfx_level.a", "libfx_time.a"} <= set(info["library"]["inputs"])  # type: ignore[index]


def _board(tmp_path: Path, define: str) -> Path:
    """A profile of the user's (target 'board') whose C flags carry ``define``."""
    data = yaml.safe_load((REPO / "toolchains" / "cortex-m7.yaml").read_text())
    data.update(name="board", c_flags=[*data.get("c_flags", []), define])
    path = tmp_path / "board.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_flag_change_with_packages_up_to_ships_only_what_was_rebuilt(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    base = ["build", "--workspace", str(ws), "--meta", str(ws / "fixture.meta")]
    run_uros(*base, "--profile", str(_board(tmp_path, "-DFX_FLAG=1")))
    out = ws / "build" / "board"
    assert len(_members(out / "libmicroros.a")) == FIXTURE_MEMBERS
    run_uros(*base, "--profile", str(_board(tmp_path, "-DFX_FLAG=2")), "--packages-up-to", "fx_util")
    members = _members(out / "libmicroros.a")
    assert len(members) == 4 and all(m.startswith(("libfx_core__", "libfx_util__")) for m in members)
    info = _info(out)
    assert info["packages"] == ["fx_core", "fx_util"]
    assert "-DFX_FLAG=2" in info["flags"]["c"]  # type: ignore[index]
    assert _headers(out) == {"fx_core", "fx_util"}
    trees = ws / ".uros" / "targets" / "board" / "build"
    for package in ("fx_core", "fx_util"):
        commands = json.loads((trees / package / "compile_commands.json").read_text())
        assert all("-DFX_FLAG=2" in c["command"] for c in commands)
    # the packages left out still hold objects with the old flag; the full build recompiles them
    run_uros(*base, "--profile", str(_board(tmp_path, "-DFX_FLAG=2")))
    assert len(_members(out / "libmicroros.a")) == FIXTURE_MEMBERS
    commands = json.loads((trees / "fx_flat" / "compile_commands.json").read_text())
    assert all("-DFX_FLAG=2" in c["command"] for c in commands)


def _add_failing_package(ws: Path) -> None:
    """fx_bad: compiles and installs its library, then its install step fails."""
    bad = ws / "mcu_ws" / "src" / "fx_bad"
    (bad / "src").mkdir(parents=True)
    (bad / "package.xml").write_text(
        (ws / "mcu_ws" / "src" / "fx_dup" / "package.xml").read_text().replace("fx_dup", "fx_bad")
    )
    (bad / "src" / "bad.c").write_text("int fx_bad_value(void) { return 13; }\n")
    (bad / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(fx_bad C)\n"
        "add_library(fx_bad STATIC src/bad.c)\n"
        "install(TARGETS fx_bad ARCHIVE DESTINATION lib)\n"
        'install(CODE "message(FATAL_ERROR \\"fx_bad: the install step fails\\")")\n'
    )


def test_a_failed_package_is_in_no_library_and_no_build_info(m7_build: Path) -> None:
    ws = m7_build  # the fixture's trees built; no output yet
    out = ws / "build" / "cortex-m7"
    shutil.rmtree(out)
    _add_failing_package(ws)
    proc = build_fixture(ws, check=False)
    assert proc.returncode == 4 and "fx_bad" in proc.stderr
    assert not out.exists()  # no library, no build-info.json
    installed = ws / ".uros" / "targets" / "cortex-m7" / "install" / "lib" / "libfx_bad.a"
    assert installed.is_file()  # what the failed install step left behind ...
    build_fixture(ws, "--packages-up-to", "fx_flat", "--packages-up-to", "fx_time")
    assert "fx_bad_value" not in defined_globals(out / "libmicroros.a")  # ... is not shipped
    info = _info(out)
    assert "fx_bad" not in info["packages"]  # type: ignore[operator]
    assert "libfx_bad.a" not in info["library"]["inputs"]  # type: ignore[index]
    assert len(_members(out / "libmicroros.a")) == FIXTURE_MEMBERS
