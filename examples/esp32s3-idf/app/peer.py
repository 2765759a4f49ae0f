"""The ROS 2 side of seed 000 (the PC's converter node, without MQTT): an rclpy node that sends the
LED node demo_interfaces/msg/Hsb commands on "command/led/hsb" and sees its state on
"state/led/hsb" follow each one. Exit 0 when it did.

    uros probe -w firmware --toolchain cortex-m7 --app examples/esp32s3-idf/app \
        -D HSB_EXIT_AFTER=2 -D HSB_STATE_PERIOD_MS=200 --peer examples/esp32s3-idf/app/peer.py

uros runs it with the Python of its ROS 2 environment (PyPI's ros-* wheels) and the workspace's
demo_interfaces built for the host, in the run's own network namespace, once the agent is up
(docs/probe.md, "A ROS 2 peer").
"""

from __future__ import annotations

import sys
import time

import rclpy
from demo_interfaces.msg import Hsb

# two colours unlike the node's start (30, 100, 50), one after the other
COMMANDS = ((200, 80, 40), (10, 100, 100))
DEADLINE = 25.0  # seconds: DDS discovery takes up to ~3 s here
RESEND = 2.0  # a command not followed in this time is sent again


def fail(text: str) -> None:
    print(f"peer: FAIL {text}", flush=True)
    sys.exit(1)


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("hsb_converter")
    states: list[tuple[int, int, int]] = []

    def on_state(m: Hsb) -> None:
        states.append((m.hue, m.saturation, m.brightness))

    node.create_subscription(Hsb, "state/led/hsb", on_state, 10)
    command = node.create_publisher(Hsb, "command/led/hsb", 10)
    end = time.monotonic() + DEADLINE
    while not states or command.get_subscription_count() == 0:  # the node is there and hears us
        if time.monotonic() > end:
            fail(f"no state on state/led/hsb, or no subscriber on command/led/hsb (states: {states})")
        rclpy.spin_once(node, timeout_sec=0.1)
    print(f"peer: the LED is {states[-1]}", flush=True)
    for hue, saturation, brightness in COMMANDS:
        sent = 0.0
        while (hue, saturation, brightness) not in states:
            if time.monotonic() > end:
                fail(f"the state did not follow the command {(hue, saturation, brightness)}: {states[-5:]}")
            if time.monotonic() - sent > RESEND:
                command.publish(Hsb(hue=hue, saturation=saturation, brightness=brightness))
                sent = time.monotonic()
            rclpy.spin_once(node, timeout_sec=0.05)
        print(f"peer: commanded {(hue, saturation, brightness)}, the state followed", flush=True)
        states.clear()
    print("peer: PASS every command was followed by the state", flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
