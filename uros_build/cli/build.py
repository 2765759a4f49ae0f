"""`uros build` and the commands about its outputs and trees: check, clean, doctor, info, size."""

from __future__ import annotations

from pathlib import Path

import click

from uros_build.cli.common import (
    JSON,
    METAS,
    PATH_ARG,
    PRESET,
    SETS,
    TRANSPORT,
    VERBOSE,
    Option,
    complete_packages,
    complete_targets,
    output_option,
    toolchain_option,
    workspace_option,
)
from uros_build.commands import build as build_cmd
from uros_build.commands import check as check_cmd
from uros_build.commands import clean as clean_cmd
from uros_build.commands import doctor as doctor_cmd
from uros_build.commands import info as info_cmd
from uros_build.commands import size as size_cmd
from uros_build.config.buildargs import BuildArgs


@click.command()
@click.option(
    "--toolchain", "--target", "toolchains", cls=Option, aliases=("--target",), multiple=True,
    help="A target name (see `uros targets`) or your own CMake toolchain file; repeat it to build "
    "several targets in one run (default: uros.yaml's target or targets).",
    shell_complete=complete_targets,
)  # fmt: skip
@click.option(
    "--profile",
    type=PATH_ARG,
    help="Your own target profile (.yaml; `uros targets show NAME` prints one to start from).",
)
@workspace_option("The firmware workspace.")
@METAS
@SETS
@PRESET
@TRANSPORT
@output_option("Output folder (default: <workspace>/build/<target>).")
@click.option(
    "--packages",
    "packages",
    multiple=True,
    metavar="PKG",
    help="The packages the firmware wants (repeatable); the core and the extra packages are added, "
    "and only their closure is built (default: uros.yaml's packages:, else every package).",
    shell_complete=complete_packages,
)
@click.option(
    "--for-firmware",
    type=PATH_ARG,
    metavar="DIR",
    help="Build what the firmware in DIR uses: the interface packages its C/C++ sources include "
    "(<pkg/msg/...>) or take type support of, plus the core and the extra packages.",
)
@click.option(
    "--packages-up-to",
    multiple=True,
    help="Build exactly these packages and their dependencies (colcon's).",
    shell_complete=complete_packages,
)
@click.option("-j", "--jobs", type=int, help="Packages built in parallel (colcon --parallel-workers).")
@click.option(
    "--compiler-prefix",
    help="Derive a target: this compiler prefix (e.g. arm-none-eabi-) instead of the profile's.",
)
@click.option(
    "--cflags", multiple=True, metavar="FLAG",
    help="Derive a target: one more compiler flag (repeatable; one flag each, never split).",
)  # fmt: skip
@click.option(
    "--idf-build", type=PATH_ARG, metavar="DIR",
    help="An ESP-IDF project's build folder (after idf.py reconfigure): compile micro-ROS against "
    "its components, sdkconfig.h and C flags (default: uros.yaml's idf_build).",
)  # fmt: skip
@click.option(
    "--rtos", type=click.Choice(["freertos"]), metavar="freertos",
    help="Compile micro-ROS against an RTOS: freertos, with --rtos-dir and --rtos-config "
    "(default: uros.yaml's rtos:; docs/rtos.md).",
)  # fmt: skip
@click.option(
    "--rtos-dir", type=PATH_ARG, metavar="KERNEL",
    help="The FreeRTOS-Kernel folder (holds include/FreeRTOS.h and portable/).",
)  # fmt: skip
@click.option("--rtos-config", type=PATH_ARG, metavar="DIR", help="The folder holding your FreeRTOSConfig.h.")
@click.option(
    "--rtos-port", metavar="PORT",
    help="The kernel's port folder under portable/ (e.g. GCC/ARM_CM4F), or an absolute folder "
    "(default: the core's, meta/rtos/freertos.yaml).",
)  # fmt: skip
@click.option(
    "--ip-stack", type=click.Choice(["lwip", "freertos-tcp"]), metavar="lwip|freertos-tcp",
    help="Compile the udp transport against an IP stack: lwip or freertos-tcp, with --ip-stack-dir and "
    "--ip-stack-config (needs --rtos; default: uros.yaml's ip_stack:; docs/network.md).",
)  # fmt: skip
@click.option(
    "--ip-stack-dir",
    type=PATH_ARG,
    metavar="DIR",
    help="The stack's folder (lwIP: src/include/lwip/, contrib/; FreeRTOS+TCP: source/).",
)
@click.option(
    "--ip-stack-config",
    type=PATH_ARG,
    metavar="DIR",
    help="The folder of your lwipopts.h and arch/cc.h, or FreeRTOSIPConfig.h.",
)
@click.option(
    "--cache", metavar="URL",
    help="A team cache of outputs: file:///DIR or http(s)://HOST/PATH (GET/PUT: nginx WebDAV, "
    "bazel-remote, Artifactory...). An output built elsewhere with the same build key is taken "
    "from it, checked, instead of building (default: uros.yaml's cache:; none: no cache).",
)  # fmt: skip
@click.option(
    "--cache-upload", is_flag=True,
    help="Upload this build's output to the cache (CI); without it the cache is only read. "
    "Credentials: $UROS_CACHE_TOKEN or ~/.netrc, never in the URL.",
)  # fmt: skip
@click.option(
    "--ccache/--no-ccache", default=None,
    help="Compile through ccache (default: when it is installed); the library is the same either way.",
)  # fmt: skip
@click.option("--force", is_flag=True, help="Write into an --output folder holding other files (kept).")
@click.option(
    "--rebuild", is_flag=True, help="Run every step even when no input changed (the cache is not read)."
)
@click.option(
    "-v", "--verbose", is_flag=True,
    help="Print every setting in force and who chose it (docs/settings.md), and stream the tools' output.",
)  # fmt: skip
def build(
    toolchains: tuple[str, ...],
    profile: Path | None,
    workspace: Path | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    preset: str,
    transport: str | None,
    output: Path | None,
    packages: tuple[str, ...],
    for_firmware: Path | None,
    packages_up_to: tuple[str, ...],
    jobs: int | None,
    compiler_prefix: str | None,
    cflags: tuple[str, ...],
    idf_build: Path | None,
    rtos: str | None,
    rtos_dir: Path | None,
    rtos_config: Path | None,
    rtos_port: str | None,
    ip_stack: str | None,
    ip_stack_dir: Path | None,
    ip_stack_config: Path | None,
    cache: str | None,
    cache_upload: bool,
    ccache: bool | None,
    force: bool,
    rebuild: bool,
    verbose: bool,
) -> None:
    """Build libmicroros.a, its include tree and a CMake package for a target (default: the
    target or targets in the workspace's uros.yaml)."""
    build_cmd.build_all(
        BuildArgs(
            workspace=workspace,
            toolchain=toolchains[0] if len(toolchains) == 1 else None,
            toolchains=toolchains,
            profile=profile,
            metas=metas,
            sets=sets,
            preset=preset,
            transport=transport,
            output=output,
            verbose=verbose,
            force=force,
            packages_up_to=packages_up_to,
            jobs=jobs,
            compiler_prefix=compiler_prefix,
            cflags=cflags,
            idf_build=idf_build,
            rtos=rtos,
            rtos_dir=rtos_dir,
            rtos_config=rtos_config,
            rtos_port=rtos_port,
            ip_stack=ip_stack,
            ip_stack_dir=ip_stack_dir,
            ip_stack_config=ip_stack_config,
            rebuild=rebuild,
            packages=packages,
            for_firmware=for_firmware,
            cache=cache,
            cache_upload=cache_upload,
            ccache=ccache,
        )
    )


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
def check(
    library: Path,
    toolchain: str | None,
    profile: Path | None,
    verbose: bool,
    as_json: bool,
    whole_archive: bool,
    for_firmware: Path | None,
) -> None:
    """Check that every object in LIBRARY has the ELF facts of a target (exit 5 if not); list the
    global symbols two members define and the symbols the firmware must provide."""
    check_cmd.check_library(library, toolchain, profile, verbose, as_json, whole_archive, for_firmware)


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
    clean_cmd.clean(workspace, toolchain, everything, profile)


@click.command()
@toolchain_option("Also check this target's compiler, C library and C++ headers (default: uros.yaml's).")
@workspace_option("The workspace whose state to check.")
@click.option("--json", "as_json", is_flag=True, help="Print the checks as JSON.")
def doctor(toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """Check that this host can build (tools, target compiler, disk) and the workspace's state;
    one line per check with its fix, exit 5 when a build would fail."""
    doctor_cmd.doctor(workspace, toolchain, as_json)


@click.command()
@click.argument("output", type=PATH_ARG, required=False)
@toolchain_option("Or the output of this target in the workspace (default: uros.yaml's target).")
@workspace_option("The workspace whose output to read.")
@JSON
def info(output: Path | None, toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """What a built library contains: ROS 2 types, packages and their commits, options in force,
    flags, sizes (OUTPUT: a `uros build` output folder)."""
    info_cmd.show_info(output, workspace, toolchain, as_json)


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
def size(
    library: Path | None,
    toolchain: str | None,
    workspace: Path | None,
    elf: Path | None,
    map_file: Path | None,
    objects: bool,
    ram: str | None,
    flash: str | None,
    as_json: bool,
) -> None:
    """text/data/bss of libmicroros.a per package (LIBRARY: the .a or its output folder), with the
    firmware's map file what each package costs once linked (after --gc-sections), and with --ram/--flash
    (or the chip the target's profile names) whether it fits."""
    size_cmd.show_size(library, workspace, toolchain, elf, map_file, objects, as_json, ram, flash)
