"""`uros agent build` and `uros agent run serial | udp4 | multiserial`."""

from __future__ import annotations

import os
from pathlib import Path

import click

from uros_build.cli.common import (
    MIRRORS,
    VERBOSE,
    Group,
    complete_distros,
    mirror_override_option,
    workspace_option,
)


@click.group(cls=Group)
def agent() -> None:
    """The Micro XRCE-DDS Agent: built from pinned sources against PyPI's ROS 2 wheels, and run."""


@click.command("build")
@click.option(
    "--distro", default=None, shell_complete=complete_distros,
    help="Whose agent (meta/distros/<distro>/agent.repos); default: the workspace's, else humble.",
)  # fmt: skip
@workspace_option("A workspace whose uros.yaml mirror rules (and distro) the clones follow.")
@MIRRORS
@mirror_override_option("xrce_agent, micro_ros_agent, micro_ros_msgs, or owner/repo")
@click.option(
    "-j", "--jobs", type=int, default=os.cpu_count() or 1, show_default="the CPUs",
    help="Parallel compiles.",
)  # fmt: skip
@VERBOSE
def agent_build(
    distro: str | None,
    workspace: Path | None,
    mirrors: tuple[str, ...],
    overrides: tuple[str, ...],
    jobs: int,
    verbose: bool,
) -> None:
    """Build the agent (micro_ros_agent, else MicroXRCEAgent) once; `uros probe` then uses it."""
    from uros_build.commands import agent as agent_cmd

    agent_cmd.build(distro, workspace, mirrors, overrides, jobs, verbose)


@click.group("run", cls=Group)
def agent_run() -> None:
    """Run the built agent in the foreground (the command it runs is printed first)."""


AGENT = click.option("--agent", help="Run this agent program instead of the built one.")
LEVEL = click.option(
    "-v", "--verbose-level", "verbosity", type=int, default=None, help="The agent's log level, 0-6."
)
BAUD = click.option("-b", "--baudrate", "baud", type=int, default=115200, show_default=True)


@click.command("serial")
@click.option("--dev", "-D", "dev", default=None, help="The serial device, e.g. /dev/ttyACM0.")
@BAUD
@LEVEL
@AGENT
def agent_run_serial(dev: str | None, baud: int, verbosity: int | None, agent: str | None) -> None:
    """One board on a serial link."""
    from uros_build.commands import agent as agent_cmd

    devices = (dev,) if dev else ()
    agent_cmd.run(agent_cmd.Transport("serial", devices, baud), verbosity, agent)


@click.command("multiserial")
@click.option(
    "--devs", "-D", "devs", multiple=True,
    help="The serial devices: repeated, or several in one quoted value ('A B').",
)  # fmt: skip
@BAUD
@LEVEL
@AGENT
def agent_run_multiserial(devs: tuple[str, ...], baud: int, verbosity: int | None, agent: str | None) -> None:
    """Several boards, one serial link each, on one agent."""
    from uros_build.commands import agent as agent_cmd

    transport = agent_cmd.Transport("multiserial", agent_cmd.parse_devices(devs), baud)
    agent_cmd.run(transport, verbosity, agent)


@click.command("udp4")
@click.option("--port", "-p", type=int, required=True, help="The UDP port, e.g. 8888.")
@LEVEL
@AGENT
def agent_run_udp4(port: int, verbosity: int | None, agent: str | None) -> None:
    """Boards over UDP/IPv4."""
    from uros_build.commands import agent as agent_cmd

    agent_cmd.run(agent_cmd.Transport("udp4", port=port), verbosity, agent)


RUN_COMMANDS = (agent_run_serial, agent_run_multiserial, agent_run_udp4)
