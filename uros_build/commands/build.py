"""`uros build`: each target's libmicroros.a, include tree, CMake package and build-info.json.

A target's build is the sequence of steps in uros_build/steps/, each over one frozen context: the
run opened, host facts, extra packages and dev_ws; then under the target's lock the trees prepared,
the toolchain file, the sources scanned, colcon's environment, the seeded toolchain, colcon's
command, readers of changed headers dropped, the inputs (up to date: done), the team cache asked,
packages the workspace lost dropped, colcon's Python shim written, the host stage readied, colcon,
merge and verify, the swap, the upload.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.colcon import fingerprint as fp
from uros_build.config.buildargs import BuildArgs, expand_targets
from uros_build.config.buildplan import BuildPlan
from uros_build.config.plan import plan_build
from uros_build.errors import (
    Interrupted,
    UrosError,
)
from uros_build.files import locked
from uros_build.output import folders as outputs
from uros_build.steps import (
    colcon_setup,
    inputs,
    prepare,
    start,
    target_kind,
    team_cache,
    toolchain_file,
)
from uros_build.steps.context import Context


@dataclass(frozen=True)
class Outcome:
    target: str
    output: Path
    how: str  # "built", "up to date", "from the cache"


def build_all(args: BuildArgs) -> list[Outcome]:
    """`uros build`: the targets the command line names (--toolchain, repeatable), else each one
    the workspace's uros.yaml names (target: or targets:). Several targets: every one is planned
    first (a typo in the last fails before the first builds), each is built even when another
    fails, and a line per target says how it ended; the first failure is the command's."""
    requests = expand_targets(args)
    if len(requests) == 1:
        return [build(plan_build(requests[0]))]
    names = ", ".join(str(r.toolchain) for r in requests)
    console.step(f"building {len(requests)} targets ({names}) from {requests[0].toolchain_from}")
    plans = [plan_build(request) for request in requests]
    outcomes: list[Outcome] = []
    ended: list[str] = []
    failure: UrosError | None = None
    for plan in plans:
        started = time.monotonic()
        try:
            outcome = build(plan)
        except Interrupted:
            raise
        except UrosError as exc:
            failure = failure or exc
            ended.append(f"{plan.target.key}: FAILED (exit {exc.exit_code}: {str(exc).splitlines()[0]})")
            continue
        outcomes.append(outcome)
        ended.append(f"{outcome.target}: {outcome.how} ({time.monotonic() - started:.1f} s)")
    console.step(f"{len(requests)} targets:")
    for line in ended:
        (console.warn if "FAILED" in line else console.info)(line)
    if failure is not None:
        raise failure
    return outcomes


def build(plan: BuildPlan) -> Outcome:
    """One planned target, every action in the order it is taken (model: colcon-core's
    BuildVerb.main): each step takes the frozen context and what earlier steps returned."""
    runner = start.open_run(plan)
    facts = start.host_facts(plan, runner)
    ctx = Context(plan, runner, facts, target_kind.kind_of(plan, facts))
    start.sync_extra_packages(ctx)
    start.build_dev_workspace(ctx)
    with locked(plan.target_dir, plan.target.key):
        started = time.monotonic()
        repaired = prepare.prepare_trees(ctx)
        toolchain = toolchain_file.write_toolchain(ctx)
        sources = inputs.scan(ctx)
        env = colcon_setup.environment(ctx)
        seeded = toolchain_file.seeded_toolchain(ctx, toolchain, env.env)
        setup = colcon_setup.colcon_setup(ctx, env, seeded, sources)
        outside = prepare.drop_readers_of_changed_headers(ctx)
        found = inputs.resolve(ctx, toolchain, setup, sources, outside)
        if inputs.up_to_date(ctx, found, repaired):
            team_cache.upload_if_asked(ctx, found.key, outputs.entries_of(plan.output))
            return Outcome(plan.target.key, plan.output, "up to date")
        # the steps that build and deliver, imported here: an up-to-date build (a daily one, most of
        # the test suite's) never needs them (start-up cost)
        from uros_build.steps import colcon_run, deliver, host_stage

        # From here the trees change: until this build succeeds, no state vouches for the output.
        fp.forget_state(found.state_path)
        hit = team_cache.take(ctx, found.key, sources)
        if hit is not None:
            left = deliver.swap_in(ctx, found, hit)
            assert plan.cache is not None
            origin = f"from the cache {plan.cache.url.shown} (entry {found.key[:16]})"
            deliver.say_done(ctx, hit, left, started, origin)
            return Outcome(plan.target.key, plan.output, "from the cache")
        prepare.drop_removed_packages(ctx)
        colcon_setup.python_shim(plan, ctx.runner, plan.target_dir)  # colcon's Python, asked and written
        setup = colcon_setup.sharing(ctx, setup, host_stage.ready(ctx, setup))
        found = inputs.with_colcon(ctx, found, setup)
        compiled = colcon_run.compile_packages(ctx, setup, found)
        found = inputs.with_outside_headers(found, compiled.outside_headers)
        assembled = deliver.assemble(ctx, found, setup, compiled)
        entries = outputs.entries_of(assembled.folder)
        left = deliver.swap_in(ctx, found, assembled)
    deliver.say_done(ctx, assembled, left, started, "")
    team_cache.upload_if_asked(ctx, found.key, entries)
    return Outcome(plan.target.key, plan.output, "built")
