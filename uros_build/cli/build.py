"""`uros build` (its options made from the settings table, config/settings.py) and the commands about
its outputs and trees: check, clean, doctor, info, size."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from uros_build.cli.common import (
    JSON,
    PATH_ARG,
    VERBOSE,
    setting_options,
    toolchain_option,
    workspace_option,
)
from uros_build.config.settings import SETTINGS


@click.command()
@setting_options(SETTINGS)
def build(**values: Any) -> None:
    """Build libmicroros.a, its include tree and a CMake package for a target (default: the
    target or targets in the workspace's uros.yaml)."""
    from uros_build.commands import build as build_cmd
    from uros_build.config.buildargs import BuildArgs

    build_cmd.build_all(BuildArgs(**values))


@click.command()
@click.argument("library", type=PATH_ARG)
@toolchain_option("The target the library must fit (see `uros targets`).")
@click.option("--profile", type=PATH_ARG, help="Or your own target profile (.yaml).")
@VERBOSE
@click.option("--json", "as_json", is_flag=True, help="Print the verdict as JSON.")
@click.option(
    "--whole-archive",
    is_flag=True,
    help="Fail (exit 5) on a global symbol two members define, as a --whole-archive link does.",
)
@click.option(
    "--for-firmware",
    type=PATH_ARG,
    help="Your firmware's sources: each message type they use, its largest size against MTU x history.",
)
def check(**request: Any) -> None:
    """Check that every object in LIBRARY has the ELF facts of a target (exit 5 if not); list the
    global symbols two members define and the symbols the firmware must provide."""
    from uros_build.commands import check as check_cmd

    check_cmd.check_library(check_cmd.CheckRequest(**request))  # every option a field by its own name


@click.command()
@toolchain_option(
    "The target whose trees and output to remove: a target name or your own toolchain file "
    "(default: uros.yaml's target)."
)
@click.option("--profile", type=PATH_ARG, help="Or the target of your own profile (.yaml).")
@click.option("--all", "everything", is_flag=True, help="Every target built in the workspace.")
@workspace_option("The workspace to clean.")
def clean(toolchain: str | None, profile: Path | None, everything: bool, workspace: Path | None) -> None:
    """Remove uros's per-target trees (.uros/targets/<target>) and outputs (build/<target>), never
    anything uros did not write, and say how much that freed."""
    from uros_build.commands import clean as clean_cmd

    clean_cmd.clean(workspace=workspace, toolchain=toolchain, everything=everything, profile=profile)


@click.command()
@toolchain_option("Also check this target's compiler, C library and C++ headers (default: uros.yaml's).")
@workspace_option("The workspace whose state to check.")
@click.option("--json", "as_json", is_flag=True, help="Print the checks as JSON.")
def doctor(toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """Check that this host can build (tools, target compiler, disk) and the workspace's state;
    one line per check with its fix, exit 5 when a build would fail."""
    from uros_build.commands import doctor as doctor_cmd

    doctor_cmd.doctor(workspace=workspace, toolchain=toolchain, as_json=as_json)


@click.command()
@click.argument("output", type=PATH_ARG, required=False)
@toolchain_option("Or the output of this target in the workspace (default: uros.yaml's target).")
@workspace_option("The workspace whose output to read.")
@JSON
def info(output: Path | None, toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """What a built library contains: ROS 2 types, packages and their commits, options in force,
    flags, sizes (OUTPUT: a `uros build` output folder)."""
    from uros_build.commands import info as info_cmd

    info_cmd.show_info(output=output, workspace=workspace, toolchain=toolchain, as_json=as_json)


@click.command()
@click.argument("library", type=PATH_ARG, required=False)
@toolchain_option("Or the library built for this target in the workspace (default: uros.yaml's).")
@workspace_option("The workspace whose library to measure.")
@click.option("--elf", type=PATH_ARG, help="The firmware ELF linked against the library (with --map).")
@click.option("--map", "map_file", type=PATH_ARG, help="The firmware's GNU ld map file (-Wl,-Map=app.map).")
@click.option("--objects", is_flag=True, help="Also list every object of the library.")
@click.option(
    "--ram",
    metavar="SIZE",
    help="The chip's RAM (e.g. 256K, 1M; K and M are 1024-based): does the library fit, with the heap "
    "and stack `uros probe` measured? Exit 5 when not (default: the chip the target's profile names).",
)
@click.option("--flash", metavar="SIZE", help="The chip's flash, as --ram (e.g. 2M).")
@JSON
def size(**request: Any) -> None:
    """text/data/bss of libmicroros.a per package (LIBRARY: the .a or its output folder), with the
    firmware's map file what each package costs once linked (after --gc-sections), and with --ram/--flash
    (or the chip the target's profile names) whether it fits."""
    from uros_build.commands import size as size_cmd

    size_cmd.show_size(size_cmd.SizeRequest(**request))  # every option a field by its own name
