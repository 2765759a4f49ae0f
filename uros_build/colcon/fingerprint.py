"""Fingerprints of a target's build inputs and of its output, so that nothing changed means
nothing done.

A build's inputs are named parts (the package sources, the merged colcon.meta, the rendered
toolchain file, the profile, the compiler, the tool versions, the dev_ws marker, the requested
package set, ...), each reduced to a digest; their combination is the build's fingerprint. The
last successful build's fingerprint is kept in ``.uros/targets/<key>/state.json`` with what it
wrote; when the next build's is equal and the output folder is still what was written, the build
is up to date.

The package sources are fingerprinted by a stat walk (``os.scandir``: ~10k files in well under a
second); a file's content is hashed only when its size, mtime, inode or ctime differ from the last
walk (kept in ``sources-cache.json``), so a ``touch`` costs one hash and changes nothing. A file
whose content changed is given a new mtime, so that the build tools, which go by mtimes, see it.

Reads and writes files; starts no process.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uros_build.files import write_atomic

STATE = "state.json"
SOURCES_CACHE = "sources-cache.json"
STATE_VERSION = 1
# Folders whose files never reach a build: version control, and Python's bytecode caches (the
# rosidl generators' own packages get them when they run).
_SKIPPED_DIRS = frozenset({".git", ".hg", ".svn", "__pycache__"})
_IGNORE_MARKER = "COLCON_IGNORE"  # colcon skips such a folder, and so does the fingerprint


def digest(*parts: str | bytes) -> str:
    h = hashlib.sha256()
    for part in parts:
        data = part.encode("utf-8", "surrogateescape") if isinstance(part, str) else part
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def digest_json(value: Any) -> str:
    return digest(json.dumps(value, sort_keys=True, default=_jsonable))


def _jsonable(value: Any) -> Any:
    if isinstance(value, tuple | frozenset | set):
        return sorted(value) if not isinstance(value, tuple) else list(value)
    if isinstance(value, Path):
        return str(value)
    return repr(value)


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def program_sha256(path: Path) -> str:
    """A program's sha256 (the compiler driver's: a build asks four times), hashed once a run for
    the same file: the cache is keyed by the file's full stat (a write changes its ctime), and
    lives only as long as the run."""
    st = os.stat(path)
    return _program_sha256(str(path), st.st_size, st.st_mtime_ns, st.st_ino, st.st_ctime_ns)


@functools.cache
def _program_sha256(path: str, size: int, mtime: int, inode: int, ctime: int) -> str:
    return file_sha256(Path(path))


@functools.cache
def uros_code_digest() -> str:
    """uros's own code by content: its version and every module's bytes (a development checkout
    changes without a version). Read once a run: the build key and the toolchain's render both
    ask."""
    import uros_build

    code = Path(uros_build.__file__).parent
    return digest(uros_build.__version__, *(p.read_bytes() for p in sorted(code.rglob("*.py"))))


def stat_key(path: Path) -> str:
    """A program's identity without running it: where it is and its file's size, mtime and
    inode (a package upgrade replaces the file). "" when it is not there."""
    try:
        real = os.path.realpath(path)
        st = os.stat(real)
    except OSError:
        return ""
    # ctime too: a file written in place and given back its old mtime (`cp -p`, `touch -r`) keeps
    # size, mtime and inode, but no one can set its ctime
    return f"{real}:{st.st_size}:{st.st_mtime_ns}:{st.st_ino}:{st.st_ctime_ns}"


# ---------------------------------------------------------------------------------------------
# the source tree


@dataclass(frozen=True)
class FileRecord:
    size: int
    mtime_ns: int
    inode: int
    sha256: str
    ctime_ns: int = 0


def _walk(root: Path, exclude: tuple[str, ...] = ()) -> Iterator[tuple[str, os.stat_result]]:
    """(path relative to root, stat) of every file colcon could read under root: folders
    holding COLCON_IGNORE are left out, symlinked folders followed once, and folders whose path
    is an ``exclude`` entry (or starts with one that ends in '.', a prefix such as
    ``/ws/.out.``). Strings and os.scandir only: this runs over ~10k files on every build."""
    top = str(root)
    cut = len(top) + 1
    seen: set[tuple[int, int]] = set()
    stack = [top]
    while stack:
        folder = stack.pop()
        try:
            entries = list(os.scandir(folder))
        except OSError:
            continue
        if folder != top and any(e.name == _IGNORE_MARKER for e in entries):
            continue
        for entry in entries:
            try:
                if entry.is_dir():
                    if entry.name in _SKIPPED_DIRS or (exclude and _excluded(entry.path, exclude)):
                        continue
                    if entry.is_symlink():  # a folder linked in: once, and never a loop
                        st = entry.stat()
                        if (st.st_dev, st.st_ino) in seen:
                            continue
                        seen.add((st.st_dev, st.st_ino))
                    stack.append(entry.path)
                elif entry.is_file():
                    yield entry.path[cut:], entry.stat()
            except OSError:
                continue


def _excluded(path: str, exclude: tuple[str, ...]) -> bool:
    return any(path == e or (e.endswith(".") and path.startswith(e)) for e in exclude)


def scan_tree(
    root: Path, previous: Mapping[str, FileRecord], exclude: tuple[str, ...] = ()
) -> dict[str, FileRecord]:
    """Every file under ``root`` with its content hash, reusing ``previous`` hashes of files
    whose size, mtime and inode did not change. ``exclude``: folders (path prefixes) that are
    not sources, such as an output folder inside a plain colcon workspace."""
    out: dict[str, FileRecord] = {}
    for rel, st in _walk(root, exclude):
        old = previous.get(rel)
        if (
            old is not None
            and old.size == st.st_size
            and old.mtime_ns == st.st_mtime_ns
            and old.inode == st.st_ino
            and old.ctime_ns == st.st_ctime_ns
        ):
            out[rel] = old
            continue
        try:
            sha = file_sha256(root / rel)
        except OSError:
            continue
        out[rel] = FileRecord(st.st_size, st.st_mtime_ns, st.st_ino, sha, st.st_ctime_ns)
    return out


def content_changed(previous: Mapping[str, FileRecord], now: Mapping[str, FileRecord]) -> list[str]:
    """Files whose content is new since the ``previous`` walk (other bytes, or not there then).
    Nothing on a first walk: everything is built then anyway."""
    if not previous:
        return []
    return sorted(rel for rel, r in now.items() if rel not in previous or previous[rel].sha256 != r.sha256)


def make_newer(root: Path, names: Iterable[str], records: dict[str, FileRecord]) -> None:
    """Give these files the current time as their mtime (their content is untouched), and record
    their new stat. The build tools decide by mtime: a file whose content changed but whose mtime
    went back (`cp -p`, `rsync -a`, `tar x`, `git stash pop` of an old file) is older than the
    objects made from its previous content, and ninja and make would never rebuild them."""
    for rel in names:
        path = root / rel
        try:
            os.utime(path)
            st = path.stat()
        except OSError:
            continue
        old = records[rel]
        records[rel] = FileRecord(st.st_size, st.st_mtime_ns, st.st_ino, old.sha256, st.st_ctime_ns)


def tree_digest(records: Mapping[str, FileRecord]) -> str:
    """The content of a tree: file names and content hashes, not times."""
    return digest("\n".join(f"{rel}\0{records[rel].sha256}" for rel in sorted(records)))


def load_sources_cache(path: Path) -> dict[str, FileRecord]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return {rel: FileRecord(*entry) for rel, entry in data["files"].items() if len(entry) == 5}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def save_sources_cache(path: Path, records: Mapping[str, FileRecord]) -> None:
    data = {
        "files": {
            rel: [r.size, r.mtime_ns, r.inode, r.sha256, r.ctime_ns] for rel, r in sorted(records.items())
        }
    }
    write_atomic(path, json.dumps(data, separators=(",", ":")))


# ---------------------------------------------------------------------------------------------
# files that must still be as written


def stat_files(paths: Iterable[Path]) -> dict[str, list[int]]:
    """path -> [size, mtime_ns] of each file that exists (archives before a merge)."""
    out = {}
    for path in paths:
        try:
            st = path.stat()
        except OSError:
            continue
        out[str(path)] = [st.st_size, st.st_mtime_ns]
    return out


def stat_folder(folder: Path, only: Collection[str] | None = None) -> dict[str, list[int]]:
    """relative path -> [size, mtime_ns] of every file under ``folder`` (an output folder);
    with ``only``, of the files under those top-level entries (what uros wrote there: a user's
    own file beside the output is not part of it)."""
    top = str(folder)
    cut = len(top) + 1
    out = {}
    stack = [top]
    while stack:
        at = stack.pop()
        try:
            entries = list(os.scandir(at))
        except OSError:
            continue
        for entry in entries:
            if only is not None and at == top and entry.name not in only:
                continue
            try:
                if entry.is_dir(follow_symlinks=False):
                    stack.append(entry.path)
                else:
                    st = entry.stat()
                    out[entry.path[cut:]] = [st.st_size, st.st_mtime_ns]
            except OSError:
                continue
    return out


# ---------------------------------------------------------------------------------------------
# the state of a target's last successful build


@dataclass(frozen=True)
class BuildState:
    """What the last successful build of a target was made of and what it wrote."""

    fingerprint: str
    parts: Mapping[str, str]  # input name -> digest, to say what changed
    output: str  # the output folder
    output_files: Mapping[str, list[int]]  # relative path -> [size, mtime_ns], as written
    library_sha256: str
    merge_key: str  # the archives (size, mtime) and what the merge and ABI check depend on
    packages: tuple[str, ...] = ()
    version: int = STATE_VERSION
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        data = {
            "version": self.version,
            "fingerprint": self.fingerprint,
            "parts": dict(self.parts),
            "output": self.output,
            "output_files": dict(self.output_files),
            "library_sha256": self.library_sha256,
            "merge_key": self.merge_key,
            "packages": list(self.packages),
            "extra": dict(self.extra),
        }
        return json.dumps(data, indent=1, sort_keys=True) + "\n"


def read_state(path: Path) -> BuildState | None:
    """The recorded state, or None when there is none or it is unreadable or of another version
    (a state is a cache: anything odd means "build")."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("version") != STATE_VERSION:
            return None
        return BuildState(
            fingerprint=str(data["fingerprint"]),
            parts={str(k): str(v) for k, v in data["parts"].items()},
            output=str(data["output"]),
            output_files={str(k): [int(x) for x in v] for k, v in data["output_files"].items()},
            library_sha256=str(data["library_sha256"]),
            merge_key=str(data["merge_key"]),
            packages=tuple(str(p) for p in data.get("packages", ())),
            extra=dict(data.get("extra", {})),
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def write_state(path: Path, state: BuildState) -> None:
    write_atomic(path, state.to_json())


def forget_state(path: Path) -> None:
    """Before a build changes the trees: a failed or interrupted build must not leave the old
    state claiming the output is current."""
    path.unlink(missing_ok=True)


def combine(parts: Mapping[str, str]) -> str:
    return digest_json(dict(parts))


def differing(before: Mapping[str, str], after: Mapping[str, str]) -> list[str]:
    return sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))


def output_intact(
    state: BuildState,
    output: Path,
    library: str,
    library_sha256: str | None,
    owned: Collection[str] | None = None,
) -> bool:
    """The output folder holds exactly the files the build wrote, unchanged (size and mtime),
    and its libmicroros.a has the sha256 ``library_sha256`` (from its build-info.json) that the
    state recorded. ``owned``: the top-level entries uros wrote (its marker); only those count,
    so a user's notes.txt beside the library does not make the next build rebuild (a file added
    inside include/ still does: the tree must hold exactly this build's headers)."""
    if str(output) != state.output or library_sha256 != state.library_sha256:
        return False
    recorded = state.output_files
    if owned is not None:
        recorded = {k: v for k, v in recorded.items() if k.split(os.sep, 1)[0] in owned}
    if stat_folder(output, owned) != recorded:
        return False
    lib = output / library
    return lib.is_file() and file_sha256(lib) == state.library_sha256
