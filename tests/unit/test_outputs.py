"""Output folders (issue 8, data loss): target names and keys, the marker, the guard, the journaled
swap and its recovery, and the pure pieces of fault handling (ENOSPC, damaged configures and
archives, leftover processes, signals). No process is started: the swap runs on tmp folders."""

from __future__ import annotations

import hashlib
import json
import os
import signal
from pathlib import Path

import pytest

from uros_build import files
from uros_build.colcon.damage import archive_damage, configure_damage, ninja_deps_damage
from uros_build.errors import (
    ConfigError,
    DiskFull,
    HungUp,
    Interrupted,
    Signalled,
    Terminated,
    disk_full_message,
    file_being_written,
    written_path,
)
from uros_build.errors import interrupted as interrupted_error
from uros_build.output import folders as outputs
from uros_build.output import swap
from uros_build.output.swap import Journal, Move, recovery_actions
from uros_build.proc import Runner, environ_has
from uros_build.sources.workspace import Workspace, target_key
from uros_build.tooltext import disk_full_line, disk_full_path

DEAD = 2**22 + 1000  # above the largest pid_max Linux allows: never a live process


# -- target keys ------------------------------------------------------------------------------


@pytest.mark.parametrize("stem", [".", "..", "", ".cmake", "-x", "_x"])
def test_a_target_key_is_never_a_path_or_hidden(stem: str) -> None:
    with pytest.raises(ConfigError, match="cannot name a target folder"):
        target_key(stem, "--toolchain t.cmake")


def test_a_target_key_keeps_a_plain_name() -> None:
    assert target_key("cortex-m7") == "cortex-m7"
    assert target_key("my board (v2)") == "my_board__v2_"


@pytest.mark.parametrize("key", ["..", ".", "", "a/b", "../x"])
def test_target_folders_stay_inside_the_workspace(tmp_path: Path, key: str) -> None:
    ws = Workspace(tmp_path)
    with pytest.raises(ConfigError, match="cannot name a target folder"):
        ws.target_dir(key)
    with pytest.raises(ConfigError, match="cannot name a target folder"):
        ws.default_output(key)
    assert ws.default_output("cortex-m7") == tmp_path / "build" / "cortex-m7"


# -- the marker and the guard -----------------------------------------------------------------


def _output(folder: Path, *extra: str) -> Path:
    """A uros output as `uros build` writes it (with its marker), plus ``extra`` files of the user's."""
    (folder / "include" / "pkg").mkdir(parents=True)
    (folder / "include" / "pkg" / "a.h").write_text("int a;\n")
    (folder / "libmicroros.a").write_bytes(b"!<arch>\n")
    (folder / "build-info.json").write_text("{}\n")
    outputs.write_marker(folder, "cortex-m7", ["include", "libmicroros.a", "build-info.json"])
    for name in extra:
        (folder / name).write_text("mine\n")
    return folder


def test_a_file_named_build_info_json_is_not_a_uros_output(tmp_path: Path) -> None:
    (tmp_path / "build-info.json").write_text("{}\n")
    assert outputs.owned_entries(tmp_path) is None
    (tmp_path / "build-info.json").write_text(json.dumps({"generated_by": "uros 0.1.0"}))
    assert outputs.owned_entries(tmp_path) is None


def test_the_marker_names_what_uros_wrote(tmp_path: Path) -> None:
    out = _output(tmp_path / "out")
    assert outputs.owned_entries(out) == {"include", "libmicroros.a", "build-info.json", ".uros-output"}
    assert outputs.parse_marker('{"generated_by": "someone", "files": []}') is None
    assert outputs.parse_marker('{"generated_by": "uros 1", "files": ["../x"]}') is None
    assert outputs.parse_marker("not json") is None


def test_an_output_of_uros_before_the_marker_is_known_by_its_library(tmp_path: Path) -> None:
    lib = b"!<arch>\nlibrary bytes"
    (tmp_path / "libmicroros.a").write_bytes(lib)
    info = {
        "generated_by": "uros 0.1.0",
        "target": "cortex-m7",
        "library": {"file": "libmicroros.a", "sha256": hashlib.sha256(lib).hexdigest()},
    }
    (tmp_path / "build-info.json").write_text(json.dumps(info))
    assert outputs.owned_entries(tmp_path) == {"libmicroros.a", "build-info.json"}
    (tmp_path / "libmicroros.a").write_bytes(b"another library")
    assert outputs.owned_entries(tmp_path) is None


def test_the_guard_refuses_a_users_folder_without_force(tmp_path: Path) -> None:
    """The reproduction of issue 8, item 2: `echo {} > proj/build-info.json`."""
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / "src" / "main.c").write_text("int main(void) { return 0; }\n")
    (proj / "build-info.json").write_text("{}\n")
    with pytest.raises(ConfigError, match=r"holds files uros did not write \(build-info.json, src\)"):
        outputs.check_output_dir(proj, force=False)
    outputs.check_output_dir(proj, force=True)  # allowed: uros writes its entries, keeps src/


@pytest.mark.parametrize(
    ("layout", "message"),
    [
        (["mcu_ws/src/pkg/package.xml"], r"holds mcu_ws, so it is a workspace or its sources"),
        (["src/pkg/package.xml"], r"holds src/pkg/package.xml"),
        (["uros.yaml"], r"holds uros.yaml"),
        (["cortex-m7/.uros-output"], r"holds the uros output cortex-m7/ of another target"),
    ],
)
def test_the_guard_never_takes_sources_or_other_outputs_even_with_force(
    tmp_path: Path, layout: list[str], message: str
) -> None:
    out = tmp_path / "out"
    for rel in layout:
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text('{"generated_by": "uros 1", "files": []}' if rel.endswith("output") else "")
    with pytest.raises(ConfigError, match=message):
        outputs.check_output_dir(out, force=True)


def test_the_guard_never_takes_the_workspace_or_its_trees(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    (ws / "mcu_ws" / "src" / "p").mkdir(parents=True)
    (ws / "mcu_ws" / "src" / "p" / "package.xml").write_text("<package/>")
    for out, message in (
        (ws, "is the workspace"),
        (tmp_path, "holds it"),
        (ws / "mcu_ws" / "out", r"inside the workspace's mcu_ws/"),
        (ws / ".uros" / "targets", r"inside the workspace's .uros/"),
    ):
        with pytest.raises(ConfigError, match=message):
            outputs.check_output_dir(out, True, "--output", ws)
    outputs.check_output_dir(ws / "build" / "cortex-m7", False, "--output", ws)


def test_the_guard_accepts_a_uros_output_and_a_half_done_swap(tmp_path: Path) -> None:
    outputs.check_output_dir(_output(tmp_path / "out", "notes.txt"), force=False)
    half = tmp_path / "half"
    half.mkdir()
    (half / "notes.txt").write_text("mine")
    (half / outputs.JOURNAL).write_text("{}")
    outputs.check_output_dir(half, force=False)


# -- the swap -----------------------------------------------------------------------------------


def _staging(out: Path, text: str = "new") -> Path:
    staging = out.with_name(f".{out.name}.staging-{os.getpid()}")
    (staging / "include" / "pkg").mkdir(parents=True)
    (staging / "include" / "pkg" / "b.h").write_text("int b;\n")
    (staging / "libmicroros.a").write_text(text)
    (staging / "build-info.json").write_text("{}\n")
    outputs.write_marker(staging, "cortex-m7", ["include", "libmicroros.a", "build-info.json"])
    return staging


def _tree(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_a_swap_replaces_the_whole_output_and_leaves_nothing_beside_it(tmp_path: Path) -> None:
    out = _output(tmp_path / "out")
    assert swap.install_output(_staging(out), out) == []
    assert (out / "libmicroros.a").read_text() == "new"
    assert not (out / "include" / "pkg" / "a.h").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_swap_keeps_the_users_files(tmp_path: Path) -> None:
    out = _output(tmp_path / "out", "notes.txt")
    (out / "toolchain.cmake").write_text("an earlier build's")
    outputs.add_to_marker(out, ["toolchain.cmake"])
    swap.install_output(_staging(out), out)
    assert (out / "notes.txt").read_text() == "mine\n"
    assert (out / "libmicroros.a").read_text() == "new"
    assert not (out / "toolchain.cmake").exists()  # uros's, and this build wrote none
    assert _tree(out) == [
        ".uros-output", "build-info.json", "include", "include/pkg", "include/pkg/b.h", "libmicroros.a",
        "notes.txt",
    ]  # fmt: skip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_force_into_a_users_folder_replaces_only_uros_files(tmp_path: Path) -> None:
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / "src" / "main.c").write_text("int main(void) { return 0; }\n")
    (proj / "build-info.json").write_text("{}\n")
    swap.install_output(_staging(proj), proj)
    assert (proj / "src" / "main.c").read_text() == "int main(void) { return 0; }\n"
    assert outputs.owned_entries(proj) == {"include", "libmicroros.a", "build-info.json", ".uros-output"}


def test_a_read_only_previous_output_is_removed(tmp_path: Path) -> None:
    out = _output(tmp_path / "out")
    (out / "include" / "pkg").chmod(0o555)
    (out / "include").chmod(0o555)
    assert swap.install_output(_staging(out), out) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# -- recovery (pure) ----------------------------------------------------------------------------

FOLDER_SWAP = Journal(DEAD, (Move("cortex-m7", ".cortex-m7.staging-9", ".cortex-m7.old-9"),))
ENTRY_SWAP = Journal(
    DEAD,
    (
        Move("include", ".uros-new-9/include", ".uros-old-9/include"),
        Move("libmicroros.a", ".uros-new-9/libmicroros.a", ".uros-old-9/libmicroros.a"),
        Move("toolchain.cmake", None, ".uros-old-9/toolchain.cmake"),
    ),
    (".uros-new-9", ".uros-old-9"),
)


@pytest.mark.parametrize(
    ("journal", "exists", "verdict", "actions"),
    [
        # journal written, nothing renamed: drop the staging
        (FOLDER_SWAP, {"cortex-m7", ".cortex-m7.staging-9"}, "rolled back", [("remove", ".cortex-m7.staging-9")]),
        # killed between the two renames (the window of issue 8, item 5): the previous output back
        (
            FOLDER_SWAP,
            {".cortex-m7.old-9", ".cortex-m7.staging-9"},
            "rolled back",
            [("rename", ".cortex-m7.old-9", "cortex-m7"), ("remove", ".cortex-m7.staging-9")],
        ),
        # both renames done, the old one not yet removed: finish
        (FOLDER_SWAP, {"cortex-m7", ".cortex-m7.old-9"}, "finished", [("remove", ".cortex-m7.old-9")]),
        # no previous output, killed before the rename: drop the staging
        (FOLDER_SWAP, {".cortex-m7.staging-9"}, "rolled back", [("remove", ".cortex-m7.staging-9")]),
        # entries: one new entry in, another still waiting: undo all
        (
            ENTRY_SWAP,
            {"include", ".uros-old-9/include", ".uros-old-9/libmicroros.a", ".uros-new-9",
             ".uros-new-9/libmicroros.a", ".uros-old-9", ".uros-old-9/toolchain.cmake"},
            "rolled back",
            [("remove", "include"), ("rename", ".uros-old-9/include", "include"),
             ("rename", ".uros-old-9/libmicroros.a", "libmicroros.a"),
             ("rename", ".uros-old-9/toolchain.cmake", "toolchain.cmake"),
             ("remove", ".uros-new-9/libmicroros.a"), ("remove", ".uros-new-9"), ("remove", ".uros-old-9")],
        ),
        # entries: all new entries in: finish
        (
            ENTRY_SWAP,
            {"include", "libmicroros.a", ".uros-old-9/include", ".uros-new-9", ".uros-old-9"},
            "finished",
            [("remove", ".uros-old-9/include"), ("remove", ".uros-new-9"), ("remove", ".uros-old-9")],
        ),
    ],
)  # fmt: skip
def test_recovery_finishes_or_rolls_back(
    journal: Journal, exists: set[str], verdict: str, actions: list[tuple[str, ...]]
) -> None:
    assert recovery_actions(journal, exists) == (verdict, actions)


def test_a_journal_reads_back_and_refuses_paths_outside_its_folder() -> None:
    assert swap.parse_journal(ENTRY_SWAP.to_json()) == ENTRY_SWAP
    bad = json.dumps({"pid": 1, "moves": [{"dest": "../../home", "new": None, "old": "x"}]})
    with pytest.raises(ValueError, match="not a path inside the folder"):
        swap.parse_journal(bad)


# -- recovery on disk ---------------------------------------------------------------------------


def test_recover_puts_back_an_output_a_killed_swap_moved_aside(tmp_path: Path) -> None:
    out = _output(tmp_path / "cortex-m7")
    staging = _staging(out)
    old = tmp_path / f".cortex-m7.old-{DEAD}"
    out.rename(old)
    journal = Journal(DEAD, (Move("cortex-m7", staging.name, old.name),))
    (tmp_path / ".cortex-m7.swap").write_text(journal.to_json())
    done = swap.recover(out)
    assert "rolled back the swap" in done[0] and "the previous output is back" in done[0]
    assert (out / "include" / "pkg" / "a.h").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cortex-m7"]


def test_a_journal_is_carried_out_once_by_runs_that_find_it_together(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`uros info`/`uros size` finish a killed swap as a build would (issue 34, item 7), so two
    runs may find one journal: each claims it by a rename, the one whose rename fails does
    nothing; a claim left by a run killed while carrying it out is taken over; a reader never
    removes the journal a live run may be writing (.swap.tmp)."""
    out = _output(tmp_path / "cortex-m7")
    staging = _staging(out)
    old = tmp_path / f".cortex-m7.old-{DEAD}"
    out.rename(old)
    journal_path = tmp_path / ".cortex-m7.swap"
    journal_path.write_text(Journal(DEAD, (Move("cortex-m7", staging.name, old.name),)).to_json())
    (tmp_path / ".cortex-m7.swap.tmp").write_text("being written")

    def other_run_claims_first(pid: int) -> bool:  # between this run's read and its claim
        if journal_path.exists():
            journal_path.rename(tmp_path / f".cortex-m7.swap.claimed-{os.getpid() + 1}")
        return False

    monkeypatch.setattr(swap, "pid_alive", other_run_claims_first)
    assert swap.finish_swaps(out, tidy=False) == []
    assert not out.exists()  # the other run carries it out
    # ... and is killed doing so: its claim is taken over by the next run
    (tmp_path / f".cortex-m7.swap.claimed-{os.getpid() + 1}").rename(
        tmp_path / f".cortex-m7.swap.claimed-{DEAD}"
    )
    monkeypatch.setattr(swap, "pid_alive", lambda pid: pid == os.getpid())
    done = swap.finish_swaps(out, tidy=False)
    assert len(done) == 1 and "rolled back the swap" in done[0], done
    assert (out / "include" / "pkg" / "a.h").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".cortex-m7.swap.tmp", "cortex-m7"]


def test_recover_without_a_journal_puts_back_the_old_folder(tmp_path: Path) -> None:
    """The state a uros without the journal left (issue 8, item 5): no output, `.X.old-PID`."""
    out = _output(tmp_path / "cortex-m7")
    out.rename(tmp_path / f".cortex-m7.old-{DEAD}")
    (tmp_path / f".cortex-m7.staging-{DEAD}").mkdir()
    (tmp_path / ".cortex-m7.staging-1").mkdir()  # pid 1 is alive: another run's, left alone
    done = swap.recover(out)
    assert any("put back the previous output" in line for line in done), done
    assert (out / "include" / "pkg" / "a.h").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".cortex-m7.staging-1", "cortex-m7"]


def test_recover_removes_what_runs_that_are_gone_left_inside_an_output(tmp_path: Path) -> None:
    out = _output(tmp_path / "out", "notes.txt")
    (out / f".uros-staging-{DEAD}").mkdir()
    (out / f".uros-old-{DEAD}").mkdir()
    swap.recover(out)
    assert sorted(p.name for p in out.iterdir()) == [
        ".uros-output", "build-info.json", "include", "libmicroros.a", "notes.txt",
    ]  # fmt: skip


# -- faults (pure) ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "data", "why"),
    [
        ("CMakeFiles/rules.ninja", b"", "CMakeFiles/rules.ninja is empty"),
        ("build.ninja", b"rule CC\n  command = gcc", "build.ninja is cut short"),
        ("build.ninja", b"default all\n\0\0\0", "build.ninja holds NUL bytes"),
        ("CMakeCache.txt", b"CMAKE_C_COMPILER:FILEPATH=/usr/bin/gcc\n", "no INTERNAL entries"),
        ("CMakeCache.txt", b"X:STRING=1\nCMAKE_UNAME:INTERNAL=/usr/bin/uname\n", None),
        ("build.ninja", b"default all\n", None),
    ],
)
def test_configure_damage(name: str, data: bytes, why: str | None) -> None:
    found = configure_damage(name, len(data), data)
    assert (found is None) if why is None else (found is not None and why in found)


@pytest.mark.parametrize(
    ("head", "why"),
    [
        (b"", "cut short in its header"),  # made, nothing written: what the full disk left
        (b"# ninjadeps\n", "cut short in its header"),  # no version
        (b"# ninja log v5\n\0\0\0\0", "cut short in its header"),  # not a dependency log
        (b"# ninjadeps\n\x04\0\0\0", None),  # a header ninja reads (a record cut after it ninja recovers)
    ],
)
def test_ninja_deps_damage(head: bytes, why: str | None) -> None:
    """ninja deletes a dependency log whose header is cut and then fails `ninja -t recompact`
    (CMake runs it after every configure): such a log is damage, found before the build."""
    found = ninja_deps_damage(head)
    assert (found is None) if why is None else (found is not None and why in found)


def _ar(*members: tuple[str, bytes]) -> bytes:
    out = b"!<arch>\n"
    for name, data in members:
        out += f"{name + '/':<16}{0:<12}{0:<6}{0:<6}{644:<8}{len(data):<10}`\n".encode() + data
        out += b"\n" if len(data) % 2 else b""
    return out


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (_ar(("a.o", b"abc"), ("b.o", b"defg")), None),
        (_ar(("a.o", b"abc"), ("b.o", b"defg"))[:-2], "cut short"),
        (_ar(("a.o", b"abc"), ("b.o", b"defg"))[:70], "cut short"),
        (b"", "not an ar archive"),
        (b"\0" * 64, "not an ar archive"),
    ],
)
def test_archive_damage(data: bytes, why: str | None) -> None:
    found = archive_damage(len(data), lambda offset, length: data[offset : offset + length])
    assert (found is None) if why is None else (found is not None and why in found)


def test_disk_full_is_one_line_with_the_path_and_the_free_space() -> None:
    line = (
        "[2.1s] ERROR:colcon: Exception in event handler: [Errno 28] No space left on device [/w/log/x.log]"
    )
    found = disk_full_line(["-- Configuring done", line, "more"])
    assert found == "Exception in event handler: [Errno 28] No space left on device [/w/log/x.log]"
    assert disk_full_path(found) == "/w/log/x.log"
    # the file being written, not the tool that says so (issue 16, item 9)
    ar = "/usr/bin/arm-none-eabi-ar: /o/.uros-staging-1/libmicroros.a: No space left on device"
    assert disk_full_path(ar) == "/o/.uros-staging-1/libmicroros.a"
    assert (
        disk_full_path("cc1: fatal error: error writing to /tmp/ccA.s: No space left on device")
        == "/tmp/ccA.s"
    )
    assert disk_full_path("OSError: [Errno 28] No space left on device: '/o/x.h'") == "/o/x.h"
    assert disk_full_line(["cc1: fatal error: error writing to /tmp/ccA.s: Disk quota exceeded"])
    assert disk_full_line(["error: expected ';'"]) is None
    text = disk_full_message("writing /w/.uros/log/x.log", "/w/.uros/log/x.log", 12 * 1024)
    assert (
        text
        == "no space left on device: writing /w/.uros/log/x.log (12.0 KiB free on the disk of /w/.uros/log/x.log)"
    )
    assert "\n" not in text


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full (Linux's always-full device)")
def test_a_write_that_fills_the_disk_names_its_file(tmp_path: Path) -> None:
    """A write, flush or close on a full disk raises ENOSPC with no filename: the file comes off the
    traceback (pathlib's frame, or a file object open for writing), never the run's log."""
    full = Path("/dev/full")
    with pytest.raises(OSError) as pathlib_write:
        full.write_text("x")
    assert pathlib_write.value.filename is None
    assert file_being_written(pathlib_write.value.__traceback__) == "/dev/full"

    def copy_into_full() -> None:
        with open(str(tmp_path / "source"), "w") as src:  # written first, and fine
            src.write("kept")
        with open(tmp_path / "source") as reading, open(full, "w") as out:
            out.write(reading.read())

    with pytest.raises(OSError) as own_write:
        copy_into_full()
    assert file_being_written(own_write.value.__traceback__) == "/dev/full"
    assert file_being_written(None) is None


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full (Linux's always-full device)")
def test_a_full_disk_in_a_copy_names_the_destination(tmp_path: Path) -> None:
    """shutil's sendfile copy reports ENOSPC with the source in filename and the destination in
    filename2: the destination's disk is the full one (the output's, not the workspace's)."""
    import errno

    copy = OSError(errno.ENOSPC, "No space left on device")
    copy.filename, copy.filename2 = "/ws/.uros/targets/m7/install/include/a.h", "/out/.staging/include/a.h"
    assert written_path(copy) == "/out/.staging/include/a.h"
    opened = OSError(errno.ENOSPC, "No space left on device", "/out/x.a")
    assert written_path(opened) == "/out/x.a"
    with pytest.raises(OSError) as written:
        Path("/dev/full").write_bytes(b"x")
    assert written_path(written.value) == "/dev/full"


def test_a_full_disk_a_tool_names_no_file_for_is_where_the_step_writes(tmp_path: Path) -> None:
    """colcon says "Exception in shell extension 'sh': [Errno 28] No space left on device" with no
    path: the disk is the step's (the target's trees), not the folder it ran in (the workspace)."""
    trees = tmp_path / "ws" / ".uros" / "targets" / "cortex-m7"
    trees.mkdir(parents=True)
    runner = Runner(log_path=tmp_path / "ws" / ".uros" / "log" / "run.log")
    line = "Exception in shell extension 'sh': [Errno 28] No space left on device"
    with pytest.raises(DiskFull) as full:
        runner._failed("colcon build", 1, [line], None, writes_to=trees)
    assert full.value.message.endswith(f"free on the disk of {trees})"), full.value.message
    with pytest.raises(DiskFull) as named:  # a path in the message still wins
        runner._failed("colcon build", 1, [f"{line} [/o/x.log]"], None, writes_to=trees)
    assert "disk of /o/x.log" in named.value.message


def test_leftover_processes_are_found_by_their_exact_mark() -> None:
    environ = b"PATH=/bin\0UROS_OWNER=/w/.uros/targets/cortex-m7\0HOME=/root\0"
    assert environ_has(environ, "UROS_OWNER", "/w/.uros/targets/cortex-m7")
    assert not environ_has(environ, "UROS_OWNER", "/w/.uros/targets/cortex-m")
    assert not environ_has(b"X=UROS_OWNER=/w/.uros/targets/cortex-m7\0", "UROS_OWNER", "/w")


def test_signals_map_to_exit_codes() -> None:
    assert isinstance(interrupted_error(KeyboardInterrupt(), "x", "h"), Interrupted)
    term = interrupted_error(Signalled(signal.SIGTERM), "colcon build was interrupted", "h")
    assert isinstance(term, Terminated) and term.exit_code == 143
    assert term.message == "colcon build was interrupted (SIGTERM)"
    assert interrupted_error(Signalled(signal.SIGHUP), "x", "h").exit_code == HungUp.exit_code == 129
    assert interrupted_error(None, "x", "h").exit_code == 130


def test_mount_points_read_octal_escapes() -> None:
    info = "36 35 98:0 /mnt1 /mnt/my\\040volume rw,noatime master:1 - ext3 /dev/root rw\n"
    assert outputs.mount_points(info) == {"/mnt/my volume"}


def test_recover_leaves_a_file_and_a_missing_folder_alone(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    assert swap.recover(notes) == [] and notes.read_text() == "mine"
    assert swap.recover(tmp_path / "none" / "out") == []


def test_recover_removes_a_journal_a_killed_run_was_writing(tmp_path: Path) -> None:
    """A run killed while writing its journal (before the rename, files.write_atomic) left only the
    temporary file: nothing to undo, the file is removed; a live writer's stays."""
    out = _output(tmp_path / "cortex-m7")
    journal = tmp_path / ".cortex-m7.swap"
    killed = Path(files.temp_path(journal, pid=DEAD))
    writing = Path(files.temp_path(journal))
    killed.write_text("{")
    writing.write_text("{")
    assert swap.recover(out) == []
    assert not killed.exists() and writing.exists()
