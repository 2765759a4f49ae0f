"""The git clones of a firmware workspace: how one is made, moved to another commit, checked for
the user's work and removed. `create-firmware` and `update` share these; every git command goes
through the one runner (proc.py), and argv is built by pure functions that unit tests check.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import ConfigError, StepFailed
from uros_build.proc import Runner
from uros_build.sources.distros import Source
from uros_build.sources.wsfiles import DEV_WS, LOCK, MCU_WS, Lock, clone_state

# git's own advice ("You are in 'detached HEAD' state...") is noise for clones uros pins
_QUIET = ("-c", "advice.detachedHead=false")
# where `update` keeps what it fetched for a pinned commit: its own namespace, never the user's refs
UPDATE_REFS = "refs/uros-update"


# What git says (the runner runs tools with their messages in English, LC_MESSAGES=C) when the source
# has no such branch, tag or commit, and when the source cannot be reached at all.
_NO_VERSION = re.compile(
    r"Remote branch .* not found|couldn't find remote ref|did not match any file|unknown revision"
    r"|reference is not a tree|not our ref|Needed a single revision"
)
_UNREACHABLE = re.compile(
    r"Could not resolve host|Repository not found|repository '.*' does not exist"
    r"|does not appear to be a git repository|unable to access|Connection refused"
    r"|Could not read from remote repository"
)


@dataclass(frozen=True)
class GitFailure:
    """Why a git command failed, decided here once (pure), so that no command reads message text:
    ``kind`` is "version" (the source has no such branch, tag or commit), "unreachable" (the source
    cannot be reached) or "other"; ``detail`` is git's own error line."""

    kind: str
    code: int | None
    detail: str


def git_failure(exc: StepFailed) -> GitFailure:
    said = "\n".join([exc.cause, *exc.output])
    kind = "version" if _NO_VERSION.search(said) else "unreachable" if _UNREACHABLE.search(said) else "other"
    return GitFailure(kind, exc.code, exc.cause or exc.message)


def source_failed(action: str, path: str, source: Source, exc: StepFailed, fix: str) -> StepFailed:
    """The one error for a clone or fetch of ``source`` that git refused (``action``: "cloning",
    "fetching"); ``fix``: what else the user can do."""
    failure = git_failure(exc)
    check = (
        f"check that {source.url} can be reached"
        if failure.kind == "unreachable"
        else f"check that the source has {source.version!r}"
    )
    return StepFailed(
        f"{action} {path} from {source.url} at {source.version!r} failed: {failure.detail}",
        f"{check}, or {fix}",
        output=exc.output,
        code=failure.code,
        cause=failure.detail,
    )


def clone_argv(git: str, source: Source, dest: Path) -> list[list[str]]:
    """git commands that put ``source`` at ``dest`` (pure)."""
    quiet = [git, *_QUIET]
    if source.is_commit:
        return [
            [*quiet, "clone", "--quiet", "--no-checkout", source.url, str(dest)],
            [*quiet, "-C", str(dest), "checkout", "--quiet", "--detach", source.version],
        ]
    return [[*quiet, "clone", "--quiet", "--branch", source.version, source.url, str(dest)]]


def fetch_argv(git: str, source: Source, dest: Path) -> list[str]:
    """git command that brings ``source``'s branch or tag (or, for a pinned commit, every branch,
    since a server need not serve an unadvertised commit) into the clone at ``dest`` without moving
    anything the user sees: a branch or tag lands in FETCH_HEAD (pure)."""
    base = [git, *_QUIET, "-C", str(dest), "fetch", "--quiet", "--no-tags", source.url]
    if source.is_commit:
        return [*base, f"+refs/heads/*:{UPDATE_REFS}/*"]
    return [*base, source.version]


def fetched_commit_argv(git: str, source: Source, dest: Path) -> list[str]:
    """git command printing the commit the fetch of ``source`` found (pure): FETCH_HEAD's, or the
    pinned commit itself (which fails when the fetch did not bring it)."""
    rev = f"{source.version}^{{commit}}" if source.is_commit else "FETCH_HEAD^{commit}"
    return [git, "-C", str(dest), "rev-parse", "--verify", "--quiet", rev]


def before_argv(git: str, dest: Path, commit: str, before: str) -> list[str]:
    """git command printing the newest commit of ``commit``'s first-parent history committed before
    ``before`` (an ISO date), or nothing when there is none (pure)."""
    return [git, "-C", str(dest), "rev-list", "-1", "--first-parent", f"--before={before}", commit]


def checkout_argv(git: str, dest: Path, commit: str) -> list[str]:
    return [git, *_QUIET, "-C", str(dest), "checkout", "--quiet", "--detach", commit]


def check_untouched(
    runner: Runner, git: str, root: Path, lock: Lock, paths: Iterable[str], action: str
) -> None:
    """uros may replace or move only the clones it made and the user did not change: a clone with
    the user's edits or commits holds the user's work, so it is refused before anything changes."""
    hint = f"save your work elsewhere (or remove the folder yourself); {action}"
    for path in sorted(paths):
        repo = lock.repositories[path]
        folder = root / path
        if not folder.exists():
            continue
        if not (folder / ".git").exists():
            raise ConfigError(f"--workspace {root}: {path} is in {LOCK} but is no git clone any more", hint)
        status = runner.query(
            [git, "-C", str(folder), "status", "--porcelain=v2", "--branch", "--untracked-files=no"],
            step=f"read {path}",
        )
        head, changed = clone_state(status)
        if changed:
            raise ConfigError(f"--workspace {root}: {path} has {changed} changed file(s) (git status)", hint)
        if head != repo.commit:
            raise ConfigError(
                f"--workspace {root}: {path} is at {head[:12]}, not at its locked commit {repo.commit[:12]}",
                hint,
            )


def head_commit(clone: Path) -> str | None:
    """The commit a clone's HEAD is at, read from its files (no git process: a build reads this for
    every repository): a detached sha, or the branch's ref in refs/ or packed-refs."""
    git_dir = clone / ".git"
    try:
        if git_dir.is_file():  # a worktree or submodule: "gitdir: <path>"
            git_dir = (clone / git_dir.read_text(encoding="utf-8").split(":", 1)[1].strip()).resolve()
        head = (git_dir / "HEAD").read_text(encoding="utf-8").strip()
        if not head.startswith("ref: "):
            return head or None
        ref = head[5:]
        loose = git_dir / ref
        if loose.is_file():
            return loose.read_text(encoding="utf-8").strip() or None
        packed = git_dir / "packed-refs"
        for line in packed.read_text(encoding="utf-8").splitlines() if packed.is_file() else ():
            parts = line.split()
            if len(parts) == 2 and parts[1] == ref:
                return parts[0]
    except (OSError, IndexError):
        return None
    return None


def built_from(
    packages: Iterable[tuple[str, Path]], root: Path, clone_paths: Iterable[str]
) -> dict[str, dict[str, str]]:
    """package -> {"repository": its clone's workspace path, "commit": the clone's HEAD}, for the
    packages that sit in one of the clones (extra packages and the user's own have none)."""
    clones_by_depth = sorted(clone_paths, key=len, reverse=True)
    heads: dict[str, str | None] = {}
    out: dict[str, dict[str, str]] = {}
    for name, where in packages:
        rel = where.relative_to(root).as_posix() if where.is_relative_to(root) else ""
        repo = next((c for c in clones_by_depth if rel == c or rel.startswith(c + "/")), None)
        if repo is None:
            continue
        if repo not in heads:
            heads[repo] = head_commit(root / repo)
        commit = heads[repo]
        if commit:
            out[name] = {"repository": repo, "commit": commit}
    return out


def remove_clones(root: Path, paths: Iterable[str]) -> None:
    """Remove these clones (and the folders they leave empty): all of it written by uros.
    Everything else in the workspace stays."""
    stops = {root / DEV_WS, root / MCU_WS, root}
    for path in sorted(paths, reverse=True):
        folder = root / path
        shutil.rmtree(folder, ignore_errors=True)
        parent = folder.parent
        while parent not in stops and parent.is_dir() and not any(parent.iterdir()):
            parent.rmdir()
            parent = parent.parent


IGNORE_NOTE = "uros: ignored as micro_ros_setup does for this distro\n"


def mark_ignored(root: Path, ws: str, paths: Iterable[str]) -> list[str]:
    """A COLCON_IGNORE (uros's) in each of these package folders of ``ws``; returns the folders
    that are not there (the distro table names more than these clones hold)."""
    missing = []
    for rel in paths:
        folder = root / ws / rel
        if folder.is_dir():
            marker = folder / "COLCON_IGNORE"
            # a COLCON_IGNORE the repository tracks (micro-ROS/rcl's rcl_yaml_param_parser) already
            # ignores it: rewriting it would make the clone "changed" for --force and update
            if not marker.exists():
                marker.write_text(IGNORE_NOTE, encoding="utf-8")
        else:
            missing.append(f"{ws}/{rel}")
    return missing


def unmark_ignored(root: Path, ws: str, paths: Iterable[str]) -> None:
    """Remove the COLCON_IGNOREs uros wrote in these folders (one with other text is the user's)."""
    for rel in paths:
        marker = root / ws / rel / "COLCON_IGNORE"
        try:
            if marker.read_text(encoding="utf-8") == IGNORE_NOTE:
                marker.unlink()
        except (OSError, UnicodeDecodeError):
            continue


def drop_dev_trees(root: Path) -> None:
    """dev_ws's colcon trees (uros's): the host tools are rebuilt from the clones at the next build."""
    for tree in ("build", "install", "log"):
        shutil.rmtree(root / DEV_WS / tree, ignore_errors=True)
