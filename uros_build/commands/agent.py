"""`uros agent build` and `uros agent run`: the Micro XRCE-DDS Agent from pinned sources against
PyPI's ROS 2 wheels (run/agentbuild.py), and that agent run in the foreground on a serial link,
several serial links or a UDP port.

build: the distro (--distro, else the workspace's, else humble) → its pin (agent.repos) → the mirror
(the workspace's uros.yaml, then --mirror/--mirror-override) → the ROS 2 environment (made or as
before) → the clones → built beside the agent in use, or found built → made current.
run: the transport's arguments checked (a device that exists, a free port) → the equivalent command
printed → the agent in the foreground (Ctrl-C and SIGTERM reach it; its exit status is uros's).
"""

from __future__ import annotations

import errno
import os
import shlex
import socket
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, defaults
from uros_build.config.resolver import resolve_outside, resolve_workspace
from uros_build.config.settings import ROS2_VENV
from uros_build.errors import ConfigError, Interrupted, MissingToolError
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.run import agentbuild, builtagent
from uros_build.run.builtagent import BuiltAgent
from uros_build.sources import distros as distros_mod
from uros_build.sources.distros import Mirror
from uros_build.sources.wsfiles import load_config

NO_AGENT_HINT = "run `uros agent build` once (about 3-10 min), or pass --agent PATH / set UROS_AGENT"


def agent_root() -> Path:
    """Where the built agent lives: beside the ROS 2 environment it was built against."""
    return resolve_outside(ROS2_VENV).value.expanduser()


def built_agent() -> BuiltAgent | None:
    """The agent `uros agent build` made current, or None."""
    return builtagent.current_agent(agent_root())


def build(
    distro: str | None,
    workspace: Path | None,
    mirrors: Sequence[str],
    overrides: Sequence[str],
    jobs: int,
    verbose: bool,
) -> BuiltAgent:
    root = resolve_workspace(workspace)
    cfg = load_config(root) if root.is_dir() else None
    name = distro or (cfg.distro if cfg is not None and cfg.distro else defaults.DISTRO)
    pin = agentbuild.load_pin(name)
    flags = Mirror(
        tuple(distros_mod.parse_rule(s) for s in mirrors),
        tuple(distros_mod.parse_override(s) for s in overrides),
    )
    mirror = distros_mod.combine(cfg.mirror, flags) if cfg is not None else flags
    check_jobs(jobs)
    where = agent_root()
    runner = Runner(new_run_log(where / "log", "agent-build"), verbose=verbose)
    console.step(
        f"uros agent build: the agent of {name} ({pin.source}), under {where / builtagent.AGENT_DIR}"
    )
    console.info(f"log: {runner.log_path}")
    built, now = agentbuild.build_agent(runner, pin, mirror, where, jobs)
    if now:
        console.step(f"agent built in {built.seconds:.0f} s: {built.describe()}")
    else:
        console.step(f"agent up to date: {built.describe()}")
    console.info(f"{built.program}: {built.why}")
    console.info(f"run it: uros agent run serial --dev DEVICE (or {built.run})")
    return built


def check_jobs(jobs: int) -> None:
    if jobs < 1:
        raise ConfigError(f"--jobs {jobs}: must be 1 or more", "e.g. --jobs 2")


# ---------------------------------------------------------------------------------------------
# uros agent run


@dataclass(frozen=True)
class Transport:
    """What the agent listens on: ``kind`` serial, multiserial or udp4, with its values."""

    kind: str
    devices: tuple[str, ...] = ()  # serial: one; multiserial: several
    baud: int = 115200
    port: int = 0  # udp4


def run_argv(program: str, transport: Transport, verbosity: int | None) -> list[str]:
    """The agent's command line (pure): the transport, its values, and -v N when given. The
    arguments are those of eProsima's agent, which micro_ros_agent shares."""
    if transport.kind == "udp4":
        argv = [program, "udp4", "--port", str(transport.port)]
    elif transport.kind == "serial":
        argv = [program, "serial", "--dev", transport.devices[0], "-b", str(transport.baud)]
    else:
        argv = [program, "multiserial", "--devs", " ".join(transport.devices), "-b", str(transport.baud)]
    return [*argv, "-v", str(verbosity)] if verbosity is not None else argv


def parse_devices(devs: Sequence[str]) -> tuple[str, ...]:
    """--devs as given: repeated, or several in one quoted value (as the agent takes them) (pure)."""
    return tuple(d for value in devs for d in value.split())


def check_transport(transport: Transport, verbosity: int | None) -> None:
    """The values the agent would refuse later, or not say why: refused now, one line each."""
    if transport.kind in ("serial", "multiserial"):
        flag = "--dev" if transport.kind == "serial" else "--devs"
        if not transport.devices:
            raise ConfigError(
                f"uros agent run {transport.kind}: {flag} is required", f"e.g. {flag} /dev/ttyACM0"
            )
        if transport.baud <= 0:
            raise ConfigError(f"-b/--baudrate {transport.baud}: must be more than 0", "e.g. -b 115200")
        for device in transport.devices:
            if not os.path.exists(device):
                raise ConfigError(
                    f"{flag} {device}: no such device",
                    "plug the board in, or name its port (ls /dev/ttyACM* /dev/ttyUSB*; a QEMU board's pty "
                    "is in its console log)",
                )
    if transport.kind == "udp4" and not 0 < transport.port < 65536:
        raise ConfigError(f"--port {transport.port}: not a UDP port", "pass 1-65535, e.g. --port 8888")
    if verbosity is not None and not 0 <= verbosity <= 6:
        raise ConfigError(f"-v/--verbose-level {verbosity}: must be 0-6", "e.g. -v 6 (every message in hex)")


def port_in_use(port: int) -> bool:
    """Something on this host has UDP ``port`` bound (the agent would fail to bind it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        try:
            sock.bind(("0.0.0.0", port))
        except OSError as exc:
            if exc.errno in (errno.EADDRINUSE, errno.EACCES):
                return True
            raise
    return False


def run(transport: Transport, verbosity: int | None, agent: str | None) -> None:
    check_transport(transport, verbosity)
    if transport.kind == "udp4" and port_in_use(transport.port):
        raise ConfigError(
            f"--port {transport.port}: UDP port in use (another agent?)",
            "stop what holds it (ss -ulpn), or pass another --port and build the firmware for it",
        )
    program = _program(agent)
    argv = run_argv(program, transport, verbosity)
    runner = Runner(new_run_log(user_log_dir(), "agent-run"), verbose=True)
    console.step(f"uros agent run: {shlex.join(argv)}")
    console.info(f"Ctrl-C stops it; log: {runner.log_path}")
    try:
        runner.run(argv, step="the agent", quiet=True)
    except Interrupted as exc:  # how an agent in the foreground is stopped: no error
        console.info(f"the agent stopped ({exc.signal_name})")
        raise SystemExit(exc.exit_code) from None


def _program(agent: str | None) -> str:
    """--agent, else the agent `uros agent build` made current (not UROS_AGENT: the built one is
    what `agent run` is for; --agent runs another with the same checked arguments)."""
    if agent:
        if not (os.path.isfile(agent) and os.access(agent, os.X_OK)):
            raise MissingToolError(f"--agent {agent}: no such program", NO_AGENT_HINT)
        return agent
    built = built_agent()
    if built is None:
        raise MissingToolError("uros agent run: no agent built yet", NO_AGENT_HINT)
    return str(built.run)
