"""Fingerprints of build inputs and outputs (over files in a temporary folder; no process)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from uros_build.colcon import fingerprint as fp


def _sources(root: Path) -> None:
    (root / "pkg" / "src").mkdir(parents=True)
    (root / "pkg" / "package.xml").write_text("<package/>")
    (root / "pkg" / "src" / "a.c").write_text("int a;")
    (root / "ignored").mkdir()
    (root / "ignored" / "COLCON_IGNORE").write_text("")
    (root / "ignored" / "x.c").write_text("int x;")
    (root / "pkg" / ".git").mkdir()
    (root / "pkg" / ".git" / "index").write_text("git")
    (root / "pkg" / "__pycache__").mkdir()
    (root / "pkg" / "__pycache__" / "m.pyc").write_text("pyc")


def test_scan_tree_lists_what_colcon_would_read(tmp_path: Path) -> None:
    _sources(tmp_path)
    records = fp.scan_tree(tmp_path, {})
    assert sorted(records) == ["pkg/package.xml", "pkg/src/a.c"]


def test_scan_tree_hashes_only_files_whose_stat_changed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _sources(tmp_path)
    first = fp.scan_tree(tmp_path, {})
    hashed: list[Path] = []
    real = fp.file_sha256

    def counting(path: Path) -> str:
        hashed.append(path)
        return real(path)

    monkeypatch.setattr(fp, "file_sha256", counting)
    assert fp.scan_tree(tmp_path, first) == first and hashed == []
    a = tmp_path / "pkg" / "src" / "a.c"
    os.utime(a, ns=(1, 1))  # a touch: hashed again, same content, same digest
    touched = fp.scan_tree(tmp_path, first)
    assert hashed == [a] and fp.tree_digest(touched) == fp.tree_digest(first)
    a.write_text("int a = 2;")
    changed = fp.scan_tree(tmp_path, touched)
    assert fp.tree_digest(changed) != fp.tree_digest(first)
    assert fp.content_changed(touched, changed) == ["pkg/src/a.c"]


@pytest.mark.parametrize("change", ["add", "remove", "rename", "unignore"])
def test_tree_digest_sees_files_come_and_go(tmp_path: Path, change: str) -> None:
    _sources(tmp_path)
    before = fp.tree_digest(fp.scan_tree(tmp_path, {}))
    if change == "add":
        (tmp_path / "pkg" / "src" / "b.c").write_text("")
    elif change == "remove":
        (tmp_path / "pkg" / "src" / "a.c").unlink()
    elif change == "rename":
        (tmp_path / "pkg" / "src" / "a.c").rename(tmp_path / "pkg" / "src" / "b.c")
    else:
        (tmp_path / "ignored" / "COLCON_IGNORE").unlink()
    assert fp.tree_digest(fp.scan_tree(tmp_path, {})) != before


def test_sources_cache_round_trip(tmp_path: Path) -> None:
    _sources(tmp_path / "ws")
    records = fp.scan_tree(tmp_path / "ws", {})
    fp.save_sources_cache(tmp_path / "cache.json", records)
    assert fp.load_sources_cache(tmp_path / "cache.json") == records
    (tmp_path / "cache.json").write_text("{not json")
    assert fp.load_sources_cache(tmp_path / "cache.json") == {}


def _state(out: Path) -> fp.BuildState:
    return fp.BuildState(
        fingerprint="f",
        parts={"sources": "1", "colcon.meta": "2"},
        output=str(out),
        output_files=fp.stat_folder(out),
        library_sha256=fp.file_sha256(out / "libmicroros.a"),
        merge_key="m",
        packages=("a", "b"),
    )


def test_state_round_trip_and_odd_files(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "libmicroros.a").write_bytes(b"!<arch>\n")
    state = _state(out)
    fp.write_state(tmp_path / "state.json", state)
    assert fp.read_state(tmp_path / "state.json") == state
    for text in ("", "[]", '{"version": 99}', '{"version": 1}'):
        (tmp_path / "state.json").write_text(text)
        assert fp.read_state(tmp_path / "state.json") is None
    fp.forget_state(tmp_path / "state.json")
    assert fp.read_state(tmp_path / "state.json") is None


def test_output_intact(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "include").mkdir(parents=True)
    (out / "libmicroros.a").write_bytes(b"!<arch>\n")
    (out / "include" / "a.h").write_text("int a;")
    state = _state(out)
    sha = state.library_sha256
    assert fp.output_intact(state, out, "libmicroros.a", sha)
    assert not fp.output_intact(state, out, "libmicroros.a", "another")  # build-info disagrees
    assert not fp.output_intact(state, tmp_path / "elsewhere", "libmicroros.a", sha)
    (out / "include" / "b.h").write_text("")
    assert not fp.output_intact(state, out, "libmicroros.a", sha)  # a file more
    (out / "include" / "b.h").unlink()
    (out / "include" / "a.h").write_text("int b;")
    assert not fp.output_intact(state, out, "libmicroros.a", sha)  # a file changed


def test_combine_and_differing() -> None:
    a = {"sources": "1", "meta": "2"}
    assert fp.combine(a) == fp.combine(dict(reversed(list(a.items()))))
    assert fp.combine(a) != fp.combine({**a, "meta": "3"})
    assert fp.differing(a, {**a, "meta": "3", "new": "x"}) == ["meta", "new"]


def test_stat_key_names_the_real_file(tmp_path: Path) -> None:
    tool = tmp_path / "gcc-12"
    tool.write_text("#!")
    link = tmp_path / "gcc"
    link.symlink_to(tool)
    assert fp.stat_key(link) == fp.stat_key(tool) and str(tool) in fp.stat_key(link)
    assert fp.stat_key(tmp_path / "none") == ""


def test_scan_tree_leaves_out_an_output_folder_and_its_staging(tmp_path: Path) -> None:
    _sources(tmp_path)
    for folder in ("out", ".out.staging-12", "outside"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "f.h").write_text("")
    found = fp.scan_tree(tmp_path, {}, (str(tmp_path / "out"), str(tmp_path / ".out.")))
    assert sorted(found) == ["outside/f.h", "pkg/package.xml", "pkg/src/a.c"]


def test_content_changed_and_made_newer(tmp_path: Path) -> None:
    (tmp_path / "a.c").write_text("one\n")
    (tmp_path / "b.c").write_text("same\n")
    first = fp.scan_tree(tmp_path, {})
    assert fp.content_changed({}, first) == []  # a first walk builds everything anyway
    old = (tmp_path / "a.c").stat()
    (tmp_path / "a.c").write_text("two\n")
    os.utime(tmp_path / "a.c", ns=(old.st_atime_ns, old.st_mtime_ns - 10**9))  # `cp -p` of an older file
    (tmp_path / "c.c").write_text("new\n")
    second = fp.scan_tree(tmp_path, first)
    changed = fp.content_changed(first, second)
    assert changed == ["a.c", "c.c"]
    fp.make_newer(tmp_path, changed, second)
    assert (tmp_path / "a.c").stat().st_mtime_ns > old.st_mtime_ns
    assert (tmp_path / "a.c").read_text() == "two\n"
    assert second["a.c"].mtime_ns == (tmp_path / "a.c").stat().st_mtime_ns  # recorded: no rehash next time
    assert fp.scan_tree(tmp_path, second) == second


def test_a_file_written_in_place_with_its_old_stat_is_hashed_again(tmp_path: Path) -> None:
    src = tmp_path / "a.c"
    src.write_text("one\n")
    first = fp.scan_tree(tmp_path, {})
    st = src.stat()
    src.write_text("two\n")  # same size, same inode
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns))  # and the old mtime back: only ctime differs
    assert fp.scan_tree(tmp_path, first)["a.c"].sha256 != first["a.c"].sha256
