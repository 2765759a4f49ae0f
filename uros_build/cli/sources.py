"""The commands that make and move a workspace's sources: create-firmware, update, add-package."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from uros_build import defaults
from uros_build.cli.common import (
    MIRRORS,
    PATH_ARG,
    VERBOSE,
    Decorator,
    complete_distros,
    mirror_override_option,
    toolchain_option,
    workspace_option,
)


def _git_jobs(what: str) -> Decorator:
    """``--git-jobs`` (named apart from build's ``-j``, which is colcon's parallel packages)."""
    return click.option(
        "--git-jobs", "jobs", type=int, default=defaults.CLONE_JOBS, show_default=True,
        help=f"Parallel git {what} (`uros build -j` is colcon's parallel packages).",
    )  # fmt: skip


@click.command("create-firmware")
@click.argument("platform", default=defaults.PLATFORM)
@click.option(
    "--distro",
    default=defaults.DISTRO,
    show_default=True,
    help="micro-ROS distro (see `uros distros`).",
    shell_complete=complete_distros,
)
@workspace_option("Workspace folder to create.")
@MIRRORS
@mirror_override_option("workspace path like uros/rclc, or owner/repo")
@click.option("--config", type=PATH_ARG, help="A uros.yaml with a mirror: section (rules, overrides).")
@click.option(
    "--stand-ins", is_flag=True,
    help="Use the stand-ins the distro declares for branches a mirror lacks (`uros distros`); each is "
    "printed with its reason and recorded in uros.yaml and uros.lock.",
)  # fmt: skip
@click.option("--locked", is_flag=True, help="Clone exactly the commits in <workspace>/uros.lock.")
@click.option("--lock-file", type=PATH_ARG, help="Clone exactly the commits in this lock file.")
@click.option(
    "--extra-package", "extra_packages", multiple=True, type=PATH_ARG,
    help="A package folder (e.g. custom interfaces) to build with micro-ROS (repeatable).",
)  # fmt: skip
@click.option("--force", is_flag=True, help="Re-clone the repositories its uros.lock lists (keeps the rest).")
@click.option("--keep-partial", is_flag=True, help="Keep what was created when a step fails.")
@click.option(
    "--no-dev-build", is_flag=True, help="Do not build the host tools now (the first `uros build` will)."
)
@toolchain_option("Check this target's compiler, C library and C++ headers before cloning.")
@_git_jobs("clones")
@VERBOSE
def create_firmware(workspace: Path | None, no_dev_build: bool, **values: Any) -> None:
    """Create a micro-ROS firmware workspace (PLATFORM: generate_lib, a library for any MCU)."""
    from uros_build.commands import create_firmware as create_cmd
    from uros_build.config.sourceplan import CreateArgs  # here, not at the top: start-up cost

    create_cmd.create_firmware(CreateArgs(directory=workspace, build_dev=not no_dev_build, **values))


@click.command("update")
@workspace_option("Firmware workspace.")
@click.option(
    "--distro",
    default=None,
    help="Move to this distro's branches (default: the workspace's own, from uros.yaml).",
    shell_complete=complete_distros,
)
@click.option(
    "--before",
    metavar="YYYY-MM-DD",
    help="The newest commits before this day instead (a consistent snapshot of branches that move apart).",
)
@click.option("--dry-run", is_flag=True, help="Fetch and show what would move; change nothing.")
@_git_jobs("fetches")
@VERBOSE
def update(
    workspace: Path | None, distro: str | None, before: str | None, dry_run: bool, jobs: int, verbose: bool
) -> None:
    """Move the workspace's clones to the newest commits of their branches (no re-clone), show what
    moved and write uros.lock."""
    from uros_build.commands import update as update_cmd
    from uros_build.config.sourceplan import UpdateArgs  # here, not at the top: start-up cost

    update_cmd.update(
        UpdateArgs(
            directory=workspace, distro=distro, before=before, dry_run=dry_run, jobs=jobs, verbose=verbose
        )
    )


@click.command("add-package")
@click.argument("source")
@workspace_option("Firmware workspace.")
@click.option("--version", help="Branch or tag, for a git URL.")
@VERBOSE
def add_package(source: str, workspace: Path | None, version: str | None, verbose: bool) -> None:
    """Add a package (a folder, kept in sync at every build, or a git URL) to the MCU workspace."""
    from uros_build.commands import add_package as add_package_cmd

    add_package_cmd.add_package(source, workspace, version, verbose)
