"""uros_build/files.py: the one home of atomic writes, write-if-changed, tree removal, locks and
"is this process still there" (issue 30, item 5)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from uros_build import files
from uros_build.errors import ConfigError

GONE = 2**31 - 2  # above any pid_max Linux allows: no such process


def test_a_temporary_name_is_hidden_beside_the_file_and_names_uros_and_the_writer(tmp_path: Path) -> None:
    assert files.temp_path(tmp_path / "state.json", pid=42) == str(tmp_path / ".state.json.uros-42")
    assert files.temp_path("state.json") == f".state.json.uros-{os.getpid()}"
    assert files.temp_pid(tmp_path / "state.json", ".state.json.uros-42") == 42
    assert files.temp_pid(tmp_path / "state.json", ".state.json.uros-x") is None
    assert files.temp_pid(tmp_path / "state.json", ".other.json.uros-42") is None


def test_write_atomic_makes_the_folder_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    path = tmp_path / "a" / "b" / "file.txt"
    files.write_atomic(path, "one\n")
    assert path.read_text(encoding="utf-8") == "one\n"
    files.write_atomic(path, b"\x00two")
    assert path.read_bytes() == b"\x00two"
    assert sorted(p.name for p in path.parent.iterdir()) == ["file.txt"]


def test_a_write_that_fails_leaves_the_old_file_and_no_temporary_file(tmp_path: Path) -> None:
    folder = tmp_path / "taken"
    (folder / "inside").mkdir(parents=True)  # a folder where the file should go: the rename fails
    with pytest.raises(OSError):
        files.write_atomic(folder, "text")
    assert folder.is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_sync_puts_the_data_on_the_disk_before_the_rename(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    synced: list[int] = []
    monkeypatch.setattr(files.os, "fsync", synced.append)
    files.write_atomic(tmp_path / "journal", "{}")
    assert synced == []
    files.write_atomic(tmp_path / "journal", "{}", sync=True)
    assert len(synced) == 1


def test_write_if_changed_keeps_a_file_whose_content_is_already_there(tmp_path: Path) -> None:
    path = tmp_path / "toolchain.cmake"
    assert files.write_if_changed(path, "set(A 1)\n")
    os.utime(path, (1000, 1000))
    assert not files.write_if_changed(path, "set(A 1)\n")
    assert path.stat().st_mtime == 1000
    assert files.write_if_changed(path, "set(A 2)\n")
    assert path.read_text(encoding="utf-8") == "set(A 2)\n"
    assert files.write_if_changed(path, b"\x01")  # bytes compared as bytes
    assert not files.write_if_changed(path, b"\x01")


def test_write_if_changed_replaces_a_file_that_is_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "colcon.meta"
    path.write_bytes(b"\xff\xfe")
    assert files.write_if_changed(path, "{}\n")
    assert path.read_text(encoding="utf-8") == "{}\n"


def test_leftover_temps_are_those_of_writers_that_are_gone(tmp_path: Path) -> None:
    journal = tmp_path / ".out.swap"
    gone = Path(files.temp_path(journal, pid=GONE))
    mine = Path(files.temp_path(journal))
    for path in (gone, mine, tmp_path / ".other.uros-1", tmp_path / f".out.swap.uros-{GONE}x"):
        path.write_text("", encoding="utf-8")
    assert files.leftover_temps(journal) == [str(gone)]
    assert files.leftover_temps(tmp_path / "missing" / "file") == []


def test_link_atomic_replaces_a_link(tmp_path: Path) -> None:
    latest = tmp_path / "latest.log"
    files.link_atomic(latest, "one.log")
    files.link_atomic(latest, "two.log")
    assert os.readlink(latest) == "two.log"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["latest.log"]


def test_remove_tree_removes_read_only_folders_files_and_links(tmp_path: Path) -> None:
    tree = tmp_path / "out"
    (tree / "sub").mkdir(parents=True)
    (tree / "sub" / "lib.a").write_bytes(b"!<arch>\n")
    (tree / "sub").chmod(stat.S_IRUSR | stat.S_IXUSR)
    assert files.remove_tree(tree) is None and not tree.exists()
    kept = tmp_path / "kept"
    kept.mkdir()
    link = tmp_path / "link"
    link.symlink_to(kept)
    assert files.remove_tree(link) is None
    assert kept.is_dir() and not link.exists()
    assert files.remove_tree(tmp_path / "none") is None


def test_pid_alive() -> None:
    assert files.pid_alive(os.getpid())
    assert files.pid_alive(os.getppid())
    assert not files.pid_alive(GONE)


def test_lock_holder() -> None:
    assert files.lock_holder("1234\n") == 1234
    assert files.lock_holder("") is None and files.lock_holder("x\n") is None


def test_locked_makes_the_folder_and_names_its_holder(tmp_path: Path) -> None:
    folder = tmp_path / "targets" / "cortex-m7"
    with files.locked(folder, "cortex-m7"):
        assert files.lock_holder((folder / files.LOCK_OWNER).read_text(encoding="utf-8")) == os.getpid()
        assert (folder / files.LOCK_FILE).exists()


@pytest.mark.skipif(os.name != "posix", reason="flock")
def test_a_lock_taken_without_filelock_still_excludes_filelock_and_itself(tmp_path: Path) -> None:
    """A lock is one flock, without importing filelock (the file made the first time); it and
    filelock's lock on the same file exclude each other both ways."""
    import filelock

    with files.locked(tmp_path, "cortex-m7"):  # the file made
        assert (tmp_path / files.LOCK_FILE).is_file()
        assert files._flock_free(str(tmp_path / files.LOCK_FILE)) is None  # held: not taken twice
    fd = files._flock_free(str(tmp_path / files.LOCK_FILE))
    assert fd is not None
    try:
        with pytest.raises(filelock.Timeout):
            filelock.FileLock(str(tmp_path / files.LOCK_FILE)).acquire(timeout=0)
        assert files._flock_free(str(tmp_path / files.LOCK_FILE)) is None
    finally:
        os.close(fd)
    with files.locked(tmp_path, "cortex-m7"):  # the fast way, released at the end
        assert files.lock_holder((tmp_path / files.LOCK_OWNER).read_text(encoding="utf-8")) == os.getpid()
    lock = filelock.FileLock(str(tmp_path / files.LOCK_FILE))
    lock.acquire(timeout=0)  # free again, and filelock's hold keeps the fast way out
    assert files._flock_free(str(tmp_path / files.LOCK_FILE)) is None
    lock.release()


@pytest.mark.skipif(os.name != "posix", reason="symlinks and flock")
def test_a_lock_file_that_is_a_link_is_left_to_filelock(tmp_path: Path) -> None:
    (tmp_path / "elsewhere").write_text("", encoding="utf-8")
    (tmp_path / files.LOCK_FILE).symlink_to(tmp_path / "elsewhere")
    assert files._flock_free(str(tmp_path / files.LOCK_FILE)) is None


def test_a_folder_where_the_lock_file_goes_is_refused(tmp_path: Path) -> None:
    (tmp_path / files.LOCK_FILE).mkdir()
    refused = pytest.raises(
        ConfigError, match="is a folder, where uros keeps the lock file of the host stage"
    )
    with refused, files.locked(tmp_path, "the host stage"):
        pass


def test_the_shim_pays_for_no_import_of_files() -> None:
    """The Python shim imports files.py on every generator run (shim/gencache.py): at its top only
    what a virtual environment's Python has imported at its start (contextlib it has not: importing
    it brought collections and functools, ~3 ms of each run)."""
    import ast

    tree = ast.parse(Path(files.__file__).read_text(encoding="utf-8"))
    top = {
        alias.name.split(".")[0] for node in tree.body if isinstance(node, ast.Import) for alias in node.names
    } | {node.module.split(".")[0] for node in tree.body if isinstance(node, ast.ImportFrom) and node.module}
    assert top <= {"__future__", "os", "sys"}, top
