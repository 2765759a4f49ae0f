"""What `uros create-firmware` and `uros update` will do, checked before anything is cloned or
moved: the distro's repositories and where each comes from (a mirror, a lock), the folders they go
to, the day to update to. Frozen plans, as plan.py's for `uros build`; no process starts here.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, defaults, loader
from uros_build.config.resolver import resolve_one, resolve_workspace
from uros_build.config.settings import DISTRO
from uros_build.errors import ConfigError
from uros_build.sources import distros as distros_mod
from uros_build.sources.distros import Distro, Mirror, Source
from uros_build.sources.workspace import PENDING, Workspace, check_build_folder, check_extra_package
from uros_build.sources.wsfiles import (
    CONFIG,
    DEV_WS,
    LOCK,
    MCU_WS,
    STATE,
    Lock,
    WorkspaceConfig,
    load_config,
    parse_config,
    read_lock,
)
from uros_build.target.profiles import (
    TargetProfile,
    find_profile,
)

# ---------------------------------------------------------------------------------------------
# uros create-firmware


@dataclass(frozen=True, kw_only=True)
class CreateArgs:
    """What `uros create-firmware`'s command line said, unvalidated: by keyword only (16 fields in
    a row are too easy to hand over in the wrong order)."""

    directory: Path | None = None  # None: resolve_workspace's default
    distro: str = defaults.DISTRO
    platform: str = defaults.PLATFORM
    mirrors: tuple[str, ...] = ()
    overrides: tuple[str, ...] = ()
    config: Path | None = None
    stand_ins: bool = False  # apply the distro's declared stand-ins (distro.yaml stand_ins:)
    locked: bool = False
    lock_file: Path | None = None
    extra_packages: tuple[Path, ...] = ()
    force: bool = False
    keep_partial: bool = False
    build_dev: bool = True
    toolchain: str | None = None  # a target whose prerequisites are checked first
    jobs: int = defaults.CLONE_JOBS
    verbose: bool = False


@dataclass(frozen=True)
class CreatePlan:
    root: Path
    existed: bool  # the folder was there (empty, or a workspace re-created with --force)
    existing: WorkspaceConfig | None
    previous: Lock | None  # the lock of the workspace re-created with --force: what uros cloned
    distro: Distro
    mirror: Mirror
    sources: Mapping[str, Source]  # workspace path (dev_ws/..., mcu_ws/...) -> what to clone
    extra_packages: tuple[tuple[Path, str], ...]  # (folder, package name)
    probe: TargetProfile | None  # check this target's compiler and C library before cloning
    args: CreateArgs


def plan_sources(distro: Distro, mirror: Mirror, locked: Mapping[str, str] | None) -> dict[str, Source]:
    """Workspace path (dev_ws/..., mcu_ws/...) -> what to clone (pure)."""
    sources = {}
    for ws, repos in ((DEV_WS, distro.dev), (MCU_WS, distro.mcu)):
        for repo in repos:
            sources[f"{ws}/{repo.path}"] = distros_mod.resolve(repo, mirror, locked, prefix=f"{ws}/")
    return sources


def print_stand_ins(distro: Distro, mirror: Mirror, sources: Mapping[str, Source]) -> None:
    """Say which clones are stand-ins, and why, before any is cloned or moved."""
    lines, unused = stand_in_report(distro, mirror, sources)
    if lines:
        console.step(f"{len(lines)} of {len(sources)} repositories from stand-ins (not the manifest's):")
    for line in lines:
        console.info(f"  stand-in {line}")
    for warning in unused:
        console.warn(warning)


def stand_in_report(
    distro: Distro, mirror: Mirror, sources: Mapping[str, Source]
) -> tuple[list[str], list[str]]:
    """(one line per clone an override stands in for, with its reason; a warning per override that
    names no repository of the distro). Pure; create-firmware and update print them, so a stand-in
    is never silent and a mistyped override is not taken for one that worked."""
    lines = [distros_mod.describe_stand_in(p, s) for p, s in sorted(sources.items()) if s.stand_in]
    repos = (*distro.dev, *distro.mcu)
    unused = [
        f"mirror override {o.key}={o.use} names no repository of {distro.name}: it changes nothing"
        for o in mirror.overrides
        if not any(o.matches(r, prefix) for r in repos for prefix in (f"{DEV_WS}/", f"{MCU_WS}/"))
    ]
    return lines, unused


def _mirror_from(args: CreateArgs, existing: WorkspaceConfig | None, distro: Distro) -> Mirror:
    parts: list[Mirror] = []
    if existing is not None:
        parts.append(existing.mirror)
    if args.config is not None:
        given = parse_config(loader.load_yaml(args.config, "--config"), f"--config {args.config}")
        parts.append(given.mirror)
    parts.append(
        Mirror(
            tuple(distros_mod.parse_rule(s) for s in args.mirrors),
            tuple(distros_mod.parse_override(s) for s in args.overrides),
        )
    )
    mirror = distros_mod.combine(*parts)
    if args.stand_ins:
        mirror = _with_stand_ins(mirror, distro)
    return mirror


def _with_stand_ins(mirror: Mirror, distro: Distro) -> Mirror:
    """The distro's declared stand-ins added to the user's mirror, except for repositories the user
    overrides already (file or flags): those win, and uros.yaml then holds one override each."""
    if not distro.stand_ins:
        raise ConfigError(
            f"--stand-ins: the {distro.name} manifest declares no stand-ins",
            "`uros distros` lists the distros that declare some; drop --stand-ins",
        )
    repos = (*distro.dev, *distro.mcu)
    own = {r for r in repos for o in mirror.overrides if o.matches(r)}
    declared = tuple(o for o in distro.stand_ins if not any(o.matches(r) for r in own))
    return Mirror(mirror.rules, (*mirror.overrides, *declared))


def _check_sources(sources: Mapping[str, Source], where: str = "--mirror") -> None:
    for path, source in sources.items():
        if distros_mod.is_local(source.url) and not distros_mod.local_path(source.url).exists():
            raise ConfigError(
                f"{where}: {source.url} (for {path}, upstream {source.repo.url}) does not exist",
                "fix the mirror rule, or point this repository elsewhere: "
                + (
                    f"--mirror-override {source.repo.path}=URL"
                    if where == "--mirror"
                    else f"an override '{source.repo.path}=URL' in that file's mirror: section"
                ),
            )


def _existing(root: Path, force: bool) -> tuple[bool, WorkspaceConfig | None, Lock | None]:
    """(existed, its config, its lock). An existing, non-empty folder needs --force, and --force
    needs a workspace uros made: only what its uros.lock lists is ever replaced."""
    if not root.exists():
        return False, None, None
    if not root.is_dir():
        raise ConfigError(f"--workspace {root}: is a file", "pass a new or empty folder")
    if not any(p.name != STATE for p in root.iterdir()) and not (root / PENDING).is_file():
        return True, None, None  # empty, or only uros's own .uros/ (logs of a run that cloned nothing)
    if not force and (root / PENDING).is_file() and not (root / CONFIG).is_file():
        raise ConfigError(
            f"--workspace {root}: a create-firmware that was stopped before it finished left this folder",
            "pass --force to finish it (only the clones it was making are made again)",
        )
    if not force:
        raise ConfigError(
            f"--workspace {root}: already exists",
            "use another --workspace, or pass --force to re-clone the repositories its uros.lock "
            "lists (everything else is kept: colcon.meta, uros.yaml, your packages)",
        )
    cfg = load_config(root)
    lock = read_lock(root / LOCK, "--workspace") if (root / LOCK).is_file() else None
    if cfg is None and lock is None and (root / PENDING).is_file():
        # a create-firmware killed before it wrote uros.yaml and uros.lock: the record it wrote
        # first names the clones it was making, all of them uros's
        pending = read_lock(root / PENDING, "--workspace")
        return True, None, pending
    if cfg is None and lock is None:
        raise ConfigError(
            f"--workspace {root}: not a workspace made by uros create-firmware (no {CONFIG}, no {LOCK})",
            "--force re-creates only uros's own clones: use a new or empty folder",
        )
    return True, cfg, lock


def _check_destinations(root: Path, sources: Mapping[str, Source], previous: Lock | None) -> None:
    """Every folder about to be cloned into is free, or a clone the previous lock lists."""
    ours = set(previous.repositories) if previous else set()
    for path in sorted(sources):
        if (root / path).exists() and path not in ours:
            raise ConfigError(
                f"--workspace {root}: {path} exists and is not in {LOCK}, so uros did not clone it",
                "move it away (uros never replaces what it did not write), or use a new folder",
            )


# ---------------------------------------------------------------------------------------------
# uros update


@dataclass(frozen=True)
class UpdateArgs:
    directory: Path | None = None
    distro: str | None = None  # None: the workspace's own (uros.yaml)
    before: str | None = None  # YYYY-MM-DD: the newest commits before this day, not the newest
    dry_run: bool = False
    jobs: int = defaults.CLONE_JOBS
    verbose: bool = False


@dataclass(frozen=True)
class UpdatePlan:
    root: Path
    config: WorkspaceConfig
    lock: Lock  # what the workspace holds now
    distro: Distro  # the distro to move to (the workspace's own, or --distro)
    sources: Mapping[str, Source]  # workspace path -> the branch to move to (uros.yaml's mirror rules)
    kept: tuple[str, ...]  # clones in the lock and in the distro: fetched and moved
    added: tuple[str, ...]  # in the distro, not in the lock: cloned
    removed: tuple[str, ...]  # in the lock, not in the distro: removed (uros cloned them)
    args: UpdateArgs


def check_day(text: str, flag: str) -> str:
    """A calendar day as YYYY-MM-DD (git reads many date forms; uros takes one, so a lock says
    plainly what it was moved to)."""
    try:
        if len(text) != 10:
            raise ValueError(text)
        day = datetime.date.fromisoformat(text)
    except ValueError:
        raise ConfigError(f"{flag} {text!r}: not a day", "write it as YYYY-MM-DD, e.g. 2024-06-30") from None
    # git's date parser silently matches nothing from 2100 on (`git rev-list --before=2100-01-01`)
    if not 1970 <= day.year <= 2099:
        raise ConfigError(f"{flag} {text}: outside the years git reads (1970-2099)", "pick a day in them")
    return text


def plan_update(args: UpdateArgs) -> UpdatePlan:
    """Every input of `uros update` checked before git runs: a firmware workspace with its lock, a
    known distro, mirrors that exist, and new clones' folders free."""
    if args.jobs < 1:
        raise ConfigError(f"--git-jobs {args.jobs}: must be 1 or more")
    if args.before is not None:
        check_day(args.before, "--before")
    ws, cfg = Workspace.open_firmware(resolve_workspace(args.directory))
    if not ws.lock_path.is_file():
        raise ConfigError(
            f"--workspace {ws.root}: no {LOCK}, so uros does not know which clones it made",
            "re-create the workspace with `uros create-firmware --force`",
        )
    lock = read_lock(ws.lock_path, "--workspace")
    # --distro, else uros.yaml's (config/settings.py)
    name = resolve_one(DISTRO, {DISTRO.name: args.distro}, cfg, ws.root, {}).value
    if not name:  # a build needs no distro; moving the clones does
        raise ConfigError(
            f"{ws.root / CONFIG}: distro: is required by `uros update` but missing",
            "add the line 'distro: humble' (the distro the clones are of; `uros distros` lists them), "
            "or pass --distro NAME",
        )
    distro = distros_mod.load_distro(name)
    sources = plan_sources(distro, cfg.mirror, None)
    _check_sources(sources, f"{ws.root / CONFIG}: mirror")
    kept = tuple(sorted(set(sources) & set(lock.repositories)))
    added = tuple(sorted(set(sources) - set(lock.repositories)))
    removed = tuple(sorted(set(lock.repositories) - set(sources)))
    for path in added:
        if (ws.root / path).exists():
            raise ConfigError(
                f"--workspace {ws.root}: {path} exists and is not in {LOCK}, so uros did not clone it",
                "move it away (uros never replaces what it did not write), then run `uros update` again",
            )
    return UpdatePlan(ws.root, cfg, lock, distro, sources, kept, added, removed, args)


def _check_lock_covers(lock: Lock, distro: Distro, where: str) -> None:
    """A lock pins every repository of this distro, or it would be silently ignored for the ones
    it lacks (they would be cloned at their branches' newest commits, from the network)."""
    if lock.distro and lock.distro != distro.name:
        raise ConfigError(
            f"{where}: locks micro-ROS {lock.distro}, not {distro.name}",
            f"pass --distro {lock.distro}, or a lock written for {distro.name}",
        )
    wanted = {f"{ws}/{r.path}" for ws, repos in ((DEV_WS, distro.dev), (MCU_WS, distro.mcu)) for r in repos}
    unknown = sorted(set(lock.repositories) - wanted)
    if unknown:  # it would be skipped without a word: the lock is another workspace's, or edited
        raise ConfigError(
            f"{where}: locks {len(unknown)} repositor{'y' if len(unknown) == 1 else 'ies'} that "
            f"{distro.name} does not have ({', '.join(unknown[:3])}{', ...' if len(unknown) > 3 else ''})",
            f"pass the uros.lock that `uros create-firmware` wrote for {distro.name}, or remove "
            f"{'that entry' if len(unknown) == 1 else 'those entries'} from it",
        )
    missing = sorted(wanted - set(lock.repositories))
    if missing:
        raise ConfigError(
            f"{where}: has no commit for {len(missing)} of the {len(wanted)} repositories of {distro.name} "
            f"({', '.join(missing[:3])}{', ...' if len(missing) > 3 else ''})",
            "pass the uros.lock that `uros create-firmware` wrote for this distro",
        )


def plan_create(args: CreateArgs) -> CreatePlan:
    if args.platform != defaults.PLATFORM:
        raise ConfigError(
            f"create-firmware: unknown platform {args.platform!r}", "uros supports `generate_lib` (any MCU)"
        )
    if args.jobs < 1:
        raise ConfigError(f"--git-jobs {args.jobs}: must be 1 or more")
    distro = distros_mod.load_distro(args.distro)
    root = resolve_workspace(args.directory).resolve()
    check_build_folder(root, "--workspace")
    extras = tuple((p, check_extra_package(p, "--extra-package")) for p in args.extra_packages)
    locked: dict[str, str] | None = None
    if args.locked or args.lock_file:
        lock_path = args.lock_file or root / "uros.lock"
        lock_flag = "--lock-file" if args.lock_file else "--locked"
        lock = read_lock(lock_path, lock_flag)
        _check_lock_covers(lock, distro, f"{lock_flag} {lock_path}")
        locked = lock.commits()
    existed, existing, previous = _existing(root, args.force)
    mirror = _mirror_from(args, existing, distro)
    sources = plan_sources(distro, mirror, locked)
    _check_sources(sources)
    _check_destinations(root, sources, previous)
    probe = find_profile(args.toolchain, alternative="") if args.toolchain is not None else None
    return CreatePlan(root, existed, existing, previous, distro, mirror, sources, extras, probe, args)
