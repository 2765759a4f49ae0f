"""`uros update`: move a firmware workspace's clones to the newest commits of their branches (or to
another distro's) without cloning again, show what moved, and write the new uros.lock.

Nothing changes until every fetch has succeeded: a failed fetch leaves the clones, the lock and
uros.yaml as they were. Only clones uros made (uros.lock) and the user did not change are moved.
"""

from __future__ import annotations

from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from uros_build import console
from uros_build.config.sourceplan import UpdateArgs, UpdatePlan, plan_update, print_stand_ins
from uros_build.errors import ConfigError, StepFailed, UrosError
from uros_build.files import write_if_changed
from uros_build.proc import Runner, new_run_log
from uros_build.sources import clones, distros
from uros_build.sources.workspace import Workspace
from uros_build.sources.wsfiles import CONFIG, DEV_WS, LOCK, MCU_WS, Lock, with_distro


@dataclass(frozen=True)
class Move:
    """One clone's move: from the locked commit to the fetched one."""

    path: str
    old: str | None  # None: a new clone
    new: str | None  # None: removed
    ahead: int = 0  # commits in new and not in old
    behind: int = 0  # commits in old and not in new (a move to another branch)


def describe(move: Move) -> str:
    """One line of the table `uros update` prints (pure)."""
    if move.old is None:
        return f"{move.path}: new clone at {move.new[:12]}" if move.new else f"{move.path}: would be cloned"
    if move.new is None:
        return f"{move.path}: removed (not in the distro) was {move.old[:12]}"
    counts = f"+{move.ahead}" + (f" -{move.behind}" if move.behind else "")
    return f"{move.path}: {move.old[:12]} -> {move.new[:12]} ({counts} commits)"


def _fetch_all(runner: Runner, git: str, plan: UpdatePlan) -> dict[str, str]:
    """path -> the commit its branch is at now, for every clone kept; moves nothing."""

    def one(path: str) -> tuple[str, str]:
        source, dest = plan.sources[path], plan.root / path
        label = f"[{path}] "
        try:
            runner.run(clones.fetch_argv(git, source, dest), step=f"fetch {path}", quiet=True, label=label)
            commit = runner.query(clones.fetched_commit_argv(git, source, dest), step=f"read {path}").strip()
        except StepFailed as exc:
            fix = (
                f"point this repository elsewhere with a mirror override in {CONFIG} "
                f"(nothing was changed; log: {runner.log_path})"
            )
            raise clones.source_failed("fetching", path, source, exc, fix) from exc
        before = plan.args.before
        if before is not None and not source.is_commit:
            argv = clones.before_argv(git, dest, commit, before)
            commit = runner.query(argv, step=f"read {path}").strip()
            if not commit:
                raise ConfigError(
                    f"--before {before}: {path} ({source.url} at {source.version!r}) "
                    "has no commit before that day",
                    "pick a later day (nothing was changed)",
                )
        return path, commit

    console.step(f"fetching {len(plan.kept)} repositories ({plan.args.jobs} at a time)")
    with ThreadPoolExecutor(max_workers=plan.args.jobs) as pool:
        return dict(pool.map(one, plan.kept))


def _count(runner: Runner, git: str, plan: UpdatePlan, path: str, old: str, new: str) -> Move:
    out = runner.query(
        [git, "-C", str(plan.root / path), "rev-list", "--count", "--left-right", f"{old}...{new}"],
        step=f"compare {path}",
    )
    behind, ahead = (int(x) for x in out.split())
    return Move(path, old, new, ahead, behind)


def _new_lock(plan: UpdatePlan, commits: Mapping[str, str]) -> Lock:
    return Lock.from_clones(plan.distro.name, plan.sources, commits)


def update(args: UpdateArgs) -> tuple[Move, ...]:
    plan = plan_update(args)
    root, old_lock = plan.root, plan.lock
    runner = Runner(new_run_log(Workspace(root).log_dir, "update"), verbose=args.verbose)
    switching = bool(plan.config.distro) and plan.distro.name != plan.config.distro
    target = f"micro-ROS {plan.distro.name}" + (f" (from {plan.config.distro})" if switching else "")
    when = f" committed before {args.before}" if args.before else ""
    console.step(f"uros update: {root} to the newest commits{when} of {target}")
    console.info(f"log: {runner.log_path}")
    print_stand_ins(plan.distro, plan.config.mirror, plan.sources)
    git = runner.which("git")
    clones.check_untouched(
        runner, git, root, old_lock, (*plan.kept, *plan.removed), "uros update moves only clean clones"
    )
    fetched = _fetch_all(runner, git, plan)
    moves = [
        _count(runner, git, plan, path, old_lock.repositories[path].commit, commit)
        for path, commit in sorted(fetched.items())
        if commit != old_lock.repositories[path].commit
    ]
    moves += [Move(path, old_lock.repositories[path].commit, None) for path in plan.removed]
    if args.dry_run:
        moves += [Move(path, None, None) for path in plan.added]
        _report(plan, moves, dry_run=True)
        return tuple(moves)

    cloned: list[str] = []
    try:
        for path in plan.added:
            for argv in clones.clone_argv(git, plan.sources[path], root / path):
                runner.run(argv, step=f"clone {path}", quiet=True, label=f"[{path}] ")
            cloned.append(path)
            head = runner.query([git, "-C", str(root / path), "rev-parse", "HEAD"], step=f"read {path}")
            fetched[path] = head.strip()
            moves.append(Move(path, None, fetched[path]))
    except (UrosError, KeyboardInterrupt):
        clones.remove_clones(root, cloned)  # nothing else has changed yet
        raise
    # Every fetch and clone succeeded: now move the clones, then write what they hold.
    # uros's COLCON_IGNORE markers are untracked files: a commit that tracks one (micro-ROS/rcl's
    # rcl_yaml_param_parser/COLCON_IGNORE) cannot be checked out over it, so they go first
    old_mcu, old_dev = _distro_ignores(plan.config.distro)
    clones.unmark_ignored(root, MCU_WS, old_mcu)
    clones.unmark_ignored(root, DEV_WS, old_dev)
    try:
        _checkout_all(runner, git, plan, [m for m in moves if m.old is not None and m.new is not None])
    except (UrosError, KeyboardInterrupt):
        clones.mark_ignored(root, MCU_WS, old_mcu)
        clones.mark_ignored(root, DEV_WS, old_dev)
        raise
    clones.remove_clones(root, plan.removed)
    for ws, ignored in ((MCU_WS, plan.distro.colcon_ignore), (DEV_WS, plan.distro.dev_colcon_ignore)):
        for missing in clones.mark_ignored(root, ws, ignored):
            console.warn(f"{missing} is not in the workspace; nothing to ignore there")
    write_if_changed(root / LOCK, _new_lock(plan, fetched).to_json("update"))
    if switching:
        config = root / CONFIG
        write_if_changed(
            config, with_distro(config.read_text(encoding="utf-8"), plan.distro.name, str(config))
        )
    if any(m.path.startswith(f"{DEV_WS}/") for m in moves):
        # the host tools were built from the old clones: the next build rebuilds them
        clones.drop_dev_trees(root)
    _report(plan, moves, dry_run=False)
    return tuple(moves)


def _checkout_all(runner: Runner, git: str, plan: UpdatePlan, moves: list[Move]) -> None:
    """Move the clones; if one cannot move (a file the checkout would overwrite), the ones already
    moved go back, so the workspace still matches its lock."""
    done: list[Move] = []
    try:
        for move in moves:
            assert move.new is not None
            runner.run(
                clones.checkout_argv(git, plan.root / move.path, move.new), step=f"checkout {move.path}"
            )
            done.append(move)
    except (UrosError, KeyboardInterrupt):
        for move in done:
            assert move.old is not None
            runner.run(
                clones.checkout_argv(git, plan.root / move.path, move.old), step=f"restore {move.path}"
            )
        raise


def _distro_ignores(name: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    try:
        old = distros.load_distro(name)
    except UrosError:
        return (), ()
    return old.colcon_ignore, old.dev_colcon_ignore


def _report(plan: UpdatePlan, moves: list[Move], dry_run: bool) -> None:
    for move in sorted(moves, key=lambda m: m.path):
        console.info(describe(move))
    total = len(plan.sources)
    if dry_run:
        console.step(f"{len(moves)} of {total} repositories would change (--dry-run: nothing was changed)")
    elif moves:
        console.step(f"updated {len(moves)} of {total} repositories; {LOCK} written. Next: `uros build`")
    else:
        console.step(f"all {total} repositories are at the newest commits of their branches; nothing changed")
