"""The programs a run starts: the board's QEMU and a Micro XRCE-DDS Agent (--agent, $UROS_AGENT, or
the one `uros agent build` made)."""

from __future__ import annotations

import os
from pathlib import Path

from uros_build import console
from uros_build.config.resolver import resolve_outside
from uros_build.config.settings import AGENT, ROS2_VENV
from uros_build.errors import MissingToolError
from uros_build.probesteps.context import ProbeContext, Tools
from uros_build.run import builtagent
from uros_build.run.machines import Board, qemu_hint

_AGENT_HINT = (
    "run `uros agent build` once, or pass --agent PATH (or set UROS_AGENT) to a MicroXRCEAgent: eProsima "
    "Micro-XRCE-DDS-Agent v2.3.0 "
    "builds against Debian 12's libfastcdr-dev and libspdlog-dev with -DUAGENT_SUPERBUILD=OFF "
    "-DUAGENT_USE_SYSTEM_FASTCDR=ON -DUAGENT_USE_SYSTEM_LOGGER=ON -DUAGENT_P2P_PROFILE=OFF "
    "-DCMAKE_CXX_FLAGS=-DFMT_DEPRECATED_OSTREAM=1 (docs/probe.md)"
)


def find_tools(ctx: ProbeContext) -> Tools:
    """QEMU for the board (the program its qemu_env names, for a core no packaged QEMU has), then
    the agent."""
    board = ctx.plan.machine.board
    return Tools(_qemu(ctx, board), _agent(ctx))


def _qemu(ctx: ProbeContext, board: Board) -> str:
    if not board.qemu_env:
        return ctx.runner.which(board.qemu, qemu_hint(board.qemu))
    named = os.environ.get(board.qemu_env, "")
    if not named:
        raise MissingToolError(
            f"uros probe: board {board.name} needs a {board.qemu} with the {board.cpu} CPU, and "
            f"{board.qemu_env} is not set",
            qemu_hint(board.qemu, board),
        )
    if not (Path(named).is_file() and os.access(named, os.X_OK)):
        raise MissingToolError(f"{board.qemu_env}={named}: no such program", qemu_hint(board.qemu, board))
    console.info(f"qemu: {named} ({board.qemu_env})")
    return str(Path(named).absolute())


def _agent(ctx: ProbeContext) -> str:
    wanted = resolve_outside(AGENT, ctx.request.agent or None).value  # --agent, else $UROS_AGENT
    if not wanted:  # else the agent `uros agent build` made
        built = builtagent.current_agent(agent_root())
        if built is None:
            raise MissingToolError("uros probe: no Micro XRCE-DDS Agent was given or built", _AGENT_HINT)
        console.info(f"agent: {built.describe()} (uros agent build)")
        return str(built.run)
    if os.sep in wanted and not (Path(wanted).is_file() and os.access(wanted, os.X_OK)):
        raise MissingToolError(f"--agent {wanted}: no such program", _AGENT_HINT)
    return ctx.runner.which(wanted, _AGENT_HINT)


def agent_root() -> Path:
    """Where `uros agent build` keeps its agents (the ROS 2 environment's cache)."""
    return resolve_outside(ROS2_VENV).value.expanduser()
