"""How colcon is run for a target: its command line and environment (ccache, the generation
cache's Python shim), the pure-Python packages left out, and the host stage's packages skipped.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import uros_build
from uros_build import __version__, console
from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import hoststage, hosttools
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.plan import BuildPlan, ProfileTarget
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.shim import gencache, pyshim
from uros_build.sources import packages as packages_mod
from uros_build.steps import host_stage
from uros_build.steps.toolchain_file import seeded_toolchain


@dataclass(frozen=True)
class ColconSetup:
    plan: colcon.ColconPlan
    argv: tuple[str, ...]
    env: Mapping[str, str]
    skipped: tuple[str, ...]  # pure-Python packages left out
    stage: hoststage.Stage | None = None  # the host stage this build takes packages from
    shared: tuple[str, ...] = ()  # the packages it takes from there (colcon skips them)

    @property
    def build_base(self) -> Path:
        return self.plan.build_base

    @property
    def install_base(self) -> Path:
        return self.plan.install_base


def colcon_setup(
    plan: BuildPlan,
    facts: HostFacts,
    toolchain_file: Path,
    meta_path: Path,
    runner: Runner,
    records: Mapping[str, fp.FileRecord],
) -> ColconSetup:
    ws = plan.workspace
    env, scrubbed = hosttools.colcon_env(ws, plan.config, plan.distro, facts.cmake_version)
    if scrubbed:
        console.warn(f"ignoring the sourced environment for this build: {', '.join(scrubbed)}")
    # colcon prints its job events with flush=True, but its other output is block-buffered in a
    # pipe: unbuffered, the live view sees each line when it is written.
    env = {**env, "PYTHONUNBUFFERED": "1"}
    launcher = _ccache(plan, env, runner)
    if launcher:
        env.update(colcon.ccache_env(ws.root, plan.target_dir / CCACHE_STATS))
    skipped = tuple(packages_mod.host_only(list(plan.workspace_packages)))
    # --packages/--for-firmware/uros.yaml packages: exactly their closure, without the test
    # dependencies colcon's --packages-up-to would add (a user's --packages-up-to stays colcon's)
    out = packages_mod.left_out(plan.workspace_packages, plan.selection.request) if plan.selection else None
    colcon_plan = colcon.ColconPlan(
        base_paths=(ws.source_dir,),
        packages_ignore=skipped if out is None else tuple(sorted(out | set(skipped))),
        build_base=plan.target_dir / "build",
        install_base=plan.target_dir / "install",
        log_base=plan.target_dir / "log",
        metas=(meta_path,),
        toolchain_file=seeded_toolchain(plan, facts, toolchain_file, runner, env),
        python=str(python_shim(plan, runner, plan.target_dir)),
        generator=colcon.generator(env),
        verbose=plan.verbose,
        packages_up_to=plan.packages_up_to,
        parallel_workers=plan.jobs,
        compiler_launcher=launcher,
    )
    building = building_names(plan, colcon_plan)
    stage = host_stage.stage_for(plan, facts, building, records, env)
    # what the stage shares, as its marker says (or, not built yet, every package it will build):
    # built only when colcon is about to run (ready_host_stage), after the team cache was asked
    shared = host_stage.expected_shares(plan, stage) if stage is not None else ()
    colcon_plan = dataclasses.replace(colcon_plan, packages_skip=shared)
    argv = tuple(colcon.colcon_argv(colcon_plan, facts.colcon))
    return ColconSetup(colcon_plan, argv, env, skipped, stage, shared)


def building_names(plan: BuildPlan, colcon_plan: colcon.ColconPlan) -> set[str]:
    """The packages colcon builds (or skips) for this target: the workspace's, or the closure of
    --packages-up-to, less what the plan ignores."""
    if colcon_plan.packages_up_to:
        names = packages_mod.closure(plan.workspace_packages, colcon_plan.packages_up_to)
    else:  # colcon also builds the CMake packages without a package.xml (Micro-CDR, the XRCE client)
        names = {p.name for p in plan.workspace_packages} | packages_mod.plain_cmake_packages(
            plan.workspace.source_dir
        )
    return colcon.kept_by_ignores(colcon_plan, names)


CCACHE_STATS = "ccache-stats.log"  # this build's ccache counters (the user's totals stay theirs)


def _ccache(plan: BuildPlan, env: Mapping[str, str], runner: Runner) -> str | None:
    """ccache's path when the build compiles through it: --ccache (then it must be installed),
    --no-ccache never, by default when it is on PATH. Only for uros's own toolchain: a user's
    toolchain file does not carry the path maps that keep the library the same under ccache."""
    if plan.ccache is False or not isinstance(plan.target, ProfileTarget):
        return None
    found = (
        runner.which("ccache", path=env.get("PATH"))
        if plan.ccache
        else shutil.which("ccache", path=env.get("PATH"))
    )
    if found is None:
        return None
    trouble = hosttools.ccache_unusable(runner, found, env)
    if trouble:
        console.warn(f"ccache cannot be used ({trouble}): compiling without it (the library is the same)")
        return None
    return found


def python_shim(plan: BuildPlan, runner: Runner, folder: Path) -> Path:
    """The Python of the CMake builds of a target (or of the host stage: ``folder``): the real one,
    with rosidl's generator runs and the configures' Python calls going through the workspace's
    caches (shared by every target: pyshim.py), and FindPython's questions about the interpreter
    answered as it answered them once for this build."""
    if not plan.gen_cache:  # UROS_GEN_CACHE=off (config/settings.py)
        return Path(colcon.host_python())
    shim = folder / "uros-python"
    python, code_dir = colcon.host_python(), Path(uros_build.__file__).resolve().parent.parent
    try:
        answers, has_distutils = pyshim.parse_answers(
            runner.query(
                pyshim.answers_argv(python, code_dir),
                step="ask Python what CMake will ask it",
                env={**os.environ, **pyshim.STDLIB_DISTUTILS},
            )
        )
    except ValueError:  # not what print_answers prints: every question goes to the interpreter
        answers, has_distutils = {}, False
    text = pyshim.shim_text(
        python,
        plan.gen_cache_dir,  # $UROS_GEN_CACHE_DIR, else the XDG cache's uros/gen: every workspace's
        folder,
        plan.workspace.root,
        code_dir,
        f"uros {__version__} build",
        gencache.module_versions(),
        stdlib_distutils=has_distutils,
        answers=answers,
    )
    write_if_changed(shim, text)
    shim.chmod(0o755)
    return shim
