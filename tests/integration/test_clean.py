"""`uros clean` on a real build (a copy of the session's cortex-m7 fixture build): it removes
uros's trees and outputs, keeps everything else, and says what it freed."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from uros_helpers import run_uros, run_uros_here

pytestmark = pytest.mark.integration


def _bytes(path: Path) -> int:
    return sum(os.lstat(os.path.join(d, f)).st_size for d, _s, files in os.walk(path) for f in files)


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


def test_clean_removes_only_uros_trees_and_outputs(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    tree, out = ws / ".uros" / "targets" / "cortex-m7", ws / "build" / "cortex-m7"
    # the user's own things, among uros's
    (ws / "build" / "mine").mkdir()
    (ws / "build" / "mine" / "notes.txt").write_text("mine\n")
    fake = ws / "build" / "rp2040"  # a folder with a build-info.json uros did not write
    fake.mkdir()
    (fake / "build-info.json").write_text('{"generated_by": "someone else", "target": "x"}\n')
    expected = _bytes(tree) + _bytes(out)
    (out / "my-notes.txt").write_text("a file the user put into uros's output\n")
    kept = {f for f in _files(ws) if not f.startswith((".uros/targets/cortex-m7/", "build/cortex-m7/"))}
    kept.add("build/cortex-m7/my-notes.txt")

    proc = run_uros("clean", "--toolchain", "cortex-m7", "-w", str(ws))
    assert not tree.exists() and sorted(p.name for p in out.iterdir()) == ["my-notes.txt"]
    assert "it holds files uros did not write (my-notes.txt)" in proc.stderr, proc.stderr
    assert f"({expected:,} bytes) in {ws}" in proc.stderr, (expected, proc.stderr)
    assert _files(ws) == kept  # sources, logs, the user's folders: all still there

    (out / "my-notes.txt").unlink()
    out.rmdir()
    nothing = run_uros("clean", "--toolchain", "cortex-m7", "-w", str(ws), check=False)
    assert nothing.returncode == 2 and "nothing of it" in nothing.stderr


def test_clean_refuses_a_typo_and_no_target_and_touches_nothing(m7_build: Path) -> None:
    typo = run_uros_here("clean", "--toolchain", "cortex-m77", "-w", str(m7_build), check=False)
    assert typo.returncode == 2 and "did you mean cortex-m7" in typo.stderr, typo.stderr
    which = run_uros_here("clean", "-w", str(m7_build), check=False)
    assert which.returncode == 2 and "--all" in which.stderr and "cortex-m7" in which.stderr
    assert (m7_build / "build" / "cortex-m7" / "libmicroros.a").is_file()  # the refusals touched nothing


def test_clean_all_from_inside_the_workspace(m7_build: Path, tmp_path: Path) -> None:
    ws = m7_build
    (ws / "uros.yaml").write_text("distro: humble\ntarget: cortex-m7\n")
    sources = _files(ws / "mcu_ws")
    entry = ws / ".uros" / "gen-cache" / "ab" / ("ab" + "0" * 62 + ".entry")
    entry.parent.mkdir(parents=True, exist_ok=True)
    entry.write_bytes(b"x" * 100)
    run_uros("clean", cwd=ws / "mcu_ws")  # the default: uros.yaml's target, in the nearest workspace
    assert not (ws / "build" / "cortex-m7").exists() and not (ws / ".uros" / "targets" / "cortex-m7").exists()
    # the generation cache every target shares goes with --all only
    assert entry.is_file()  # still there after the one target's clean above
    said = run_uros("clean", "--all", cwd=ws).stderr
    assert _files(ws / "mcu_ws") == sources and (ws / "uros.yaml").is_file()
    assert not entry.exists() and "gen-cache" in said
