"""The probe's graph stage, on the host (`uros probe --graph`; uros_build/run/graph.py reads its output).

An rclpy node in the run's network namespace watches the ROS graph, as `ros2 node list` and
`ros2 topic list -t` would, until a node other than itself appears and a second more, then prints
what it saw in that time as one JSON line: the nodes (name, namespace), the topics with their types,
and each topic's publishers and subscriptions with their node and QoS. uros judges that line; this
script judges nothing.
"""

import json
import os
import sys
import time

# Fast DDS over UDP only: its shared-memory transport across the run's network namespace left the
# agent's participant undiscovered in most short runs (docs/probe.md, "The board in the ROS graph")
os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS", "UDPv4")

import rclpy  # noqa: E402  (after the transport is chosen)

SELF = "uros_graph_peer"
SETTLE = 1.0  # seconds to keep looking after the first node: its topics' endpoints follow it
GIVE_UP = 30.0  # seconds without any node: the firmware's life is over by then


def snapshot(node, nodes, topics, endpoints):
    """What the graph shows now, added to what it showed before (a node the firmware tears down,
    or the agent's restart, may leave it between two looks)."""
    for name, namespace in node.get_node_names_and_namespaces():
        if name != SELF:
            nodes.add((name, namespace))
    for topic, types in node.get_topic_names_and_types():
        topics.setdefault(topic, set()).update(types)
        infos = [("publisher", i) for i in node.get_publishers_info_by_topic(topic)]
        infos += [("subscription", i) for i in node.get_subscriptions_info_by_topic(topic)]
        for kind, info in infos:
            qos = info.qos_profile
            endpoints.add((
                topic, kind, info.node_name, info.node_namespace, info.topic_type,
                qos.reliability.name.lower(), qos.durability.name.lower(), qos.history.name.lower(), qos.depth,
            ))  # fmt: skip


def main() -> int:
    rclpy.init()
    node = rclpy.create_node(SELF)
    started = time.monotonic()
    first = None
    nodes, topics, endpoints = set(), {}, set()
    while first is None or time.monotonic() - first < SETTLE:
        if first is None and time.monotonic() - started > GIVE_UP:
            print(json.dumps({"graph": "none", "after": GIVE_UP}), flush=True)
            return 1
        rclpy.spin_once(node, timeout_sec=0.05)
        snapshot(node, nodes, topics, endpoints)
        if nodes and first is None:
            first = time.monotonic()
    keys = ("topic", "kind", "node", "namespace", "type", "reliability", "durability", "history", "depth")
    seen = {
        "graph": "seen",
        "after": round(first - started, 3),
        "nodes": [{"name": n, "namespace": ns} for n, ns in sorted(nodes)],
        "topics": [{"name": t, "types": sorted(types)} for t, types in sorted(topics.items())],
        "endpoints": [dict(zip(keys, e)) for e in sorted(endpoints, key=str)],
    }
    print(json.dumps(seen, sort_keys=True), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
