"""--peer (or --graph's own peer): the peer's ROS 2 environment (run/peerenv.py), with the
workspace's interface packages."""

from __future__ import annotations

from uros_build.config.resolver import resolve_outside
from uros_build.config.settings import ROS2_VENV
from uros_build.probesteps.context import ProbeContext
from uros_build.run import peerenv
from uros_build.run.session import PeerRun
from uros_build.sources.packages import discover
from uros_build.sources.workspace import workspace_of_output


def prepare_peer(ctx: ProbeContext) -> PeerRun | None:
    """The peer the run starts beside the firmware, or None: no --peer, no --graph."""
    script = ctx.plan.peer
    if script is None:
        return None
    out, info = ctx.plan.out, ctx.plan.info
    ws = workspace_of_output(out, info.target)
    source = ws.source_dir if ws is not None else None
    own = None
    if ws is not None and ws.extra_dir.is_dir():
        own = tuple(p.name for p in discover(ws.extra_dir))
    root = resolve_outside(ROS2_VENV).value
    interfaces = peerenv.PeerInterfaces(tuple(info.packages), source, own)
    return peerenv.prepare(ctx.runner, script.resolve(), root, interfaces, ctx.work / "peer.log")
