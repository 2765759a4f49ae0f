"""colcon/relocate.py: the CMake caches a moved or copied workspace holds are found (nested ones
too) and dropped once, and a build base records where it was checked."""

from __future__ import annotations

from pathlib import Path

from uros_build.colcon import relocate


def _cache(folder: Path, made_in: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "CMakeCache.txt"
    path.write_text(
        f"# For build in directory: {made_in}\nFOO:BOOL=ON\n"
        f"########################\nCMAKE_CACHEFILE_DIR:INTERNAL={made_in}\nCMAKE_HOME_DIRECTORY:INTERNAL=/src\n"
    )
    return path


def test_cache_dir_reads_the_internal_entry() -> None:
    assert relocate.cache_dir("A:STRING=x\nCMAKE_CACHEFILE_DIR:INTERNAL=/w/b d/x\n") == "/w/b d/x"
    assert relocate.cache_dir("# CMAKE_CACHEFILE_DIR:INTERNAL=/no\n") is None


def test_only_caches_made_elsewhere_are_dropped_nested_ones_too(tmp_path: Path) -> None:
    old, base = tmp_path / "old" / "build", tmp_path / "new" / "build"
    here = _cache(base / "pkg_here", base / "pkg_here")
    top = _cache(base / "vendor", old / "vendor")
    nested_dir = base / "vendor" / "up-prefix" / "src" / "up-build"
    nested = _cache(nested_dir, old / "vendor" / "up-prefix" / "src" / "up-build")
    # a copy: the old cache still exists, but it is another file
    _cache(old / "vendor", old / "vendor")
    dropped = relocate.forget_moved(base)
    assert sorted(c for c, _ in dropped) == sorted([top, nested])
    assert here.is_file() and not top.exists() and not nested.exists()
    assert relocate.was_in(dropped, base) == str(old)
    assert (base / relocate.RECORD).read_text() == f"{base}\n"
    # checked here once: a cache made elsewhere later is not looked for again
    _cache(base / "other", old / "other")
    assert relocate.forget_moved(base) == []


def test_a_symlinked_path_to_the_same_folder_is_no_move(tmp_path: Path) -> None:
    base = tmp_path / "real" / "build"
    _cache(base / "pkg", tmp_path / "link" / "build" / "pkg")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    assert relocate.forget_moved(base) == []
    assert (base / "pkg" / "CMakeCache.txt").is_file()


def test_a_build_base_not_made_yet_records_nothing(tmp_path: Path) -> None:
    assert relocate.forget_moved(tmp_path / "build") == []
    assert not (tmp_path / "build").exists()
