"""Putting a new output in place without ever losing the previous one.

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
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import __version__, console, proc
from uros_build.errors import StepFailed, interrupted
from uros_build.files import leftover_temps, pid_alive, remove_tree, write_atomic
from uros_build.output.folders import (
    JOURNAL,
    TEMP_INSIDE,
    entries,
    owned_entries,
)

# rename(2) of a folder that is a mount point (EBUSY), on another mount (EXDEV), or that the
# system will not move (EPERM, EACCES on a sticky or read-only parent): swap its entries instead.
_CANNOT_RENAME = (errno.EBUSY, errno.EXDEV, errno.EPERM, errno.EACCES, errno.EROFS)


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


def _write_journal(path: Path, journal: Journal) -> None:
    write_atomic(path, journal.to_json(), sync=True)


def _exists(path: Path) -> bool:
    return path.exists() or path.is_symlink()


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
    new_names = entries(staging)
    if not out.is_dir():
        out.parent.mkdir(parents=True, exist_ok=True)
        return _swap_folder(staging, out)
    owned = owned_entries(out) or frozenset()
    replace = {*new_names, *(owned & entries(out))}
    if staging.parent != out and not (entries(out) - replace):
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


def finish_swaps(out: Path, tidy: bool = True) -> list[str]:
    """Finish or roll back a swap into ``out`` that a killed run left half-way, as its journal
    says; returns what was done, for the console. A run claims a journal by renaming it to
    ``<journal>.claimed-<pid>`` (one rename wins), so two runs that find it at once (a build and
    `uros info`, two readers) never both carry it out; the claim of a run killed while carrying it
    out is taken over. ``tidy``: also remove the journal a run was writing when it was killed,
    before its first rename (only where no other run can be writing one: under the target's lock)."""
    done = []
    for folder, journal_path in ((out.parent, out.with_name(f".{out.name}.swap")), (out, out / JOURNAL)):
        if not folder.is_dir():
            continue  # no folder, no swap (an --output that is a file is refused later)
        claims = re.compile(rf"^{re.escape(journal_path.name)}\.claimed-(\d+)$")
        found = [journal_path]
        with contextlib.suppress(OSError):
            found += sorted(p for p in folder.iterdir() if claims.match(p.name))
        for path in found:
            journal = _journal_at(path)
            if journal is None:
                if tidy and path == journal_path:  # killed while writing it: nothing to undo
                    for tmp in leftover_temps(journal_path):
                        with contextlib.suppress(OSError):
                            os.unlink(tmp)
                continue
            claimer = claims.match(path.name)
            if pid_alive(journal.pid) or (claimer and pid_alive(int(claimer.group(1)))):
                continue
            mine = journal_path.with_name(f"{journal_path.name}.claimed-{os.getpid()}")
            try:
                path.rename(mine)
            except FileNotFoundError:
                continue  # another run claimed it first
            verdict, actions = recovery_actions(journal, _existing(folder, journal))
            left = _apply(folder, actions)
            mine.unlink(missing_ok=True)
            state = "the new output is in place" if verdict == "finished" else "the previous output is back"
            done.append(
                f"{out}: {verdict} the swap of a uros run (pid {journal.pid}) that stopped half-way: {state}"
            )
            done += [f"could not remove {why}" for why in left]
    return done


def recover(out: Path) -> list[str]:
    """At the start of a build (the target's lock held): :func:`finish_swaps`, then the staging
    folders of runs that are gone removed; returns what was done, for the console."""
    return finish_swaps(out) + _remove_stale(out)


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
                match = TEMP_INSIDE.match(path.name)
                if match and not pid_alive(int(match.group(2))):
                    done.append(_removed(path, f"{out.name}/{path.name}"))
    return done
