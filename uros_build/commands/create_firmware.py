"""`uros create-firmware generate_lib`: a real micro-ROS firmware workspace from a distro manifest
(the layout is in workspace.py): plan and check every input, check the target's tools, clone in
parallel, write uros.lock, uros.yaml and colcon.meta, build the host tools once.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

from uros_build import console
from uros_build.colcon import devws
from uros_build.config.sourceplan import CreateArgs, CreatePlan, plan_create, print_stand_ins
from uros_build.errors import StepFailed, UrosError
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.sources import clones
from uros_build.sources import meta as meta_mod
from uros_build.sources.distros import Source
from uros_build.sources.workspace import PENDING, USER_META, Workspace, sync_tree
from uros_build.sources.wsfiles import CONFIG, DEV_WS, LOCK, MCU_WS, Lock, WorkspaceConfig, save_config
from uros_build.target import compilers


def _clone_all(runner: Runner, git: str, plan: CreatePlan, jobs: int) -> dict[str, str]:
    root, sources = plan.root, plan.sources

    def one(item: tuple[str, Source]) -> tuple[str, str]:
        path, source = item
        dest = root / path
        label = f"[{path}] "
        try:
            for argv in clones.clone_argv(git, source, dest):
                runner.run(argv, step=f"clone {path}", quiet=True, label=label)
        except StepFailed as exc:
            declared = next((o for o in plan.distro.stand_ins if o.matches(source.repo)), None)
            fix = (
                f"pass --stand-ins: the {plan.distro.name} manifest declares {declared.use} for it "
                f"({declared.reason})"
                if declared is not None and source.stand_in is None
                else f"override it: --mirror-override {source.repo.path}=URL@VERSION"
            )
            fix += f" (log: {runner.log_path})"
            raise clones.source_failed("cloning", path, source, exc, fix) from exc
        head = runner.query([git, "-C", str(dest), "rev-parse", "HEAD"], step=f"read {path}")
        return path, head.strip()

    console.step(f"cloning {len(sources)} repositories ({jobs} at a time)")
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(one, sorted(sources.items())))
    return dict(results)


def _remove_partial(root: Path, existed: bool, cloned: Iterable[str]) -> None:
    if not existed:
        shutil.rmtree(root, ignore_errors=True)
        console.info(f"removed the partial workspace {root} (keep it with --keep-partial)")
        return
    # Every folder cloned into was free or uros's own (plan._check_destinations).
    clones.remove_clones(root, cloned)
    clones.drop_dev_trees(root)
    console.info(f"removed the partial sources in {root} (keep them with --keep-partial)")


def _precheck(runner: Runner, plan: CreatePlan) -> str:
    """git, cmake and (with --toolchain) the target's compiler, C library and C++ headers, checked
    before anything is cloned, so a missing package costs seconds, not a clone and a dev_ws build."""
    git = runner.which("git")
    runner.which("cmake")
    if plan.probe is not None:
        tools, _ = compilers.probe_target_tools(runner, plan.probe)
        compilers.check_target_prerequisites(
            runner, plan.probe, tools, Workspace(plan.root).state_dir / "probe"
        )
    return git


def create_firmware(args: CreateArgs) -> Path:
    plan = plan_create(args)
    root, distro = plan.root, plan.distro
    root.mkdir(parents=True, exist_ok=True)
    # A new folder is removed whole when a step fails, so its log must live elsewhere for the
    # error's hint to name a file that exists.
    logs = Workspace(root).log_dir if plan.existed else user_log_dir()
    runner = Runner(new_run_log(logs, "create-firmware"), verbose=args.verbose)
    console.step(f"uros create-firmware {args.platform}: micro-ROS {distro.name} in {root}")
    console.info(f"log: {runner.log_path}")
    try:
        git = _precheck(runner, plan)
        if plan.previous is not None and not (root / PENDING).is_file():
            clones.check_untouched(
                runner,
                git,
                root,
                plan.previous,
                plan.previous.repositories,
                "then run this command again: it re-clones the folder",
            )
    except UrosError:
        if not plan.existed:
            shutil.rmtree(root, ignore_errors=True)
        raise
    if plan.previous is not None:
        clones.remove_clones(root, plan.previous.repositories)
        clones.drop_dev_trees(root)
    if distro.status == "manifest-only":
        console.warn(
            f"the {distro.name} manifest was written from upstream facts and not built by uros's authors"
        )
    if distro.stand_ins and not args.stand_ins:
        console.info(
            f"{distro.name} was built here with {len(distro.stand_ins)} stand-ins for branches the mirror "
            f"lacked, not with these branches (`uros distros show {distro.name}`; --stand-ins uses them)"
        )
    print_stand_ins(distro, plan.mirror, plan.sources)
    pending = root / PENDING
    pending.parent.mkdir(parents=True, exist_ok=True)
    unfinished = {p: "0" * 40 for p in plan.sources}
    pending.write_text(Lock.from_clones(distro.name, plan.sources, unfinished).to_json(), "utf-8")
    try:
        commits = _clone_all(runner, git, plan, args.jobs)
        (root / LOCK).write_text(Lock.from_clones(distro.name, plan.sources, commits).to_json(), "utf-8")
        for ws, ignored in ((MCU_WS, distro.colcon_ignore), (DEV_WS, distro.dev_colcon_ignore)):
            for missing in clones.mark_ignored(root, ws, ignored):
                console.warn(f"{missing} is not in the workspace; nothing to ignore there")
        extras = list(plan.existing.extra_packages) if plan.existing else []
        for path, name in plan.extra_packages:
            if str(path.resolve()) not in extras:
                extras.append(str(path.resolve()))
            sync_tree(path, Workspace(root).extra_dir / name)
        # --force keeps what the user added to uros.yaml (target, set, ...); --toolchain becomes the
        # target `uros build` builds by default, unless the file names one already
        cfg = replace(
            plan.existing or WorkspaceConfig(distro.name),
            distro=distro.name,
            platform=args.platform,
            mirror=plan.mirror,
            extra_packages=tuple(extras),
        )
        if args.toolchain is not None and cfg.target is None and not cfg.targets:
            cfg = replace(cfg, target=args.toolchain)
        save_config(root, cfg)
        if not (root / USER_META).exists():
            preset = meta_mod.load_preset(distro.preset)
            (root / USER_META).write_text(
                meta_mod.dump_meta(preset, f"{distro.name} generate_lib defaults; edit freely"),
                encoding="utf-8",
            )
        (root / "COLCON_IGNORE").write_text("uros: the firmware folder is not a package\n")
        if args.build_dev:
            devws.build_dev_workspace(Workspace(root), cfg, distro, runner, args.verbose)
    except (UrosError, KeyboardInterrupt):
        if not args.keep_partial:
            _remove_partial(root, plan.existed, plan.sources)
        raise
    pending.unlink(missing_ok=True)
    console.step(f"created {root} ({len(commits)} repositories, locked in {LOCK}; edit {CONFIG} freely)")
    return root
