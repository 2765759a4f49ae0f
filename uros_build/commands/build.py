"""`uros build`: each target's libmicroros.a, include tree, CMake package and build-info.json.

A target's build is the sequence of steps in uros_build/steps/ (one module each): the run opened,
host facts, then under the target's lock the trees prepared, the inputs resolved (up to date: done),
the team cache asked, colcon, merge and verify, the swap, the upload.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.colcon import fingerprint as fp
from uros_build.config.plan import BuildPlan, plan_build
from uros_build.config.settings import BuildArgs, expand_targets
from uros_build.errors import (
    Interrupted,
    UrosError,
)
from uros_build.files import locked
from uros_build.steps import colcon_run, deliver, inputs, prepare, start, team_cache


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
    """One planned target: resolve → prepare the trees → the team cache → colcon → merge and
    verify → swap in → upload (model: colcon-core's BuildVerb.main, a sequence of named steps)."""
    runner = start.open_run(plan)
    facts = start.host_facts(plan, runner)
    with locked(plan.target_dir, plan.target.key):
        started = time.monotonic()
        repaired = prepare.prepare_trees(plan, facts)
        found = inputs.resolve(plan, facts, runner)
        if inputs.up_to_date(plan, found, repaired):
            team_cache.upload_if_asked(plan, found.key, deliver.entries_of(plan.output))
            return Outcome(plan.target.key, plan.output, "up to date")
        # From here the trees change: until this build succeeds, no state vouches for the output.
        fp.forget_state(found.state_path)
        hit = team_cache.take(runner, plan, found.key)
        if hit is not None:
            left = deliver.swap_in(plan, found, hit, merge_key="")
            assert plan.cache is not None
            deliver.say_done(
                plan, hit, left, started, f"from the cache {plan.cache.url.shown} (entry {found.key[:16]})"
            )
            return Outcome(plan.target.key, plan.output, "from the cache")
        compiled = colcon_run.compile_packages(plan, facts, runner, found)
        assembled, merge_key = deliver.merge_and_verify(runner, plan, facts, found, compiled)
        entries = deliver.entries_of(assembled.folder)
        left = deliver.swap_in(plan, found, assembled, merge_key)
    deliver.say_done(plan, assembled, left, started, "")
    team_cache.upload_if_asked(plan, found.key, entries)
    return Outcome(plan.target.key, plan.output, "built")
