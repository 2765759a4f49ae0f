"""The host stage (hoststage.py): the packages that compile nothing, built once per workspace for
the host, and taken into a target's trees before its colcon runs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from pathlib import Path

from uros_build import __version__, console
from uros_build.colcon import command as colcon
from uros_build.colcon import hoststage, relocate
from uros_build.errors import StepFailed
from uros_build.files import locked
from uros_build.sources import packages as packages_mod
from uros_build.steps.colcon_setup import ColconSetup, python_shim, shared_if_built
from uros_build.steps.context import Context
from uros_build.steps.toolchain_file import host_toolchain


def stage_lock(stage: hoststage.Stage) -> AbstractContextManager[None]:
    """One build of a stage at a time, and no copy from it while it is built."""
    return locked(stage.folder, "the host stage")


def ready(ctx: Context, setup: ColconSetup) -> tuple[str, ...]:
    """Just before colcon: the host stage built for its key (once) and its packages taken into the
    target's trees, under the stage's lock. Returns the packages it shares: those ``setup`` expected,
    or fewer when it failed or a listed package compiled code (() without a stage)."""
    stage, plan = setup.stage, ctx.plan
    if stage is None:
        return ()
    with stage_lock(stage):
        shared = shared_if_built(plan, stage)
        if shared is None:
            python = str(python_shim(plan, ctx.runner, stage.folder))
            toolchain = host_toolchain(plan, stage.folder, ctx.facts, ctx.runner, setup.env)
            shared = _build(ctx, stage, setup.env, setup.building, python, toolchain)
        take_into(setup.build_base, setup.install_base, stage, shared, plan.workspace.root)
    return shared


def _build(
    ctx: Context,
    stage: hoststage.Stage,
    env: Mapping[str, str],
    building: frozenset[str],
    python: str,
    toolchain_file: Path,
) -> tuple[str, ...]:
    """Build the stage (under :func:`stage_lock`) with ``python`` (the generation cache's shim)
    and ``toolchain_file`` (the host compilers' facts, found once); returns the packages it shares:
    those that compiled nothing (and need no other). A stage whose colcon fails shares nothing:
    each target builds them; --rebuild tries the stage again."""
    plan, facts, runner = ctx.plan, ctx.facts, ctx.runner
    written_by = f"uros {__version__} build"
    relocate.reconfigure_moved(stage.build_base, "the host stage")
    stage.meta_path.write_text(hoststage.meta_text(stage, written_by), encoding="utf-8")
    others = {p.name for p in plan.workspace_packages} | packages_mod.plain_cmake_packages(
        plan.workspace.source_dir
    )
    colcon_plan = colcon.ColconPlan(
        base_paths=(plan.workspace.source_dir,),
        build_base=stage.build_base,
        install_base=stage.install_base,
        log_base=stage.log_base,
        metas=(stage.meta_path,),
        toolchain_file=toolchain_file,
        python=python,
        generator=colcon.generator(env),
        verbose=plan.verbose,
        parallel_workers=plan.jobs,
        ignore_regex=None,
        packages_ignore=tuple(sorted(others - set(stage.packages))),
    )
    console.step(
        f"building {len(stage.packages)} packages that compile nothing once for every target "
        f"(the host stage, {stage.folder.name}): {', '.join(stage.packages)}"
    )
    try:
        runner.run(
            colcon.colcon_argv(colcon_plan, facts.colcon),
            step="colcon build (host stage)",
            cwd=plan.workspace.root,
            env=env,
            quiet=not plan.verbose,
        )
    except StepFailed as exc:
        console.warn(
            f"the host stage failed ({exc.message}): each target builds these packages itself; "
            f"the log: {runner.log_path}"
        )
        hoststage.write_marker(stage, hoststage.Marker(stage.key, (), (), failed=True), written_by)
        return ()
    compiled = tuple(
        p for p in stage.packages if hoststage.compiled_code(stage.build_base, stage.install_base, p)
    )
    shared = hoststage.choose(
        list(plan.workspace_packages), set(building), set(stage.packages) - set(compiled)
    )
    if compiled:
        them = "it" if len(compiled) == 1 else "them"
        console.warn(
            f"{', '.join(compiled)}: compiled code in the host stage, so each target builds {them} "
            f"(meta/host-stage.yaml lists {them} as compiling nothing)"
        )
    hoststage.write_marker(stage, hoststage.Marker(stage.key, shared, compiled), written_by)
    return shared


def take_into(
    target_build: Path, target_install: Path, stage: hoststage.Stage, shared: Sequence[str], workspace: Path
) -> None:
    """The shared packages into the target's trees (under :func:`stage_lock`), where they are not
    already the stage's."""
    stale = [p for p in shared if not hoststage.taken(target_build, p, stage.key)]
    if not stale:
        return
    copied = sum(hoststage.take(stage, p, target_build, target_install, workspace) for p in stale)
    console.info(
        f"from the host stage: {len(stale)} packages ({copied} files) into the target's install tree"
    )
