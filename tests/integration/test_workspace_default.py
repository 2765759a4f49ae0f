"""One -w/--workspace default for every command, through the real CLI: the nearest folder upward
with a uros.yaml, else ./firmware; `uros build` refuses a folder that is no uros workspace."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from fixture_ws import TIME_MEMBERS, make_fixture_workspace
from uros_helpers import REPO, run_uros, run_uros_here

pytestmark = pytest.mark.integration


def _firmware(root: Path) -> Path:
    """A hand-written firmware workspace: what uros reads needs no clone (uros.yaml, mcu_ws/)."""
    (root / "mcu_ws" / "src").mkdir(parents=True)
    (root / "uros.yaml").write_text("distro: humble\n")
    return root


def _package(folder: Path, name: str) -> Path:
    folder.mkdir(parents=True)
    (folder / "package.xml").write_text(
        f"<package format='3'><name>{name}</name><version>0.1.0</version><description>d</description>"
        "<maintainer email='m@example.com'>m</maintainer><license>MIT</license></package>\n"
    )
    return folder


def _time_workspace(root: Path) -> Path:
    """The fixture workspace with fx_time and fx_core alone (fixture_ws.UP_TO_TIME's packages;
    fx_time fails to configure unless its option arrives): what these tests build, for up to three
    targets, without three packages that would add only their fixed cost (~0.14 s of CPU a package
    a target)."""
    ws = make_fixture_workspace(root)
    for name in ("fx_util", "fx_dup", "fx_flat"):
        shutil.rmtree(ws / "mcu_ws" / "src" / name)
    return ws


def test_build_outside_a_workspace_is_refused_and_writes_nothing(tmp_path: Path) -> None:
    proc = run_uros_here("build", "--toolchain", "cortex-m7", cwd=tmp_path, check=False)
    assert proc.returncode == 2, proc.stderr
    assert "no uros workspace here" in proc.stderr and "create-firmware" in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_colcon_workspace_needs_w(tmp_path: Path) -> None:
    """Packages without a uros.yaml: not found by default (a build run in the wrong folder crawled
    every project below it), built when named with -w (see test_build_fixture)."""
    ws = make_fixture_workspace(tmp_path / "ws")
    before = sorted(p.name for p in ws.iterdir())
    proc = run_uros_here("build", "--toolchain", "cortex-m7", cwd=ws, check=False)
    assert proc.returncode == 2 and "-w DIR" in proc.stderr, proc.stderr
    assert sorted(p.name for p in ws.iterdir()) == before  # no .uros/, no build/


def test_a_folder_without_packages_or_uros_yaml_is_refused_with_w(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine\n")
    proc = run_uros_here("build", "--toolchain", "cortex-m7", "-w", str(tmp_path), check=False)
    assert proc.returncode == 2 and "not a uros workspace" in proc.stderr, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_the_nearest_uros_yaml_upward_is_the_workspace(tmp_path: Path) -> None:
    fw = _firmware(tmp_path / "project" / "fw")
    pkg = _package(tmp_path / "my_msgs", "my_msgs")
    deep = fw / "mcu_ws" / "src"
    run_uros("add-package", str(pkg), cwd=deep)
    assert (fw / "mcu_ws" / "extra_packages" / "my_msgs" / "package.xml").is_file()
    assert str(pkg) in (fw / "uros.yaml").read_text()


def test_firmware_is_the_default_elsewhere(tmp_path: Path) -> None:
    fw = _firmware(tmp_path / "firmware")
    pkg = _package(tmp_path / "my_msgs", "my_msgs")
    run_uros("add-package", str(pkg), cwd=tmp_path)
    assert (fw / "mcu_ws" / "extra_packages" / "my_msgs").is_dir()
    # create-firmware resolves the same way: here that is the existing ./firmware
    proc = run_uros_here("create-firmware", cwd=tmp_path, check=False)
    assert proc.returncode == 2 and f"{fw}: already exists" in proc.stderr, proc.stderr


@pytest.mark.colcon
def test_uros_build_builds_every_target_uros_yaml_names(tmp_path: Path) -> None:
    """A colcon workspace with a hand-written uros.yaml: `uros build` with no options, from a
    folder inside it, builds each of its targets with its set: options."""
    ws = _time_workspace(tmp_path / "ws")
    (ws / "uros.yaml").write_text(
        "distro: humble\ntargets: [cortex-m7, cortex-m0plus]\nset: [fx_time.FX_TIME_ENABLE=ON]\n"
    )
    proc = run_uros("build", cwd=ws / "mcu_ws" / "src")
    assert "building 2 targets (cortex-m7, cortex-m0plus)" in proc.stderr, proc.stderr
    for key in ("cortex-m7", "cortex-m0plus"):
        assert (ws / "build" / key / "libmicroros.a").is_file(), key
    one = run_uros("build", "--toolchain", "cortex-m7", cwd=ws)  # the command line wins
    assert "building 2 targets" not in one.stderr


@pytest.mark.colcon
def test_several_targets_on_the_command_line_each_say_how_they_ended(tmp_path: Path) -> None:
    """Issue 19, item 6: `--toolchain a --toolchain b` builds each, goes on after one fails, says
    per target how it ended, and exits with the first failure's code; a typo fails first."""
    ws = _time_workspace(tmp_path / "ws")
    broken = tmp_path / "broken.cmake"
    broken.write_text("set(CMAKE_SYSTEM_NAME Generic)\nset(CMAKE_C_COMPILER /nonexistent/gcc)\n")
    meta = ["--meta", str(ws / "fixture.meta")]
    typo = run_uros_here(
        "build", "-w", str(ws), *meta, "--toolchain", "cortex-m7", "--toolchain", "cortex-m77", check=False
    )
    assert typo.returncode == 2 and "cortex-m77" in typo.stderr
    assert not (ws / "build").exists()  # nothing was built before the typo was found

    proc = run_uros(
        "build", "-w", str(ws), *meta, "--toolchain", str(broken), "--toolchain", "cortex-m7",
        "--toolchain", "cortex-m0plus", check=False,
    )  # fmt: skip
    assert proc.returncode == 4, proc.stderr
    assert "building 3 targets" in proc.stderr and "3 targets:" in proc.stderr
    summary = proc.stderr.split("3 targets:")[1]
    assert (
        "FAILED (exit 4" in summary
        and "cortex-m7: built (" in summary
        and "cortex-m0plus: built (" in summary
    )
    for key in ("cortex-m7", "cortex-m0plus"):
        assert (ws / "build" / key / "libmicroros.a").is_file(), key
    again = run_uros("build", "-w", str(ws), *meta, "--target", "cortex-m7", "--target", "cortex-m0plus")
    assert "cortex-m7: up to date" in again.stderr and "cortex-m0plus: up to date" in again.stderr
    with_output = run_uros_here("build", "-w", str(ws), "--toolchain", "cortex-m7", "--toolchain", "cortex-m0plus",
                           "--output", str(tmp_path / "o"), check=False)  # fmt: skip
    assert with_output.returncode == 2 and "--output with 2 targets" in with_output.stderr


def test_a_uros_yaml_without_a_distro_builds_and_update_asks_for_one(m7_build: Path) -> None:
    """Issue 34, item 2: a plain colcon workspace whose uros.yaml has only `target:` builds (it was
    refused: "distro: is required but missing"); a distro is needed only to move clones."""
    ws = m7_build
    (ws / "uros.yaml").write_text("target: cortex-m7\n")
    proc = run_uros("build", "--meta", str(ws / "fixture.meta"), cwd=ws / "mcu_ws")
    assert "target cortex-m7" in proc.stderr, proc.stderr
    assert (ws / "build" / "cortex-m7" / "libmicroros.a").is_file()
    (ws / "uros.lock").write_text('{"repositories": {}}\n')  # as if create-firmware had cloned
    update = run_uros_here("update", cwd=ws, check=False)
    assert update.returncode == 2, update.stderr
    assert "uros.yaml: distro: is required by `uros update` but missing" in update.stderr
    assert (ws / "uros.yaml").read_text() == "target: cortex-m7\n"


@pytest.mark.colcon
def test_a_profile_file_named_in_uros_yaml_is_a_profile(tmp_path: Path) -> None:
    """Issue 34, item 3: `target: boards/my_board.yaml` in uros.yaml is a profile, as --profile's
    (it reached CMake as a toolchain file: "Parse error. Expected a command name"); so is one in a
    `targets:` list."""
    ws = _time_workspace(tmp_path / "ws")
    board = ws / "boards" / "my_board.yaml"
    board.parent.mkdir()
    shipped = (REPO / "toolchains" / "cortex-m7.yaml").read_text()
    board.write_text(shipped.replace("name: cortex-m7", "name: my-board"))
    (ws / "uros.yaml").write_text(
        "distro: humble\ntarget: boards/my_board.yaml\nset: [fx_time.FX_TIME_ENABLE=ON]\n"
    )
    proc = run_uros("build", cwd=ws / "mcu_ws" / "src")
    out = ws / "build" / "my-board"
    assert (out / "libmicroros.a").is_file(), proc.stderr
    info = json.loads((out / "build-info.json").read_text())
    assert info["target"] == "my-board", info["target"]
    assert f"all {TIME_MEMBERS} objects show the ELF facts of my-board" in proc.stderr, (
        proc.stderr
    )  # checked as a profile
    (ws / "uros.yaml").write_text(
        "distro: humble\ntargets: [boards/my_board.yaml]\nset: [fx_time.FX_TIME_ENABLE=ON]\n"
    )
    again = run_uros("build", cwd=ws)  # uros.yaml changed: a build, of the same target
    assert "target my-board" in again.stderr and "built " in again.stderr, again.stderr
    missing = run_uros_here(
        "build", "-w", str(ws), "--toolchain", str(ws / "boards" / "none.yaml"), check=False
    )
    assert missing.returncode == 2 and "none.yaml: no such profile file" in missing.stderr, missing.stderr
