"""Output folders: what uros wrote there, the guard that keeps everything else, and a swap that
never loses the previous output.

An output (default ``<workspace>/build/<target>``) holds what `uros build` wrote: libmicroros.a,
include/, the CMake package files, toolchain.cmake, build-info.json, and ``.uros-output``, a
marker naming those entries. The marker is how uros tells its own output from a folder that merely
holds a file called build-info.json, and which entries are its to replace: a user's files beside
them are kept.

A new output is built in a staging folder and put in place by renames (the folder itself, or,
where the folder cannot be renamed — a mount point, a parent uros cannot write — entry by entry
inside it). A journal written before the first rename lets the next run finish or roll back a swap
that a SIGKILL or a power cut stopped half-way (:func:`recover`); signals uros can catch wait
until the renames are done. This module starts no processes.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import stat
import sys
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import __version__, console, proc
from uros_build.buildinfo import BUILD_INFO, parse_build_info
from uros_build.errors import ConfigError, StepFailed, interrupted
from uros_build.fingerprint import file_sha256
from uros_build.workspace import Workspace, nearest_existing

MARKER = ".uros-output"
JOURNAL = ".uros-swap"  # a swap of the entries inside an output folder
# uros's own temporary names inside an output folder (a swap of its entries): never the user's
_TEMP_INSIDE = re.compile(r"^\.uros-(staging|new|old)-(\d+)$")
# Outputs of uros before the marker existed: these names, recognised by build-info.json.
_LEGACY_NAMES = (
    "libmicroros.a",
    "include",
    "toolchain.cmake",
    BUILD_INFO,
    "microrosConfig.cmake",
    "microrosConfigVersion.cmake",
    "microros.cmake",
)
_OWN_NAMES = frozenset([*_LEGACY_NAMES, MARKER])
# What an output folder must never be, or hold, even with --force: a workspace or its sources.
_WORKSPACE_SIGNS = ("uros.yaml", "uros.lock", ".uros", "mcu_ws", "dev_ws", "package.xml", "COLCON_IGNORE")
_SEARCH_DEPTH = 3
_SEARCH_LIMIT = 20000
# rename(2) of a folder that is a mount point (EBUSY), on another mount (EXDEV), or that the
# system will not move (EPERM, EACCES on a sticky or read-only parent): swap its entries instead.
_CANNOT_RENAME = (errno.EBUSY, errno.EXDEV, errno.EPERM, errno.EACCES, errno.EROFS)


# ---------------------------------------------------------------------------------------------
# the marker


def marker_text(target: str, names: Collection[str]) -> str:
    data = {"generated_by": f"uros {__version__} build", "target": target, "files": sorted(names)}
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def parse_marker(text: str) -> frozenset[str] | None:
    """The entries a marker names, or None when it is not one uros wrote (pure)."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if not isinstance(data, dict) or not str(data.get("generated_by", "")).startswith("uros "):
        return None
    files = data.get("files")
    if not isinstance(files, list) or not all(_entry_name(f) for f in files):
        return None
    return frozenset([*files, MARKER])


def _entry_name(name: object) -> bool:
    return isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\0" not in name


def owned_entries(out: Path) -> frozenset[str] | None:
    """The entries of ``out`` that uros wrote, or None when ``out`` is not a uros output.

    Its marker says so; an output of uros before the marker is one whose build-info.json was
    written by uros and records the sha256 of the libmicroros.a beside it (a file that is merely
    called build-info.json is not enough)."""
    try:
        return parse_marker((out / MARKER).read_text(encoding="utf-8"))
    except FileNotFoundError:
        pass
    except (OSError, UnicodeDecodeError):
        return None
    try:
        info = parse_build_info(json.loads((out / BUILD_INFO).read_text(encoding="utf-8")), str(out))
        if info.generated_by.startswith("uros ") and info.library.sha256 == file_sha256(
            out / "libmicroros.a"
        ):
            return frozenset(n for n in _LEGACY_NAMES if (out / n).exists())
    except (OSError, ValueError, ConfigError):
        pass
    return None


def _entries(folder: Path) -> set[str]:
    """The entries of a folder that are not uros's temporary ones."""
    return {p.name for p in folder.iterdir() if not _TEMP_INSIDE.match(p.name) and p.name != JOURNAL}


def write_marker(out: Path, target: str, names: Collection[str]) -> None:
    (out / MARKER).write_text(marker_text(target, {*names} - {MARKER}), encoding="utf-8")


def add_to_marker(out: Path, names: Collection[str]) -> None:
    """Record more entries uros wrote into an existing output (`uros export` in place)."""
    owned = owned_entries(out) or frozenset()
    try:
        target = str(json.loads((out / MARKER).read_text(encoding="utf-8")).get("target", ""))
    except (OSError, ValueError, AttributeError):
        target = ""
    write_marker(out, target, {*owned, *names})


# ---------------------------------------------------------------------------------------------
# the guard


def _workspace_sign(folder: Path) -> Path | None:
    """A file or folder below ``folder`` (a few levels deep) showing sources or a workspace."""
    seen = 0
    for dirpath, dirnames, filenames in os.walk(folder):
        depth = len(Path(dirpath).relative_to(folder).parts)
        for name in sorted([*filenames, *dirnames]):
            if name in _WORKSPACE_SIGNS:
                return Path(dirpath) / name
        seen += len(filenames) + len(dirnames)
        if depth >= _SEARCH_DEPTH or seen > _SEARCH_LIMIT:
            dirnames[:] = []
    return None


def _other_output(folder: Path) -> Path | None:
    """A subfolder of ``folder`` that is a uros output (another target's)."""
    with contextlib.suppress(OSError):
        for sub in sorted(folder.iterdir()):
            if sub.is_dir() and not sub.is_symlink() and owned_entries(sub) is not None:
                return sub
    return None


def mount_points(mountinfo: str) -> set[str]:
    """The mount points listed in /proc/self/mountinfo (field 5, with spaces and the like written
    as octal escapes: https://man7.org/linux/man-pages/man5/proc_pid_mountinfo.5.html) (pure)."""
    points = set()
    for line in mountinfo.splitlines():
        fields = line.split(" ")
        if len(fields) > 4:
            points.add(re.sub(r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)), fields[4]))
    return points


def is_mount_point(folder: Path) -> bool:
    """Whether ``folder`` is a mount point; a bind mount of a folder of the same file system too,
    which os.path.ismount misses (it compares devices), and which rename(2) refuses all the same."""
    if os.path.ismount(folder):
        return True
    try:
        return str(folder) in mount_points(Path("/proc/self/mountinfo").read_text(encoding="utf-8"))
    except OSError:
        return False


def _writable(folder: Path) -> bool:
    # access(2) answers EROFS for a read-only mount, for root too
    return os.access(folder, os.W_OK | os.X_OK)


def output_target(out: Path) -> str | None:
    """The target whose output ``out`` is, from its marker (None: no marker, or one that names none)."""
    try:
        target = json.loads((out / MARKER).read_text(encoding="utf-8")).get("target")
    except (OSError, ValueError, AttributeError):
        return None
    return str(target) if target else None


def check_output_owner(out: Path, target: str, force: bool, flag: str = "--output") -> None:
    """An output belongs to one target: building another target into it would replace that
    target's library without a word (issue 16). Checked when the build is planned and again, under
    the output's lock, just before the swap (another build may have written it meanwhile)."""
    owner = output_target(out) if out.is_dir() else None
    if owner is not None and owner != target and not force:
        raise ConfigError(
            f"{flag} {out}: is the output of target {owner}, not {target}",
            f"choose another folder (the default is <workspace>/build/{target}), or pass --force to "
            f"replace {owner}'s output with {target}'s",
        )


def check_output_dir(
    out: Path, force: bool, flag: str = "--output", workspace: Path | None = None, offers_force: bool = True
) -> None:
    """Refuse, before anything is built, an output folder uros could not write or would have to
    take from the user. ``out`` is resolved. Never, even with --force: the workspace, a folder
    holding it, its sources or other targets' outputs. Without --force: a folder holding files uros
    did not write (with it, uros writes its own entries there and keeps the rest)."""
    fix = "choose a new or empty folder (the default is <workspace>/build/<target>)"
    if workspace is not None:
        ws = workspace.resolve()
        if ws == out or ws.is_relative_to(out):
            raise ConfigError(f"{flag} {out}: is the workspace {ws} or holds it", fix)
        for part in (".uros", "mcu_ws", "dev_ws"):
            if out.is_relative_to(ws / part):
                raise ConfigError(f"{flag} {out}: is inside the workspace's {part}/", fix)
        for parent in out.parents:
            if (parent / "package.xml").is_file():
                raise ConfigError(f"{flag} {out}: is inside the package {parent}", fix)
            if parent == ws:
                break
    if out.is_dir() and not out.is_symlink():
        owned = owned_entries(out)
        if owned is None and (out / JOURNAL).is_file():
            owned = frozenset()  # a swap uros left half-done: the build recovers it first
        if owned is None and _entries(out):
            other = _other_output(out)
            if other is not None:
                raise ConfigError(f"{flag} {out}: holds the uros output {other.name}/ of another target", fix)
            sign = _workspace_sign(out)
            if sign is not None:
                raise ConfigError(
                    f"{flag} {out}: holds {sign.relative_to(out)}, so it is a workspace or its sources; "
                    "uros never writes there",
                    fix,
                )
            if not force:
                foreign = sorted(_entries(out))
                shown = ", ".join(foreign[:4]) + (", ..." if len(foreign) > 4 else "")
                raise ConfigError(
                    f"{flag} {out}: the folder holds files uros did not write ({shown})",
                    f"{fix}, or pass --force to write uros's files into it (libmicroros.a, include/, "
                    "the CMake files, toolchain.cmake, build-info.json) and keep the others"
                    if offers_force
                    else "choose a new or empty folder",  # `uros export` has no --force to offer
                )
        # Replaced with one rename where uros can write beside it; entry by entry where it cannot,
        # where it is a mount point, or where the user's files stay in it.
        mount = is_mount_point(out)
        keeps = not _entries(out) <= _OWN_NAMES | (owned or frozenset())
        if (mount or keeps or not _writable(out.parent)) and not _writable(out):
            why = (
                "it is a mount point, so uros replaces what is inside it"
                if mount
                else "it holds files uros keeps, so uros replaces what is inside it"
                if keeps
                else f"nor in {out.parent}"
            )
            raise ConfigError(
                f"{flag} {out}: cannot write in this folder ({why})",
                "make it writable (its permissions, or a read-write mount), or choose another folder",
            )
    elif out.exists() or out.is_symlink():
        raise ConfigError(f"{flag} {out}: is not a folder", fix)
    else:
        parent = nearest_existing(out.parent)
        if not _writable(parent):
            raise ConfigError(f"{flag} {out}: cannot create it (cannot write in {parent})", fix)


def staging_dir(out: Path) -> Path:
    """Where the new output is built: beside ``out`` (so that it can replace it with one rename),
    or inside it where uros cannot write beside it or ``out`` is a mount point."""
    if out.is_dir() and (is_mount_point(out) or not _writable(out.parent)):
        return out / f".uros-staging-{os.getpid()}"
    return out.with_name(f".{out.name}.staging-{os.getpid()}")


# ---------------------------------------------------------------------------------------------
# the journal and its recovery (pure)


@dataclass(frozen=True)
class Move:
    """One entry of a swap, paths relative to the journal's folder: ``dest`` is moved aside to
    ``old``, then ``new`` (None: nothing, the entry is only removed) takes its place."""

    dest: str
    new: str | None
    old: str


@dataclass(frozen=True)
class Journal:
    pid: int
    moves: tuple[Move, ...]
    cleanup: tuple[str, ...] = ()  # folders removed once the swap is finished or rolled back

    def to_json(self) -> str:
        data = {
            "generated_by": f"uros {__version__}",
            "pid": self.pid,
            "moves": [{"dest": m.dest, "new": m.new, "old": m.old} for m in self.moves],
            "cleanup": list(self.cleanup),
        }
        return json.dumps(data, indent=2, sort_keys=True) + "\n"


def _rel(value: Any) -> str:
    if not isinstance(value, str) or not value or value.startswith("/") or ".." in value.split("/"):
        raise ValueError(f"not a path inside the folder: {value!r}")
    return value


def parse_journal(text: str) -> Journal:
    """A journal; ValueError when it is not one uros wrote (pure)."""
    data = json.loads(text)
    if not isinstance(data, dict) or not isinstance(data.get("pid"), int):
        raise ValueError("no pid")
    moves = tuple(
        Move(_rel(m["dest"]), None if m.get("new") is None else _rel(m["new"]), _rel(m["old"]))
        for m in data.get("moves", [])
    )
    return Journal(data["pid"], moves, tuple(_rel(c) for c in data.get("cleanup", [])))


Action = tuple[str, ...]  # ("remove", path) | ("rename", from, to)


def recovery_actions(journal: Journal, exists: Collection[str]) -> tuple[str, list[Action]]:
    """What finishes or undoes a swap stopped half-way, from which of its paths exist (pure).

    The swap moves every ``dest`` aside first, then every ``new`` in. Once every new entry is in
    place the swap is finished: what was moved aside is removed. Otherwise it is rolled back: new
    entries already in place are removed, the previous ones renamed back, the staging removed; the
    folder is as it was before the run."""
    moved_in = [m for m in journal.moves if m.new is not None and m.new not in exists and m.dest in exists]
    pending = [m for m in journal.moves if m.new is not None and m.new in exists]
    actions: list[Action] = []
    if not pending and moved_in:
        actions = [("remove", m.old) for m in journal.moves if m.old in exists]
        return "finished", actions + [("remove", c) for c in journal.cleanup if c in exists]
    for m in journal.moves:
        if m.new is not None and m.new not in exists and m.dest in exists:
            actions.append(("remove", m.dest))  # the new entry, already in place
    for m in journal.moves:
        if m.old in exists:
            actions.append(("rename", m.old, m.dest))
    for m in journal.moves:
        if m.new is not None and m.new in exists:
            actions.append(("remove", m.new))
    return "rolled back", actions + [("remove", c) for c in journal.cleanup if c in exists]


# ---------------------------------------------------------------------------------------------
# the swap


def pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    return True


def _write_journal(path: Path, journal: Journal) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", encoding="utf-8") as handle:
        handle.write(journal.to_json())
        handle.flush()
        os.fsync(handle.fileno())
    tmp.replace(path)


def _exists(path: Path) -> bool:
    return path.exists() or path.is_symlink()


def remove_tree(path: Path) -> str | None:
    """Remove a file or folder uros wrote, making read-only folders in it writable first (an
    output copied from a read-only store); the reason when some of it could not be removed."""

    def retry(func: Callable[..., Any], name: str, _exc: BaseException) -> None:
        parent = Path(name).parent
        with contextlib.suppress(OSError):
            parent.chmod(parent.stat().st_mode | stat.S_IWUSR | stat.S_IXUSR)
        func(name)

    try:
        if path.is_dir() and not path.is_symlink():
            if sys.version_info >= (3, 12):
                shutil.rmtree(path, onexc=retry)
            else:
                shutil.rmtree(path, onerror=lambda func, name, info: retry(func, name, info[1]))
        elif _exists(path):
            path.unlink()
    except OSError as exc:
        return f"{exc.filename or path} ({exc.strerror or exc})"
    return None


def _apply(folder: Path, actions: list[Action]) -> list[str]:
    """Carry out recovery actions; the paths that could not be removed, with why."""
    left = []
    for action in actions:
        if action[0] == "rename":
            (folder / action[1]).rename(folder / action[2])
        else:
            why = remove_tree(folder / action[1])
            if why:
                left.append(why)
    return left


def _swap(folder: Path, journal_path: Path, journal: Journal, shown: Path) -> list[str]:
    """Run a journaled swap; returns what could not be cleaned up afterwards. On an error before
    every rename is done, the renames done are undone (the new entries stay where they wait, for
    the caller) and the error re-raised."""
    _write_journal(journal_path, journal)
    try:
        with proc.signals_held():
            for m in journal.moves:
                if _exists(folder / m.dest):
                    (folder / m.dest).rename(folder / m.old)
            for m in journal.moves:
                if m.new is not None:
                    (folder / m.new).rename(folder / m.dest)
            journal_path.unlink()
            left = _finish(folder, journal)
    except OSError as exc:
        _, actions = recovery_actions(journal, _existing(folder, journal))
        keep = {m.new for m in journal.moves} | set(journal.cleanup)
        try:
            _apply(folder, [a for a in actions if not (a[0] == "remove" and a[1] in keep)])
        except OSError as undo:
            raise StepFailed(
                f"{folder / journal.moves[0].dest}: replacing the output failed ({exc.strerror}) and "
                f"could not be undone ({undo.strerror}): the previous output is in "
                f"{', '.join(str(folder / m.old) for m in journal.moves if _exists(folder / m.old))}",
                "the next uros build puts it back",
            ) from exc
        journal_path.unlink(missing_ok=True)
        raise
    except KeyboardInterrupt as stop:
        # held during the swap, delivered once it was done: the new output is in place
        raise interrupted(stop, "interrupted", f"the new output was already in place: {shown}") from None
    return left


def _finish(folder: Path, journal: Journal) -> list[str]:
    """Remove what the swap moved aside (never raises: returns what could not be removed)."""
    left = [why for m in journal.moves if (why := remove_tree(folder / m.old))]
    return left + [why for c in journal.cleanup if (why := remove_tree(folder / c))]


def _existing(folder: Path, journal: Journal) -> set[str]:
    paths = {p for m in journal.moves for p in (m.dest, m.new, m.old) if p is not None}
    return {p for p in paths | set(journal.cleanup) if _exists(folder / p)}


def _swap_folder(staging: Path, out: Path) -> list[str]:
    pid = os.getpid()
    move = Move(out.name, staging.name, f".{out.name}.old-{pid}")
    return _swap(out.parent, out.with_name(f".{out.name}.swap"), Journal(pid, (move,)), out)


def _swap_entries(staging: Path, out: Path, names: Collection[str]) -> list[str]:
    """Swap ``names`` inside ``out`` (a folder that cannot be renamed, or that holds the user's
    files): the new entries move into ``out`` first, so that every rename stays on its mount."""
    pid = os.getpid()
    new = out / f".uros-new-{pid}"
    if staging != new:
        try:
            staging.rename(new)
        except OSError as exc:
            if exc.errno != errno.EXDEV:
                raise
            shutil.copytree(staging, new, symlinks=True)
            remove_tree(staging)
    old = f".uros-old-{pid}"
    (out / old).mkdir(exist_ok=True)
    moves = tuple(
        Move(name, f"{new.name}/{name}" if _exists(new / name) else None, f"{old}/{name}")
        for name in sorted(names)
    )
    try:
        return _swap(out, out / JOURNAL, Journal(pid, moves, (new.name, old)), out)
    except OSError:
        remove_tree(new)
        with contextlib.suppress(OSError):
            (out / old).rmdir()  # empty once undone; else it holds the previous output (see the error)
        raise


def install_output(staging: Path, out: Path) -> list[str]:
    """Put the output built in ``staging`` in place of ``out``; the previous output is replaced
    only where uros wrote it: a folder with the user's files keeps them. Returns what could not be
    cleaned up afterwards (the new output is in place all the same)."""
    new_names = _entries(staging)
    if not out.is_dir():
        out.parent.mkdir(parents=True, exist_ok=True)
        return _swap_folder(staging, out)
    owned = owned_entries(out) or frozenset()
    replace = {*new_names, *(owned & _entries(out))}
    if staging.parent != out and not (_entries(out) - replace):
        try:
            return _swap_folder(staging, out)
        except OSError as exc:
            if exc.errno not in _CANNOT_RENAME:
                raise
            console.info(f"{out} cannot be renamed ({exc.strerror}): replacing its contents instead")
    return _swap_entries(staging, out, replace)


# ---------------------------------------------------------------------------------------------
# recovery at the start of a run


def _journal_at(path: Path) -> Journal | None:
    try:
        return parse_journal(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        console.warn(f"{path}: not a swap journal uros can read ({exc}); leaving it")
        return None


def recover(out: Path) -> list[str]:
    """Finish or roll back a swap into ``out`` that a killed run left half-way, and remove the
    staging folders of runs that are gone; returns what was done, for the console."""
    done = []
    for folder, journal_path in ((out.parent, out.with_name(f".{out.name}.swap")), (out, out / JOURNAL)):
        if not folder.is_dir():
            continue  # no folder, no swap (an --output that is a file is refused later)
        journal = _journal_at(journal_path)
        if journal is None:
            # killed while writing it, before the first rename: nothing to undo
            with contextlib.suppress(OSError):
                journal_path.with_name(journal_path.name + ".tmp").unlink(missing_ok=True)
        if journal is None or pid_alive(journal.pid):
            continue
        verdict, actions = recovery_actions(journal, _existing(folder, journal))
        left = _apply(folder, actions)
        journal_path.unlink(missing_ok=True)
        state = "the new output is in place" if verdict == "finished" else "the previous output is back"
        done.append(
            f"{out}: {verdict} the swap of a uros run (pid {journal.pid}) that stopped half-way: {state}"
        )
        done += [f"could not remove {why}" for why in left]
    done += _remove_stale(out)
    return done


def _removed(path: Path, shown: str) -> str:
    why = remove_tree(path)
    return f"could not remove {why}" if why else f"removed {shown}, left by a uros run that is gone"


def _remove_stale(out: Path) -> list[str]:
    """Staging and old folders of uros runs that are gone (killed; SIGKILL leaves them)."""
    done = []
    beside = re.compile(rf"^\.{re.escape(out.name)}\.(staging|old)-(\d+)$")
    found: list[tuple[str, Path]] = []
    with contextlib.suppress(OSError):
        for path in out.parent.iterdir():
            match = beside.match(path.name)
            if match and not pid_alive(int(match.group(2))):
                found.append((match.group(1), path))
    olds = sorted((p for kind, p in found if kind == "old"), key=lambda p: p.stat().st_mtime)
    if olds and not _exists(out):
        # Left by a uros before the journal, killed between its two renames.
        olds[-1].rename(out)
        done.append(f"{out}: put back the previous output from {olds[-1].name} (a run stopped in its swap)")
    done += [_removed(path, path.name) for _kind, path in found if _exists(path)]
    if out.is_dir() and not out.is_symlink():
        with contextlib.suppress(OSError):
            for path in sorted(out.iterdir()):
                match = _TEMP_INSIDE.match(path.name)
                if match and not pid_alive(int(match.group(2))):
                    done.append(_removed(path, f"{out.name}/{path.name}"))
    return done


def is_uros_output(folder: Path) -> bool:
    """A folder `uros build` wrote (its marker, or an older output's build-info.json that
    vouches for the library beside it)."""
    return folder.is_dir() and not folder.is_symlink() and owned_entries(folder) is not None


def target_keys(ws: Workspace) -> list[str]:
    """The targets uros has trees or outputs of in ``ws`` (.uros/targets/<key>, build/<key>)."""
    keys = set(ws.tree_keys())
    outputs = ws.root / "build"
    if outputs.is_dir():
        keys |= {p.name for p in outputs.iterdir() if is_uros_output(p)}
    return sorted(keys)
