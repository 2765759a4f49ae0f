"""Never "up to date", never a green build, over objects that do not match their sources, flags or
compiler (issue 16, items 1-5). Each test judges the library by its bytes (nm, strings), not by
what uros says, and each failed on c34c85f. Real CLI, colcon, CMake and arm-none-eabi-gcc on the
fixture workspace: fx_core alone (the "core" built fixture, UP_TO_CORE), whose files each test
changes; the other packages added only their fixed cost to every build."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE, make_fixture_workspace
from uros_helpers import build_fixture, defined_globals, need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

_CORE_V2 = '#include "fx_core/core.h"\nint fx_core_add(int a, int b) { return a + b; }\nint fx_core_v2(void) { return 2; }\n'


def _build(ws: Path, *more: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """build_fixture of fx_core alone: the "core" built fixture's command."""
    return build_fixture(ws, *UP_TO_CORE, *more, env=env)


def _strings(lib: Path) -> str:
    return subprocess.run(["strings", "-a", str(lib)], capture_output=True, text=True, check=True).stdout


def test_a_source_restored_with_its_old_mtime_is_rebuilt(built: Callable[[str], Path]) -> None:
    """`cp -p`, `rsync -a`, `tar x`, `git stash pop`: the content goes back, and so does the mtime,
    to before the objects were made."""
    ws = built("core")
    core = ws / "mcu_ws/src/fx_core/src/core.c"
    original, old = core.read_text(), core.stat()
    lib = ws / "build/cortex-m7/libmicroros.a"
    core.write_text(_CORE_V2)
    _build(ws)
    assert defined_globals(lib)["fx_core_v2"] == 1
    # the user restores the old file as `cp -p` would: old content, old mtime
    core.write_text(original)
    os.utime(core, ns=(old.st_atime_ns, old.st_mtime_ns))
    doctor = run_uros("doctor", "-w", str(ws), check=False)
    _build(ws)
    assert "fx_core_v2" not in defined_globals(lib)
    assert "stale: inputs changed since the last build: sources" in doctor.stdout + doctor.stderr
    assert defined_globals(lib)["fx_core_add"] == 1
    assert core.read_text() == original  # uros changed its mtime, never its content
    doctor = run_uros("doctor", "-w", str(ws), check=False)
    assert re.search(r"ok +target cortex-m7 +built and up to date", doctor.stdout), doctor.stdout


def _shim(folder: Path, extra: str) -> None:
    """arm-none-eabi-gcc replaced at the same path (an upgrade, another install): the real
    compiler, with ``extra`` arguments that leave a mark in every object."""
    folder.mkdir(exist_ok=True)
    real = shutil.which("arm-none-eabi-gcc")
    shim = folder / "arm-none-eabi-gcc"
    shim.write_text(f'#!/bin/sh\nexec {real} {extra} "$@"\n')
    shim.chmod(0o755)


def test_a_replaced_compiler_rebuilds_every_object(built: Callable[[str], Path], tmp_path: Path) -> None:
    need("strings")
    ws = built("core")
    shims = tmp_path / "bin"
    env = {**os.environ, "PATH": f"{shims}{os.pathsep}{os.environ['PATH']}"}
    lib = ws / "build/cortex-m7/libmicroros.a"
    _shim(shims, "-frecord-gcc-switches -fno-tree-vectorize")
    _build(ws, env=env)
    assert "-fno-tree-vectorize" in _strings(lib)
    _shim(shims, "-frecord-gcc-switches -fno-tree-loop-distribute-patterns")
    proc = _build(ws, env=env)
    text = _strings(lib)
    assert "-fno-tree-loop-distribute-patterns" in text and "-fno-tree-vectorize" not in text
    assert "the compiler changed" in proc.stderr


def test_rebuild_recompiles_objects_the_build_tools_think_current(
    built: Callable[[str], Path], tmp_path: Path
) -> None:
    ws = built("core")
    lib = ws / "build/cortex-m7/libmicroros.a"
    objects = list((ws / ".uros/targets/cortex-m7/build/fx_core").rglob("core.c.obj"))
    assert len(objects) == 1
    # an object not made from its source, with the very mtime the build tools recorded (a crash, a
    # restored backup of the trees): nothing but a rebuild from scratch replaces it
    made = objects[0].stat()
    bad = tmp_path / "bad.c"
    bad.write_text("int fx_core_add(int a, int b) { return a - b; }\nint fx_tampered(void) { return 0; }\n")
    subprocess.run(
        ["arm-none-eabi-gcc", "-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard", "-c", str(bad),
         "-o", str(objects[0])],
        check=True,
    )  # fmt: skip
    os.utime(objects[0], ns=(made.st_atime_ns, made.st_mtime_ns))
    for archive in (ws / ".uros/targets/cortex-m7/build/fx_core").rglob("libfx_core.a"):
        archive.unlink()  # archived again from the objects that are there
    proc = _build(ws, "--rebuild")
    assert "fx_tampered" not in defined_globals(lib)
    assert defined_globals(lib)["fx_core_add"] == 1
    assert "--rebuild: building every package afresh" in proc.stderr


def test_a_header_outside_the_workspace_restored_with_an_old_mtime(tmp_path: Path) -> None:
    """Issue 16, item 3: headers a profile's flags (or the C library, or ESP-IDF) bring in from
    outside the workspace were not fingerprinted; their content is now compared, package by
    package, from the compiler's own dependency output (ninja -t deps)."""
    need("arm-none-eabi-gcc", "cmake", "strings")
    import yaml
    from uros_helpers import REPO

    ws = make_fixture_workspace(tmp_path / "ws")
    board = tmp_path / "board" / "board_config.h"
    board.parent.mkdir()
    board.write_text('__attribute__((used)) static const char fx_board_mark[] = "BOARD_CONFIG_ONE";\n')
    data = yaml.safe_load((REPO / "toolchains" / "cortex-m7.yaml").read_text())
    data.update(name="board", c_flags=[*data.get("c_flags", []), "-include", str(board)])
    profile = tmp_path / "board.yaml"
    profile.write_text(yaml.safe_dump(data))
    args = ["build", "--profile", str(profile), "--workspace", str(ws), "--meta", str(ws / "fixture.meta")]
    args += UP_TO_CORE
    run_uros(*args)
    lib = ws / "build/board/libmicroros.a"
    assert "BOARD_CONFIG_ONE" in _strings(lib)
    old = board.stat()
    board.write_text('__attribute__((used)) static const char fx_board_mark[] = "BOARD_CONFIG_TWO";\n')
    os.utime(board, ns=(old.st_atime_ns, old.st_mtime_ns - 10**9))  # older than every object
    proc = run_uros(*args)
    text = _strings(lib)
    assert "BOARD_CONFIG_TWO" in text and "BOARD_CONFIG_ONE" not in text
    assert "headers outside the workspace changed since the last build" in proc.stderr
    assert "up to date" in run_uros(*args).stderr  # and then nothing to do


def test_a_users_file_beside_the_output_is_not_a_change_but_a_header_added_to_include_is(
    built: Callable[[str], Path],
) -> None:
    """A notes.txt (or a folder of the user's) beside an up-to-date libmicroros.a made the next
    build rebuild everything ("changed since the last build: the output folder"): only what uros
    wrote there (its `.uros-output` marker names it) is the output. A header dropped into include/
    is uros's tree changed, and still rebuilds it, to exactly this build's headers."""
    ws = built("core")
    out = ws / "build/cortex-m7"
    (out / "notes.txt").write_text("mine\n")
    (out / "mine").mkdir()
    (out / "mine" / "board.h").write_text("/* mine */\n")
    again = _build(ws)
    assert "up to date" in again.stderr and "the output folder" not in again.stderr, again.stderr
    assert (out / "notes.txt").read_text() == "mine\n" and (out / "mine" / "board.h").is_file()
    stray = out / "include" / "stray.h"
    stray.write_text("/* not from this build */\n")
    rebuilt = _build(ws)
    assert "the output folder" in rebuilt.stderr and "up to date" not in rebuilt.stderr, rebuilt.stderr
    assert not stray.exists()
    assert (out / "notes.txt").read_text() == "mine\n"


def test_a_set_option_dropped_from_the_command_line_leaves_the_library(built: Callable[[str], Path]) -> None:
    """`--set fx_core.FX_MARK=7`, then the same build without it: colcon no longer passed
    -DFX_MARK=7, but fx_core's CMakeCache.txt kept FX_MARK, so the library was still built with it
    while build-info.json named no such option (issue 33 item 3's size helper found it with
    RMW_UXRCE_MAX_HISTORY). Judged by the library's bytes."""
    ws = built("core")
    core = ws / "mcu_ws/src/fx_core"
    cmake = core / "CMakeLists.txt"
    cmake.write_text(
        cmake.read_text() + "\nif(FX_MARK)\n  add_compile_definitions(FX_MARK_VALUE=${FX_MARK})\nendif()\n"
    )
    source = core / "src/core.c"
    source.write_text(source.read_text() + "\n#ifdef FX_MARK_VALUE\nint fx_marked = FX_MARK_VALUE;\n#endif\n")
    lib = ws / "build/cortex-m7/libmicroros.a"
    _build(ws, "--set", "fx_core.FX_MARK=7")
    assert "fx_marked" in defined_globals(lib)
    dropped = _build(ws)
    assert "fx_marked" not in defined_globals(lib), dropped.stderr
    assert "configuring afresh (their colcon.meta options changed): fx_core" in dropped.stderr
    info = (ws / "build/cortex-m7/build-info.json").read_text()
    assert "FX_MARK" not in info
    assert "up to date" in _build(ws).stderr
