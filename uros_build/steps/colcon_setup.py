"""How colcon is run for a target: its environment (ccache), its command line (the generation
cache's Python shim, the colcon.meta, the pure-Python packages left out) and the host stage whose
packages it skips: which stage, and what it shares.
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
from uros_build.colcon import devws, hoststage, hosttools
from uros_build.colcon import fingerprint as fp
from uros_build.config.buildplan import BuildPlan
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.shim import gencache, pyshim, shimfile
from uros_build.sources import meta as meta_mod
from uros_build.sources import packages as packages_mod
from uros_build.steps.context import Context
from uros_build.steps.renders import kept_render


@dataclass(frozen=True)
class Environment:
    """colcon's environment for this target, and the compiler launcher in it (ccache, or None)."""

    env: Mapping[str, str]
    launcher: str | None


def environment(ctx: Context) -> Environment:
    """colcon's environment (the sourced one scrubbed, said so) and ccache when it is used."""
    plan = ctx.plan
    env, scrubbed = devws.colcon_env(plan.workspace, plan.config, plan.distro, ctx.facts.cmake_version)
    if scrubbed:
        console.warn(f"ignoring the sourced environment for this build: {', '.join(scrubbed)}")
    # colcon prints its job events with flush=True, but its other output is block-buffered in a
    # pipe: unbuffered, the live view sees each line when it is written.
    env = {**env, "PYTHONUNBUFFERED": "1"}
    launcher = _ccache(plan, ctx.kind.uses_ccache, env, ctx.runner)
    if launcher:
        env.update(colcon.ccache_env(plan.workspace.root, plan.target_dir / CCACHE_STATS))
    return Environment(env, launcher)


@dataclass(frozen=True)
class ColconSetup:
    plan: colcon.ColconPlan
    argv: tuple[str, ...]
    env: Mapping[str, str]
    skipped: tuple[str, ...]  # pure-Python packages left out
    building: frozenset[str]  # what colcon builds or skips (building_names)
    stage: hoststage.Stage | None = None  # the host stage this build takes packages from
    shared: tuple[str, ...] = ()  # the packages it takes from there (colcon skips them)
    # a setup.py or setup.cfg in the sources outside every package.xml folder (colcon would find a
    # Python package there that uros does not list)
    loose_python: bool = True
    blocked: tuple[str, ...] = ()  # extensions this target's colcon runs without (python_blocked)

    @property
    def colcon_env(self) -> dict[str, str]:
        """The environment of this target's colcon run: :attr:`env` (which the host stage's colcon
        also runs in) with :attr:`blocked` added to colcon's blocklist."""
        return colcon.with_blocked(self.env, self.blocked)

    @property
    def build_base(self) -> Path:
        return self.plan.build_base

    @property
    def install_base(self) -> Path:
        return self.plan.install_base


def meta_text(plan: BuildPlan) -> str:
    """The merged colcon.meta as the build writes it."""
    return meta_mod.dump_meta(plan.meta, f"uros build --toolchain {plan.target.key}")


def colcon_setup(
    ctx: Context, environment: Environment, toolchain_file: Path, records: Mapping[str, fp.FileRecord]
) -> ColconSetup:
    """colcon's command for this target (with ``toolchain_file``, the seeded one): colcon.meta
    written (when it changes), the Python shim named (:func:`python_shim` writes it when colcon is
    to run), the host stage chosen from the sources ``records`` and what it is expected to share
    skipped."""
    plan, env = ctx.plan, environment.env
    ws = plan.workspace
    meta_path = plan.target_dir / "colcon.meta"
    write_if_changed(meta_path, meta_text(plan))
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
        toolchain_file=toolchain_file,
        python=str(shim_path(plan, plan.target_dir)),
        generator=colcon.generator(env),
        verbose=plan.verbose,
        packages_up_to=plan.packages_up_to,
        parallel_workers=plan.jobs,
        compiler_launcher=environment.launcher,
    )
    building = frozenset(building_names(plan, colcon_plan))
    stage = _stage_for(ctx, building, records, env)
    argv = tuple(colcon.colcon_argv(colcon_plan, ctx.facts.colcon))
    loose = bool(packages_mod.python_outside_packages(plan.workspace_packages, ws.source_dir, records))
    blocked = python_blocked(plan, colcon_plan, loose)
    setup = ColconSetup(colcon_plan, argv, env, skipped, building, stage, loose_python=loose, blocked=blocked)
    # what the stage shares, as its marker says (or, not built yet, every package it will build):
    # built only when colcon is about to run (host_stage.ready), after the team cache was asked
    return sharing(ctx, setup, _expected_shares(plan, stage) if stage is not None else ())


def sharing(ctx: Context, setup: ColconSetup, shared: tuple[str, ...]) -> ColconSetup:
    """``setup`` with the host stage's packages ``shared`` skipped by colcon (itself when they are
    the ones it skips already)."""
    if shared == setup.shared and setup.plan.packages_skip == shared:
        return setup
    colcon_plan = dataclasses.replace(setup.plan, packages_skip=shared)
    argv = tuple(colcon.colcon_argv(colcon_plan, ctx.facts.colcon))
    blocked = python_blocked(ctx.plan, colcon_plan, setup.loose_python)
    return dataclasses.replace(setup, plan=colcon_plan, argv=argv, shared=shared, blocked=blocked)


def python_blocked(plan: BuildPlan, colcon_plan: colcon.ColconPlan, loose_python: bool) -> tuple[str, ...]:
    """colcon's Python package extensions (colcon.PYTHON_EXTENSIONS), blocked for this target's
    colcon run when it builds no package of another build type than CMake's and the sources hold no
    ``loose_python`` (pure); () otherwise. What colcon builds is counted from above: every
    package.xml package its ignores keep, less those it skips (the host stage's), whatever
    --packages-up-to leaves out."""
    names = {p.name for p in plan.workspace_packages}
    built = colcon.kept_by_ignores(colcon_plan, names) - set(colcon_plan.packages_skip)
    if loose_python or packages_mod.builds_python(plan.workspace_packages, built):
        return ()
    return colcon.PYTHON_EXTENSIONS


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


def _stage_for(
    ctx: Context, building: frozenset[str], records: Mapping[str, fp.FileRecord], env: Mapping[str, str]
) -> hoststage.Stage | None:
    """The host stage of this target's build: None when switched off or when no package qualifies."""
    plan, facts = ctx.plan, ctx.facts
    if not plan.host_stage:
        return None
    chosen = hoststage.choose(list(plan.workspace_packages), set(building), hoststage.load_list().packages)
    if not chosen:
        return None
    ws = plan.workspace
    by_name = {p.name: p for p in plan.workspace_packages}
    sources = {name: hoststage.package_sources(records, ws.source_dir, by_name[name]) for name in chosen}
    dev = ws.dev_built_from()
    tools = (facts.cmake, facts.cmake_version, facts.colcon, str(colcon.generator(env)), colcon.host_python())
    return hoststage.plan_stage(ws.stages_dir, chosen, plan.meta.names, tools, sources, dev)


def _expected_shares(plan: BuildPlan, stage: hoststage.Stage) -> tuple[str, ...]:
    """What the stage will share, known without building it (resolve needs it for the colcon
    command): its marker's answer when it is built for its key, else every package it builds."""
    found = shared_if_built(plan, stage)
    return stage.packages if found is None else found


def shared_if_built(plan: BuildPlan, stage: hoststage.Stage) -> tuple[str, ...] | None:
    """What the stage shares when it is built for its key (under host_stage.stage_lock); None when it
    must be built (never built, its inputs changed, or it failed and --rebuild asks again)."""
    found = hoststage.read_marker(stage)
    if found is None or found.key != stage.key or (found.failed and plan.rebuild):
        return None
    return found.shared


CCACHE_STATS = "ccache-stats.log"  # this build's ccache counters (the user's totals stay theirs)


def _ccache(plan: BuildPlan, allowed: bool, env: Mapping[str, str], runner: Runner) -> str | None:
    """ccache's path when the build compiles through it: --ccache (then it must be installed),
    --no-ccache never, by default when it is on PATH. Only for uros's own toolchain: a user's
    toolchain file does not carry the path maps that keep the library the same under ccache."""
    if plan.ccache is False or not allowed:
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


def shim_path(plan: BuildPlan, folder: Path) -> Path:
    """The Python colcon's CMake builds are given (``Python3_EXECUTABLE``): the shim in ``folder``
    that :func:`python_shim` writes, or the real interpreter with UROS_GEN_CACHE=off. Named in
    colcon's command (an input of the build) without asking the interpreter anything."""
    if not plan.gen_cache:  # UROS_GEN_CACHE=off (config/settings.py)
        return Path(colcon.host_python())
    return folder / "uros-python"


def python_shim(plan: BuildPlan, runner: Runner, folder: Path) -> Path:
    """The Python of the CMake builds of a target (or of the host stage: ``folder``), written before
    its colcon runs (an up-to-date build, which runs none, starts no interpreter for it): the real
    one, with rosidl's generator runs and the configures' Python calls going through the
    workspace's caches (shared by every target: pyshim.py), and FindPython's questions about the
    interpreter answered as it answered them once for this build. Returns :func:`shim_path`."""
    shim = shim_path(plan, folder)
    if not plan.gen_cache:
        return shim
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
    found = shimfile.Shim(
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
    # kept per folder (steps/renders.py): a build that only runs colcon again imports no jinja2
    template = ("uros-python.sh.j2",)
    text = kept_render(folder, "uros-python", repr(found), template, lambda: shimfile.shim_text(found))
    write_if_changed(shim, text)
    shim.chmod(0o755)
    return shim
