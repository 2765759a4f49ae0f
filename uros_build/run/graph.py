"""The probe's graph stage (`uros probe --graph`): is the board in the ROS graph? An rclpy peer of
uros's own (templates/probe-graph-peer.py) watches the graph from the run's network namespace, as
`ros2 node list` and `ros2 topic list -t` would, and prints what it saw as one JSON line; this
module judges that line against what the probe firmware creates (templates/probe/main.c: the node
``uros_probe`` in ``/``, a publisher and a subscription of std_msgs/msg/Int32 on ``/uros_probe``).

Only an agent with micro-ROS-Agent's graph manager (``micro_ros_agent``) puts a micro-ROS node into
the graph: eProsima's plain ``MicroXRCEAgent`` creates the DDS entities but announces no ROS node
(micro_ros_setup#352), so with it the stage fails and says so by name.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from uros_build import resources
from uros_build.run.stages import Stage

NAME = "graph"
SCRIPT = "probe-graph-peer.py"  # in templates/
NODE, NAMESPACE = "uros_probe", "/"
TOPIC, TYPE = "/uros_probe", "std_msgs/msg/Int32"
GRAPH_AGENT = "micro_ros_agent"
FIX = "`uros agent build` builds micro_ros_agent, which has one (then probe without --agent)"


def script() -> Path:
    return resources.templates_dir() / SCRIPT


def observation(peer_output: str) -> dict[str, Any] | None:
    """The peer's last ``{"graph": "seen", ...}`` line (pure); None: it saw no node."""
    found = None
    for line in peer_output.splitlines():
        try:
            data = json.loads(line)
        except ValueError:
            continue
        if isinstance(data, dict) and data.get("graph") == "seen":
            found = data
    return found


def _endpoints(seen: dict[str, Any]) -> list[dict[str, Any]]:
    ends = seen.get("endpoints")
    return [e for e in ends if isinstance(e, dict)] if isinstance(ends, list) else []


def stage(peer_output: str, agent_program: str) -> Stage:
    """The graph stage from the peer's output and the agent's program name (pure)."""
    seen = observation(peer_output)
    plain = agent_program != GRAPH_AGENT
    why_plain = f"the agent is {agent_program}, which has no graph manager: {FIX}"
    if seen is None:
        why = why_plain if plain else "the peer saw no node in the ROS graph while the firmware ran"
        return Stage(NAME, "fail", f"node /{NODE} not in the ROS graph: {why}")
    listed = seen.get("nodes")
    nodes = listed if isinstance(listed, list) else []
    ours = any(
        isinstance(n, dict) and n.get("name") == NODE and n.get("namespace") == NAMESPACE for n in nodes
    )
    if not ours:
        names = sorted(f"{n.get('namespace')}/{n.get('name')}" for n in nodes if isinstance(n, dict))
        return Stage(NAME, "fail", f"node /{NODE} not in the ROS graph (it has {', '.join(names) or 'none'})")
    mine = [e for e in _endpoints(seen) if e.get("topic") == TOPIC and e.get("node") == NODE]
    kinds = {str(e.get("kind")) for e in mine if e.get("type") == TYPE}
    if kinds != {"publisher", "subscription"}:
        listed = sorted(f"{e.get('kind')} {e.get('type')}" for e in mine)
        return Stage(
            NAME,
            "fail",
            f"node /{NODE} seen, but {TOPIC} [{TYPE}] lacks its publisher or subscription: {listed}",
        )
    qos = sorted({f"{e.get('reliability')} {e.get('durability')} depth {e.get('depth')}" for e in mine})
    after = seen.get("after")
    when = f" after {after:.2f} s" if isinstance(after, int | float) else ""
    return Stage(
        NAME,
        "pass",
        f"node /{NODE}, topic {TOPIC} [{TYPE}] publisher and subscription ({'; '.join(qos)}), seen{when}",
    )
