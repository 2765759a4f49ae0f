"""The host tools workspace (dev_ws: ament and friends, built once for every target) and the
environment colcon runs in: sourced ROS 2 scrubbed, uros's Python first, dev_ws as if sourced,
git redirects for the build-time clones."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

from uros_build import console
from uros_build.colcon import command as colcon
from uros_build.colcon import relocate
from uros_build.colcon.hosttools import cmake_version, colcon_program, major
from uros_build.proc import Runner
from uros_build.sources import distros as distros_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.distros import Distro
from uros_build.sources.packages import PackageInfo
from uros_build.sources.workspace import Workspace, dev_env
from uros_build.sources.wsfiles import WorkspaceConfig


def colcon_env(
    ws: Workspace,
    cfg: WorkspaceConfig | None,
    distro: Distro | None,
    cmake_version: str,
    with_dev: bool = True,
) -> tuple[dict[str, str], list[str]]:
    """The environment colcon runs in: sourced ROS 2 scrubbed, uros's Python first, and for a
    firmware workspace its dev_ws (as if sourced) and git redirects for the build-time clones of
    its ``distro`` (the plan's, loaded once)."""
    git_config = None
    if cfg is not None and distro is not None:
        git_config = distros_mod.insteadof(distro.build_time_clones, cfg.mirror)
    env, scrubbed = colcon.build_env(
        os.environ,
        python_bin_dir=str(Path(colcon.host_python()).parent),
        cmake_major=major(cmake_version),
        git_config=git_config,
    )
    if cfg is not None and with_dev:
        env = dev_env(env, ws.dev_install)
    return env, scrubbed


DEV_PACKAGES = ".uros-dev-packages.json"  # in dev_ws/install: what the dev build built, of what


def dev_record(ws: Workspace) -> tuple[frozenset[str], frozenset[str]] | None:
    """(built, available): the dev_ws packages the last dev build built and those dev_ws had
    then; None for a dev_ws built whole (before uros built only the closure)."""
    try:
        data = json.loads((ws.dev_install / DEV_PACKAGES).read_text(encoding="utf-8"))
        return frozenset(data["built"]), frozenset(data["available"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def dev_needs_building(ws: Workspace, mcu: Sequence[PackageInfo]) -> bool:
    """dev_ws was never built, or the MCU packages now need a dev_ws package it did not build
    (a new extra package that finds another ament_cmake extension). Reads no package.xml."""
    if not ws.dev_built():
        return True
    record = dev_record(ws)
    if record is None:
        return False
    built, available = record
    wanted = {d for p in mcu for d in p.build_deps} & available
    return not wanted <= built


def build_dev_workspace(
    ws: Workspace,
    cfg: WorkspaceConfig,
    distro: Distro | None,  # None: a uros.yaml without one (no build-time clones to redirect)
    runner: Runner,
    verbose: bool,
    jobs: int | None = None,
) -> None:
    """Build the part of dev_ws (ament and friends) the MCU packages need, for the host; every
    target reuses it. micro_ros_setup builds all of it, uncrustify and a dozen linters included,
    which a BUILD_TESTING=OFF cross build never calls."""
    dev = packages_mod.discover(ws.dev_dir)
    needed = packages_mod.tool_closure(packages_mod.discover(ws.source_dir), dev)
    console.step(
        f"building the host tools workspace (dev_ws): {len(needed)} of its {len(dev)} packages, "
        "those the MCU packages need"
    )
    if needed:
        relocate.reconfigure_moved(ws.dev_dir / "build", "dev_ws")
        _cmake, version = cmake_version(runner)
        env, _ = colcon_env(ws, cfg, distro, version, with_dev=False)
        plan = colcon.ColconPlan(
            base_paths=(ws.dev_dir,),
            build_base=ws.dev_dir / "build",
            install_base=ws.dev_install,
            log_base=ws.dev_dir / "log",
            metas=(),
            toolchain_file=None,
            firmware=False,
            python=colcon.host_python(),
            generator=colcon.generator(env),
            verbose=verbose,
            parallel_workers=jobs,
            ignore_regex=None,
            packages_ignore=tuple(sorted({p.name for p in dev} - needed)),
        )
        runner.run(
            colcon.colcon_argv(plan, runner.which(colcon_program())),
            step="colcon build (dev_ws)",
            cwd=ws.dev_dir,
            env=env,
        )
    ws.dev_install.mkdir(parents=True, exist_ok=True)
    record = {"built": sorted(needed), "available": sorted(p.name for p in dev)}
    (ws.dev_install / DEV_PACKAGES).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    ws.mark_dev_built()
