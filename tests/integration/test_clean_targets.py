"""`uros clean` removes exactly what `uros build` made for a target, however the target was named
(issue 30 item 4: one name → folder-key rule): a shipped target, a --profile file, a toolchain file
named in uros.yaml (and `uros clean --toolchain path/to/file.cmake`, issue 34); and `uros build -v`
says which settings are in force and who chose each."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE
from uros_helpers import run_uros, run_uros_here

pytestmark = pytest.mark.integration


def _files(root: Path) -> set[str]:
    """Every file and link under ``root`` (relative), folders left out."""
    out = set()
    for folder, dirs, files in os.walk(root):
        for name in files + [d for d in dirs if os.path.islink(os.path.join(folder, d))]:
            out.add(os.path.relpath(os.path.join(folder, name), root))
    return out


def _of_target(files: set[str], key: str) -> set[str]:
    """What `uros build` made for the target ``key``: its trees and its output."""
    return {f for f in files if f.startswith((f".uros/targets/{key}/", f"build/{key}/"))}


def _clean_removes_exactly(ws: Path, key: str, *args: str, cwd: Path | None = None) -> str:
    before = _files(ws)
    made = _of_target(before, key)
    assert made and f"build/{key}/libmicroros.a" in made, sorted(before)[:20]
    said = run_uros("clean", *args, cwd=cwd).stderr
    after = _files(ws)
    assert before - after == made, sorted((before - after) ^ made)[:20]  # all of it, nothing else
    assert not (ws / ".uros" / "targets" / key).exists() and not (ws / "build" / key).exists()
    return said


def test_clean_a_shipped_target_and_a_profile_file(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    profile = tmp_path / "board.yaml"  # a profile whose name: is not its file name
    shown = run_uros_here("targets", "show", "cortex-m7").stdout  # starts no process: in process
    profile.write_text(shown.replace("name: cortex-m7", "name: my-board", 1), encoding="utf-8")
    # fx_core alone for the second target: what clean removes is the target's, however many packages
    run_uros(
        "build", "--profile", str(profile), "-w", str(ws), "--meta", str(ws / "fixture.meta"), *UP_TO_CORE
    )
    assert (ws / "build" / "my-board" / "libmicroros.a").is_file()

    _clean_removes_exactly(ws, "my-board", "--profile", str(profile), "-w", str(ws))
    assert (ws / "build" / "cortex-m7" / "libmicroros.a").is_file()  # the other target stays
    _clean_removes_exactly(ws, "cortex-m7", "--toolchain", "cortex-m7", "-w", str(ws))


def test_clean_a_toolchain_file_named_in_uros_yaml(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    (ws / "boards").mkdir()
    run_uros_here(  # starts no process: in process
        "toolchain", "render", "cortex-m7", "--for", "micro-ros", "-o", str(ws / "boards" / "my-tc.cmake")
    )
    (ws / "uros.yaml").write_text("distro: humble\ntarget: boards/my-tc.cmake\n", encoding="utf-8")
    env = {**os.environ, "UROS_GEN_CACHE_DIR": str(tmp_path / "gen")}
    # fx_core alone for the second target (as above)
    built = run_uros("build", "-v", "--meta", str(ws / "fixture.meta"), *UP_TO_CORE, cwd=ws, env=env).stderr
    # -v: the settings in force, one line each, with who chose them
    assert f"toolchains = boards/my-tc.cmake  ({ws}/uros.yaml: target)" in built, built
    assert f"metas = {ws / 'fixture.meta'}  (--meta)" in built
    assert f"gen_cache_dir = {tmp_path / 'gen'}  ($UROS_GEN_CACHE_DIR)" in built
    assert "host_stage = on  (default)" in built and "verbose = on  (-v/--verbose)" in built
    assert (ws / "build" / "my-tc" / "libmicroros.a").is_file()
    # what reads an output finds this one by the same rule
    assert '"target"' in run_uros("info", "--json", cwd=ws).stdout
    run_uros("info", "--toolchain", "boards/my-tc.cmake", "-w", str(ws))

    other = tmp_path / "copy"  # the same build, to clean it the other way
    shutil.copytree(ws, other, symlinks=True)
    # the default: uros.yaml's target, from inside the workspace
    _clean_removes_exactly(ws, "my-tc", cwd=ws / "mcu_ws")
    # --toolchain with the file's path (issue 34: it looked for a folder named after the path)
    tc = other / "boards" / "my-tc.cmake"
    _clean_removes_exactly(other, "my-tc", "--toolchain", str(tc), "-w", str(other))
