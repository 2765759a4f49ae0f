"""colcon runs: the live view, the packages it built, a failure read from its logs, what it generated
and compiled from the caches, the headers it read outside the workspace.
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.colcon import command as colcon
from uros_build.colcon import depfiles, installtree
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.errors import (
    DiskFull,
    StepFailed,
    VerifyError,
)
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.shim import pyshim
from uros_build.steps.colcon_setup import CCACHE_STATS, ColconSetup
from uros_build.steps.context import Context
from uros_build.steps.inputs import Inputs, flags_fingerprint
from uros_build.steps.prepare import DISK_FULL_MARK
from uros_build.tooltext import disk_full_line, disk_full_path, first_error


def _record_outside_headers(plan: BuildPlan, runner: Runner, setup: ColconSetup) -> str:
    """Read, from ninja's record of the compiler's dependency output, every header each package's
    objects included from outside the workspace, and keep their sha256 for the next build. With
    another generator than Ninja there is no such record: those headers are not tracked."""
    ninja = colcon.ninja_program(setup.env)
    if ninja is None:
        return depfiles.changed_packages({})[1]
    roots = (plan.workspace.root, plan.target_dir)

    def outside(folder: Path) -> list[str]:
        text = runner.query(
            [ninja, "-C", str(folder), "-t", "deps"],
            step=f"read {folder.name}'s dependencies",
            label=f"[{folder.name}] ",
        )
        return depfiles.outside(depfiles.parse_ninja_deps(text), roots)

    folders = sorted(p for p in setup.build_base.iterdir() if (p / ".ninja_deps").is_file())
    # two at a time (~60 packages, each a ninja start and its parse): the runner logs from threads
    with ThreadPoolExecutor(max_workers=2, thread_name_prefix="uros-deps") as pool:
        per_package = dict(zip((f.name for f in folders), pool.map(outside, folders), strict=True))
    snap = depfiles.snapshot(per_package)
    write_if_changed(plan.target_dir / depfiles.RECORD, depfiles.record_text(snap))
    return depfiles.changed_packages(snap)[1]


def _say_ccache(plan: BuildPlan, setup: ColconSetup) -> dict[str, int]:
    """This build's ccache hits and misses (empty without ccache)."""
    if not setup.plan.compiler_launcher:
        return {}
    try:
        counts = colcon.ccache_counts((plan.target_dir / CCACHE_STATS).read_text(encoding="utf-8"))
    except OSError:
        counts = {"hits": 0, "misses": 0}
    total = counts["hits"] + counts["misses"]
    rate = f" ({100 * counts['hits'] / total:.0f}%)" if total else ""
    remote = f", {counts['remote_hits']} of them from its remote storage" if counts.get("remote_hits") else ""
    console.info(f"ccache: {counts['hits']} of {total} compiles taken from the cache{rate}{remote}")
    return counts


def _say_generation(plan: BuildPlan) -> None:
    try:
        runs = pyshim.count_runs((plan.target_dir / pyshim.RUNS).read_text(encoding="utf-8"))
    except OSError:
        return  # nothing configured or generated in this build
    generator_runs = runs["hit"] + runs["miss"] + runs["bypass"]
    if generator_runs:
        bypass = f", {runs['bypass']} not cacheable" if runs["bypass"] else ""
        console.info(
            f"interface code: {generator_runs} generator runs, {runs['hit']} taken from the "
            f"generation cache, {runs['miss']} generated{bypass}"
        )
    calls = runs["call-hit"] + runs["call-miss"] + runs["call-bypass"]
    if calls:
        console.info(
            f"configure: {calls} Python calls, {runs['call-hit']} answered from the generation cache"
        )


# Touched whenever a colcon build of the target returns. CMake's install copies a file only when its
# time differs from the installed copy's by a whole second (cmFileCopier::InstallFile,
# cmFileTimeCache::DifferS: https://gitlab.kitware.com/cmake/cmake/-/blob/v3.25.1/Source/cmFileCopier.cxx),
# so an archive or header rebuilt within the second of the last install stayed the old one in the
# install tree, and in the library (seen: a source edited right after a build, test_faults).
COLCON_ENDED = "colcon-ended"
# How long colcon took over each package of the target's last colcon build: kept beside its trees,
# not in build-info.json, which says what was built and must be the same for the same inputs.
TIMINGS = "timings.json"


def timings_json(finished: Mapping[str, float]) -> str:
    """The text of TIMINGS: package -> seconds (colcon's own measure), sorted (pure)."""
    data = {"package_seconds": {p: round(s, 2) for p, s in finished.items()}}
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def next_second_wait(last_end: float, now: float) -> float:
    """Seconds to wait before a colcon build so that every file it writes falls in a later second
    than those of the build that ended at ``last_end`` (pure; 0 after that second)."""
    return max(0.0, math.floor(last_end) + 1.0 + 0.02 - now)


def _run_colcon(
    plan: BuildPlan, facts: HostFacts, runner: Runner, setup: ColconSetup, parts: Mapping[str, str]
) -> colcon.BuildProgress:
    """colcon build into the target's own trees, shown as it goes (colcon's own job events).
    Every package colcon reports finished is stamped with the flags it was built with; one being
    built vouches for nothing."""
    if setup.skipped:
        console.info(f"not building {len(setup.skipped)} pure-Python packages: {', '.join(setup.skipped)}")
    flags = flags_fingerprint(parts)
    stamps = {p: installtree.package_stamp(flags, p, plan.meta.names.get(p, {})) for p in setup.building}
    afresh = installtree.forget_changed_configs(setup.build_base, stamps)
    if afresh:
        console.info(f"configuring afresh (their colcon.meta options changed): {', '.join(afresh)}")
    progress = colcon.BuildProgress(total=_expected_packages(setup), started_at=time.monotonic())
    console.step("colcon build")
    view = console.ProgressView(progress.total, plain=plan.verbose)

    def on_line(line: str) -> None:
        event = progress.feed(line, time.monotonic())
        if event is None:
            return
        if event.kind == "start":
            (setup.build_base / event.package / installtree.STAMP).unlink(missing_ok=True)
        elif event.kind == "finish":
            entry = plan.meta.names.get(event.package, {})
            installtree.write_stamp(
                setup.build_base, event.package, installtree.package_stamp(flags, event.package, entry)
            )
        ended = None
        if event.kind != "start":
            what = {"finish": "built", "fail": "FAILED", "abort": "stopped"}[event.kind]
            ended = (what, event.package, event.seconds or 0.0)
        view.update(
            console.Progress(
                progress.done,
                progress.total,
                tuple(progress.running.items()),
                progress.started_at,
                tuple(progress.failed),
            ),
            ended,
        )

    # Files CMake generates when it configures (a package's <pkg>Config.cmake, its targets file)
    # can be cut short by a full disk, and CMake writes them again only when it configures. A mark
    # written now, while there is room, and removed unless the disk filled up, makes the next build
    # configure every package afresh (the objects stay: ninja redoes only what differs).
    mark = plan.target_dir / DISK_FULL_MARK
    with contextlib.suppress(OSError):
        mark.write_text("a colcon build that may run out of disk\n", encoding="utf-8")
    ended = plan.target_dir / COLCON_ENDED
    with contextlib.suppress(OSError):
        time.sleep(next_second_wait(ended.stat().st_mtime, time.time()))
    try:
        runner.run(
            setup.argv,
            step="colcon build",
            cwd=plan.workspace.root,
            # colcon's build, install and log folders: a full disk that colcon reports without a
            # path ("Exception in shell extension 'sh': [Errno 28] ...") is theirs, not the workspace's
            writes_to=plan.target_dir,
            env=setup.colcon_env,  # without the extensions this target's colcon never uses
            hint=f"the full output is in {runner.log_path}",
            on_line=on_line,
            quiet=not plan.verbose,  # the command is in the log; the progress says the rest
        )
    except StepFailed as exc:
        failure = _colcon_failure(exc, setup.plan.log_base, runner.log_path)
        if not isinstance(failure, DiskFull):
            mark.unlink(missing_ok=True)
        raise failure from None
    finally:
        view.stop()
        with contextlib.suppress(OSError):
            ended.touch()
    mark.unlink(missing_ok=True)
    elapsed = time.monotonic() - progress.started_at
    slowest = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in progress.slowest(5))
    console.info(f"colcon built {len(progress.finished)} packages in {elapsed:.1f} s; slowest: {slowest}")
    with contextlib.suppress(OSError):  # a record of times is never why a build fails
        (plan.target_dir / TIMINGS).write_text(timings_json(progress.finished), encoding="utf-8")
    return progress


def _expected_packages(setup: ColconSetup) -> int:
    """How many packages colcon will build (for the progress view; colcon does not say)."""
    return len(setup.building - set(setup.shared))


def _check_built(
    plan: BuildPlan, setup: ColconSetup, progress: colcon.BuildProgress, parts: Mapping[str, str]
) -> tuple[str, ...]:
    """The packages of this build (those colcon reported finished), each stamped with this
    build's flags: VerifyError otherwise, before anything is merged."""
    built = tuple(sorted(progress.finished))
    if not built:
        raise StepFailed(
            "colcon reported no package built",
            f"check that colcon finds packages in {plan.workspace.source_dir}; the log is above",
        )
    flags = flags_fingerprint(parts)
    expected = {p: installtree.package_stamp(flags, p, plan.meta.names.get(p, {})) for p in built}
    stale = installtree.stale(setup.build_base, expected)
    if stale:
        raise VerifyError(
            f"{', '.join(stale)}: built with other flags than this build's (build stamp differs)",
            "run `uros build --rebuild` to build them again with the flags recorded",
        )
    return built


def _colcon_failure(exc: StepFailed, log_base: Path, run_log: Path) -> StepFailed | DiskFull:
    """Name the package that failed and its own first error, read from colcon's log of that
    package (the interleaved output of parallel packages can put another's line first)."""
    failed = colcon.failed_packages(exc.output)
    if not failed:
        return _disk_full(exc.output, log_base, "colcon build failed") or exc
    package = failed[0]
    log = colcon.package_log(log_base, package)
    lines = log.read_text(encoding="utf-8", errors="replace").splitlines() if log.is_file() else []
    full = _disk_full([*lines, *exc.output], log_base, f"colcon build failed in package {package}")
    if full is not None:
        return full
    cause = first_error(lines) or first_error(exc.output) or "no error line in its output"
    others = f" (also failed: {', '.join(failed[1:])})" if failed[1:] else ""
    where = f"its log: {log}; everything: {run_log}" if lines else f"the full output is in {run_log}"
    return StepFailed(f"colcon build failed in package {package}{others}: {cause}", where, exc.output)


# Below this, a failed build is taken for a full disk even when no tool said so (some, like CMake's
# file(WRITE) or an install step, report a short write in their own words).
_NEARLY_FULL = 1 << 20


def _disk_full(lines: list[str] | tuple[str, ...], where: Path, what: str) -> DiskFull | None:
    full = disk_full_line(lines)
    error = DiskFull.at((full and disk_full_path(full)) or where, f"{what}: {full}" if full else what)
    if full is not None or (error.free is not None and error.free < _NEARLY_FULL):
        return error
    return None


@dataclass(frozen=True)
class Compiled:
    packages: tuple[str, ...]  # what colcon built and what the host stage gave, in build-info's order
    shared: tuple[str, ...]  # of those, the host stage's
    progress: colcon.BuildProgress
    ccache: dict[str, int]  # this build's ccache hits and misses (empty without ccache)
    outside_headers: str  # the digest of the headers it read outside the workspace (their record kept)


def compile_packages(ctx: Context, setup: ColconSetup, inputs: Inputs) -> Compiled:
    """colcon over the workspace with ``setup``; then what the generation cache and ccache served,
    and the headers read outside the workspace."""
    plan, runner = ctx.plan, ctx.runner
    (plan.target_dir / pyshim.RUNS).unlink(missing_ok=True)
    (plan.target_dir / CCACHE_STATS).unlink(missing_ok=True)
    progress = _run_colcon(plan, ctx.facts, runner, setup, inputs.parts)
    _say_generation(plan)
    counts = _say_ccache(plan, setup)
    built = _check_built(plan, setup, progress, inputs.parts)
    # what the compiler read outside the workspace this time: the state records its content
    outside = _record_outside_headers(plan, runner, setup)
    return Compiled(tuple(sorted({*built, *setup.shared})), setup.shared, progress, counts, outside)
