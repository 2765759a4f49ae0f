"""The commands about uros's data and exports: targets, distros, toolchain render, meta write and
options, export, probe, interface new."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from uros_build.cli.common import (
    FROM,
    JSON,
    METAS,
    PATH_ARG,
    PRESET,
    SETS,
    TRANSPORT,
    VERBOSE,
    Group,
    complete_distros,
    complete_targets,
    output_option,
    table,
    toolchain_option,
    workspace_option,
)
from uros_build.output import exports
from uros_build.output.exports.base import ExportFormat


@click.group(cls=Group, invoke_without_command=True, subcommand_metavar="[show NAME]")
@JSON
@click.pass_context
def targets(ctx: click.Context, as_json: bool) -> None:
    """List the shipped target profiles (`uros targets show NAME` prints one)."""
    from uros_build.commands import listings

    if ctx.invoked_subcommand is None:
        columns = (("name", "TARGET"), ("compiler", "COMPILER"), ("transport", "TRANSPORT"))
        table(listings.targets_table(), as_json, (*columns, ("description", "DESCRIPTION")))


@click.command("show")
@click.argument("name", shell_complete=complete_targets)
def targets_show(name: str) -> None:
    """Print the profile of target NAME, to copy and edit: uros targets show cortex-m7 > my-board.yaml"""
    from uros_build.commands import listings

    click.echo(listings.target_profile_text(name), nl=False)


@click.group(cls=Group, invoke_without_command=True, subcommand_metavar="[show NAME]")
@JSON
@click.pass_context
def distros(ctx: click.Context, as_json: bool) -> None:
    """List the micro-ROS distro manifests (meta/distros/; `uros distros show NAME` lists one's
    repositories and the stand-ins it was built with here)."""
    from uros_build.commands import listings

    if ctx.invoked_subcommand is None:
        columns = (("name", "DISTRO"), ("status", "STATUS"), ("dev_repositories", "DEV REPOS"))
        more = (("mcu_repositories", "MCU REPOS"), ("stand_in_count", "STAND-INS"))
        table(listings.distros_table(), as_json, (*columns, *more))


@click.command("show")
@click.argument("name", shell_complete=complete_distros)
@JSON
def distros_show(name: str, as_json: bool) -> None:
    """Print the repositories of distro NAME and, for each declared stand-in, what stands in and why."""
    from uros_build.commands import listings

    columns = (("path", "REPOSITORY"), ("version", "VERSION"), ("stand_in", "STAND-IN (--stand-ins)"))
    table(listings.distro_repositories(name), as_json, (*columns, ("why", "WHY")))


@click.group(cls=Group)
def toolchain() -> None:
    """CMake toolchain files."""


@click.command("render")
@click.argument("target", shell_complete=complete_targets)
@output_option("Write here instead of standard output.")
@click.option(
    "--for", "purpose", type=click.Choice(["firmware", "micro-ros"]), default="firmware", show_default=True,
    help="firmware: no micro-ROS-only flags; micro-ros: with them (what `uros build` uses).",
)  # fmt: skip
@click.option("--gcc-major", type=int, help="The cross GCC's major version (decides GCC<6 workarounds).")
def toolchain_render(target: str, output: Path | None, purpose: str, gcc_major: int | None) -> None:
    """Render the CMake toolchain file of TARGET (a target name or a profile .yaml)."""
    from uros_build.commands import listings

    listings.render_toolchain_file(target, output, micro_ros=purpose == "micro-ros", gcc_major=gcc_major)


@click.group(cls=Group)
def meta() -> None:
    """colcon.meta files."""


@click.command("write")
@PRESET
@toolchain_option("Add what this target needs (transport, atomics).")
@TRANSPORT
@METAS
@SETS
@output_option("Write here instead of standard output.")
def meta_write(
    preset: str,
    toolchain: str | None,
    transport: str | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    output: Path | None,
) -> None:
    """Write a colcon.meta (JSON, sorted keys)."""
    from uros_build.commands import listings

    listings.write_meta(preset, toolchain, transport, metas, sets, output)


@click.command("options")
@JSON
def meta_options(as_json: bool) -> None:
    """The memory and entity options per package (RMW_UXRCE_MAX_*, history, MTU): upstream default,
    what uros's default preset builds with, and what a larger value costs; --set is checked
    against them."""
    from uros_build.commands import listings

    columns = (("package", "PACKAGE"), ("option", "OPTION"), ("default", "DEFAULT"), ("preset", "PRESET"))
    table(listings.options_table(), as_json, (*columns, ("cost", "COST")))


@click.group(cls=Group)
def export() -> None:
    """Packages for firmware build systems."""


def _export_command(fmt: ExportFormat) -> click.Command:
    """One `uros export KIND --output DIR [--from DIR]` command, from the format's record: every
    kind but arduino has this shape."""

    @click.command(fmt.kind, help=fmt.what)
    @output_option(fmt.output_help, required=True)
    @FROM
    def command(output: Path, source: Path | None) -> None:
        from uros_build.commands import export as export_cmd  # when it runs: start-up cost

        export_cmd.export_format(fmt.kind, source, output)

    return command


EXPORT_COMMANDS = tuple(_export_command(fmt) for fmt in exports.FORMATS)


@click.command("arduino")
@output_option("Folder of the Arduino library.", required=True)
@click.option(
    "--from", "sources", type=PATH_ARG, multiple=True, required=True,
    help="A `uros build` output (repeat: one per board, e.g. cortex-m4f and cortex-m7).",
)  # fmt: skip
def export_arduino(output: Path, sources: tuple[Path, ...]) -> None:
    """Write a precompiled Arduino library (library.properties, src/<mcu>/<fpu>-<abi>/libmicroros.a)."""
    from uros_build.commands import export as export_cmd

    export_cmd.export_arduino(sources, output)


@click.command("probe")
@click.argument("output", required=False, type=PATH_ARG)
@workspace_option("Firmware workspace (its output of --toolchain, or its only one).")
@toolchain_option("The target whose output to probe.")
@click.option("--agent", help="A MicroXRCEAgent program (default: $UROS_AGENT).")
@click.option(
    "--timeout", type=float,
    help="Seconds the firmware may take in QEMU.  [default: 60; 180 with --link]",
)  # fmt: skip
@click.option(
    "--app", "app", type=PATH_ARG,
    help="Run your application instead: a folder of C files with void appMain(void *arg).",
)  # fmt: skip
@click.option(
    "--define", "-D", "defines", multiple=True, metavar="NAME[=VALUE]",
    help="A macro for the app's C files, as the compiler's -D (repeatable; with --app).",
)  # fmt: skip
@click.option(
    "--duration", type=float,
    help="With --app: end the run this many seconds after appMain started (an app that never exits).",
)  # fmt: skip
@click.option("--json", "as_json", is_flag=True, help="The result as JSON on stdout.")
@click.option(
    "--peer", type=PATH_ARG,
    help="A host ROS 2 program (Python, rclpy) run beside the firmware over DDS; its exit status counts.",
)  # fmt: skip
@click.option(
    "--freertos", metavar="KERNEL",
    help="Run the probe firmware on FreeRTOS with this FreeRTOS-Kernel checkout (a library built "
    "with --rtos freertos runs on FreeRTOS without it).",
)  # fmt: skip
@click.option("--board", help="Another QEMU board of the target (meta/probe/machines.yaml), e.g. microbit.")
@click.option(
    "--link", metavar="FAULTS",
    help="A link that drops (serial or UDP): a seeded relay between QEMU and the agent, e.g. "
    "loss=10%,delay=50-150,seed=7 (also corrupt=, duplicate=, reorder=).",
)  # fmt: skip
@click.option(
    "--graph", is_flag=True,
    help="Add the graph stage: an rclpy peer sees the board's node and topics (micro_ros_agent; root).",
)  # fmt: skip
@click.option(
    "--instances", type=int, default=1, show_default=True, metavar="N",
    help="Boot N copies of the probe firmware against one agent (multiserial, or udp4); all must pass.",
)  # fmt: skip
@click.option(
    "--client-keys", "client_keys", metavar="own|same|drawn",
    help="With --instances: each board its own key (default), the same on all (must fail), "
    "or the library's own draw.",
)  # fmt: skip
@VERBOSE
def probe(app: Path | None, defines: tuple[str, ...], duration: float | None, **request: Any) -> None:
    """Run a built library: boot a probe firmware (or your --app) in QEMU against a real XRCE-DDS Agent."""
    from uros_build.commands import probe as probe_cmd

    # every other option is a field of ProbeRequest by its own name (tests/unit/test_cli_pure.py)
    if request["timeout"] is None:  # a lossy link is slow: 55 s at load 20 over 10 % loss, 100-300 ms
        request["timeout"] = 180.0 if request["link"] else 60.0
    probe_cmd.probe(probe_cmd.ProbeRequest(app=probe_cmd.app_request(app, defines, duration), **request))


@click.group(cls=Group)
def interface() -> None:
    """Custom interface packages (.msg, .srv)."""


@click.command("new")
@click.argument("name")
@click.option("--msg", "msgs", multiple=True, type=PATH_ARG, help="A .msg file (repeatable).")
@click.option("--srv", "srvs", multiple=True, type=PATH_ARG, help="A .srv file (repeatable).")
@output_option("Package folder (default: ./NAME).")
@click.option("--force", is_flag=True, help="Write into an existing folder.")
def interface_new(
    name: str, msgs: tuple[Path, ...], srvs: tuple[Path, ...], output: Path | None, force: bool
) -> None:
    """Scaffold an interface package NAME from .msg/.srv files (package.xml, CMakeLists.txt)."""
    from uros_build.commands import interface as interface_cmd

    interface_cmd.interface_new(name, list(msgs), list(srvs), output, force)
