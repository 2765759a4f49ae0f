"""Never lose a user's data (issue 8, items 1, 2, 4, 5) through the real CLI: target names that are
identifiers, outputs recognised by uros's marker, outputs on mount points and read-only ones, and a
swap a killed run left half-way, put right by the next run."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE, fixture_build_args, make_fixture_workspace
from uros_helpers import (
    REPO,
    build_fixture,
    in_namespace,
    line_result,
    mount_namespace,
    need,
    run_uros,
    run_uros_here,
    uros_build_line,
)

pytestmark = pytest.mark.integration

DEAD = 2**22 + 1000  # above the largest pid_max Linux allows: a run that is gone


def _errors(proc: subprocess.CompletedProcess[str]) -> list[str]:
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr, proc.stderr
    return [line for line in proc.stderr.splitlines() if line.startswith("error:")]


def _listing(root: Path) -> dict[str, str]:
    """Every file under ``root`` with a digest of its content."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _build(ws: Path, *more: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return build_fixture(ws, *UP_TO_CORE, *more, check=check)


def _refused_build(ws: Path, *more: str) -> subprocess.CompletedProcess[str]:
    """:func:`_build` of a case refused before any process starts: in process (run_uros_here)."""
    return run_uros_here(*fixture_build_args(ws, *UP_TO_CORE, *more), check=False)


@pytest.mark.parametrize("name", ["..", ".", "a/.."])
def test_a_profile_named_dotdot_deletes_nothing(tmp_path: Path, name: str) -> None:
    """Issue 8, item 1, reproduced exactly: `name: ".."` in a copy of cortex-m7.yaml and the
    `--force` uros's own hint suggested, which deleted the workspace."""
    ws = make_fixture_workspace(tmp_path / "W")
    (ws / "build" / "other").mkdir(parents=True)
    (ws / "build" / "other" / "libmicroros.a").write_text("another target's output")
    text = (REPO / "toolchains" / "cortex-m7.yaml").read_text(encoding="utf-8")
    profile = tmp_path / "dd.yaml"
    profile.write_text(text.replace("name: cortex-m7\n", f"name: {json.dumps(name)}\n"), encoding="utf-8")
    before = _listing(tmp_path)
    proc = run_uros_here("build", "--profile", str(profile), "--workspace", str(ws), "--force", check=False)
    assert proc.returncode == 2, proc.stderr
    (error,) = _errors(proc)
    assert error.startswith(f"error: {profile}: name: {name!r} is not a target name"), error
    assert _listing(tmp_path) == before


def test_a_toolchain_file_whose_name_is_dots_is_refused(tmp_path: Path) -> None:
    ws = make_fixture_workspace(tmp_path / "W")
    tc = tmp_path / "..cmake"  # its stem is '.'
    tc.write_text("set(CMAKE_SYSTEM_NAME Generic)\n")
    before = _listing(tmp_path)
    proc = run_uros_here("build", "--toolchain", str(tc), "--workspace", str(ws), "--force", check=False)
    assert proc.returncode == 2
    (error,) = _errors(proc)
    assert "'.' cannot name a target folder" in error
    assert _listing(tmp_path) == before


def test_build_into_a_users_folder_keeps_its_files(built: Callable[[str], Path], tmp_path: Path) -> None:
    """Issue 8, item 2, reproduced exactly: `echo {} > proj/build-info.json; uros build --output
    proj` deleted proj/src/main.c (with --force, and without it since build-info.json was there)."""
    ws = built("core")
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / "src" / "main.c").write_text("int main(void) { return 0; }\n")
    (proj / "CMakeLists.txt").write_text("project(firmware C)\n")
    (proj / "build-info.json").write_text("{}\n")
    before = _listing(proj)

    refused = _refused_build(ws, "--output", str(proj))
    assert refused.returncode == 2, refused.stderr
    (error,) = _errors(refused)
    assert "holds files uros did not write (CMakeLists.txt, build-info.json, src)" in error
    assert "colcon build" not in refused.stderr  # refused before anything was built
    assert _listing(proj) == before

    _build(ws, "--output", str(proj), "--force")
    assert (proj / "src" / "main.c").read_text() == "int main(void) { return 0; }\n"
    assert (proj / "CMakeLists.txt").read_text() == "project(firmware C)\n"
    assert (proj / "libmicroros.a").is_file() and (proj / "include" / "fx_core" / "core.h").is_file()
    assert json.loads((proj / "build-info.json").read_text())["target"] == "cortex-m7"
    # now a uros output: rebuilt without --force, the user's files still kept
    (ws / "mcu_ws/src/fx_core/src/core.c").write_text("int fx_core_add(int a, int b) { return b + a; }\n")
    _build(ws, "--output", str(proj))
    assert (proj / "src" / "main.c").is_file() and (proj / "CMakeLists.txt").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["proj"]  # no staging left beside it


@pytest.mark.parametrize(
    ("where", "message"),
    [
        (".", "is the workspace"),
        ("build", "holds"),  # COLCON_IGNORE and the cortex-m7 output of the first build
        ("mcu_ws/src", "is inside the workspace's mcu_ws/"),
    ],
)
def test_force_never_takes_the_workspace_or_other_outputs(
    built: Callable[[str], Path], where: str, message: str
) -> None:
    ws = built("core")
    before = _listing(ws)
    proc = _refused_build(ws, "--output", str(ws / where), "--force")
    assert proc.returncode == 2, proc.stderr
    (error,) = _errors(proc)
    assert message in error
    after = _listing(ws)
    assert {k: v for k, v in after.items() if k in before} == before  # only a run log was added


# -- outputs on mount points (docker -v, CI volumes) ----------------------------------------------


def test_output_on_a_mount_point_is_filled_in_place(built: Callable[[str], Path], tmp_path: Path) -> None:
    """Issue 8, item 4: an output folder that is a mount point cannot be renamed (EBUSY), which
    failed with a traceback after the whole build. A bind mount (how docker -v mounts a host
    folder) and a tmpfs (another file system: EXDEV). The mount hides the built output: the first
    build writes it into the volume."""
    prefix = mount_namespace(tmp_path)
    ws = built("core")
    vol, logs = tmp_path / "vol", tmp_path / "logs"
    vol.mkdir()
    logs.mkdir()
    out = ws / "build" / "cortex-m7"
    tmp_out = ws / "build" / "tmpfs-out"
    tmp_out.mkdir()
    script = (
        f"mount --bind {vol} {out}\n"
        + uros_build_line(ws, logs / "first")
        + f"echo mine > {out}/notes.txt\n"
        + uros_build_line(ws, logs / "second")
        + f"mount -o remount,ro,bind {out}\n"
        + uros_build_line(ws, logs / "readonly")
        + f"mount -t tmpfs -o size=32m tmpfs {tmp_out}\n"
        + uros_build_line(ws, logs / "tmpfs1", "--output", str(tmp_out))
        + uros_build_line(ws, logs / "tmpfs2", "--output", str(tmp_out))
        + f"ls -A {tmp_out} > {logs}/tmpfs.ls\n"
    )
    done = in_namespace(prefix, script)
    assert done.returncode == 0, done.stderr
    for step in ("first", "second"):
        code, err = line_result(logs / step)
        assert code == 0, err
    assert (vol / "libmicroros.a").is_file() and (vol / "include" / "fx_core" / "core.h").is_file()
    assert (vol / "notes.txt").read_text() == "mine\n"  # the user's file in the volume is kept
    assert not [p.name for p in vol.iterdir() if p.name.startswith(".uros-") and p.name != ".uros-output"]
    # a read-only volume: refused before building, in one line
    code, err = line_result(logs / "readonly")
    assert code == 2, err
    assert f"the output folder {out}: cannot write in this folder (it is a mount point" in err
    assert "colcon build" not in err
    for step in ("tmpfs1", "tmpfs2"):
        code, err = line_result(logs / step)
        assert code == 0, err
    listed = (logs / "tmpfs.ls").read_text().split()
    assert "libmicroros.a" in listed and not [
        n for n in listed if n.startswith(".uros-") and n != ".uros-output"
    ]
    assert sorted(p.name for p in (ws / "build").iterdir()) == ["COLCON_IGNORE", "cortex-m7", "tmpfs-out"]


def test_a_read_only_previous_output_is_no_failure(built: Callable[[str], Path]) -> None:
    """Issue 8, item 4: a previous output uros cannot delete (read-only folders; for root, an
    immutable file) ended in "exit 1 + traceback" after the new output was already in place."""
    ws = built("core")
    out = ws / "build" / "cortex-m7"
    header = out / "include" / "fx_core" / "core.h"
    immutable = os.geteuid() == 0
    if immutable:
        if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(header)]).returncode:
            pytest.skip("root ignores permissions, and chattr +i is not supported here")
    else:
        for path in sorted(out.rglob("*"), reverse=True):
            path.chmod(path.stat().st_mode & ~0o222)
        out.chmod(0o555)
    try:
        (ws / "mcu_ws/src/fx_core/src/core.c").write_text("int fx_core_add(int a, int b) { return b + a; }\n")
        proc = _build(ws, check=False)
        assert proc.returncode == 0, proc.stderr
        assert not _errors(proc)
        info = json.loads((out / "build-info.json").read_text())
        assert info["library"]["sha256"] == _sha(out / "libmicroros.a")
        if immutable:
            assert "warning: could not remove the previous output" in proc.stderr, proc.stderr
    finally:
        if immutable:
            for old in (ws / "build").glob(".cortex-m7.old-*"):
                subprocess.run(["chattr", "-R", "-i", str(old)], check=False)
            subprocess.run(["chattr", "-R", "-i", str(out)], check=False)


# -- a swap a killed run left half-way ------------------------------------------------------------


@pytest.mark.parametrize("journal", [True, False], ids=["journal", "uros-before-the-journal"])
def test_a_swap_killed_half_way_is_undone_by_the_next_run(
    built: Callable[[str], Path], journal: bool
) -> None:
    """Issue 8, item 5: a SIGKILL between the two renames left no output at all (it sat in
    `.cortex-m7.old-PID`), while "the previous output was left untouched" was printed. The next run
    puts it back before anything else; here that run fails to compile, so what is in place after it
    is what the recovery put there."""
    ws = built("core")
    build = ws / "build"
    out = build / "cortex-m7"
    good = _sha(out / "libmicroros.a")
    # the state on disk after the first rename of the swap of run DEAD
    old, staging = build / f".cortex-m7.old-{DEAD}", build / f".cortex-m7.staging-{DEAD}"
    out.rename(old)
    staging.mkdir()
    (staging / "libmicroros.a").write_text("the new output, never put in place")
    if journal:
        moves = [{"dest": "cortex-m7", "new": staging.name, "old": old.name}]
        (build / ".cortex-m7.swap").write_text(json.dumps({"pid": DEAD, "moves": moves, "cleanup": []}))
    (ws / "mcu_ws/src/fx_core/src/core.c").write_text("int fx_core_add(int a, int b) { return a + ; }\n")
    proc = _build(ws, check=False)
    assert proc.returncode == 4, proc.stderr
    expected = "rolled back the swap" if journal else "put back the previous output"
    assert expected in proc.stderr, proc.stderr
    assert _sha(out / "libmicroros.a") == good
    assert sorted(p.name for p in build.iterdir()) == ["COLCON_IGNORE", "cortex-m7"]


def _lib_sha(out: Path) -> str:
    return hashlib.sha256((out / "libmicroros.a").read_bytes()).hexdigest()


def test_an_output_belongs_to_one_target(m7_build: Path) -> None:
    """Issue 16, item 7: a cortex-m4 build into cortex-m7's output replaced it without a word."""
    ws = m7_build
    base = ["build", "--workspace", str(ws), "--meta", str(ws / "fixture.meta")]
    m7 = ws / "build" / "cortex-m7"
    good = _lib_sha(m7)
    m4 = ("--toolchain", "cortex-m4", *UP_TO_CORE)  # a cold first build: fx_core is enough of one
    proc = run_uros_here(*base, *m4, "--output", str(m7), check=False)  # in process
    assert proc.returncode == 2, proc.stderr
    line = next(x for x in proc.stderr.splitlines() if x.startswith("error:"))
    assert f"--output {m7}: is the output of target cortex-m7, not cortex-m4" in line
    assert "--force" in proc.stderr
    assert _lib_sha(m7) == good and json.loads((m7 / "build-info.json").read_text())["target"] == "cortex-m7"
    run_uros(*base, *m4, "--output", str(m7), "--force")
    assert json.loads((m7 / "build-info.json").read_text())["target"] == "cortex-m4"


@pytest.mark.colcon
def test_two_targets_building_into_one_output_never_both_win(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    shared = tmp_path / "shared"
    base = [
        sys.executable,
        "-m",
        "uros_build",
        "build",
        "--workspace",
        str(ws),
        "--meta",
        str(ws / "fixture.meta"),
        *UP_TO_CORE,  # two cold first builds racing for the output: fx_core is enough of one
    ]
    procs = {
        target: subprocess.Popen(
            [*base, "--toolchain", target, "--output", str(shared)], stderr=subprocess.PIPE, text=True
        )
        for target in ("cortex-m7", "cortex-m4")
    }
    codes = {
        target: (p.wait(timeout=600), p.stderr.read() if p.stderr else "") for target, p in procs.items()
    }
    assert sorted(code for code, _ in codes.values()) == [0, 2], codes
    winner = next(t for t, (code, _) in codes.items() if code == 0)
    loser = next(t for t, (code, _) in codes.items() if code == 2)
    assert f"is the output of target {winner}, not {loser}" in codes[loser][1]
    assert json.loads((shared / "build-info.json").read_text())["target"] == winner
