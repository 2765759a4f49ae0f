"""The ROS 2 side of seed 001 (the PC the STM32H743 talks to): an rclpy node that subscribes to the
firmware's eic_demo_interface/msg/CmdVel on "pub_topic", checks every field of what arrives, calls
its eic_demo_interface/srv/GetTime on "get_time" and checks the answers (the epoch, going forward).
Exit 0 when all holds.

    uros probe -w firmware --toolchain cortex-m7 --app examples/stm32h7-custom \
        -D APP_PEER_REQUESTS=2 --peer examples/stm32h7-custom/peer.py

uros runs it with the Python of its ROS 2 environment (PyPI's ros-* wheels) and the workspace's
eic_demo_interface built for the host, in the run's own network namespace, once the agent is up
(docs/probe.md, "A ROS 2 peer"). The field checks are what catch a wrong interface definition: the
type names match over DDS whatever the fields are, and a mismatched CmdVel decodes into nonsense.
"""

from __future__ import annotations

import sys
import time

import rclpy
from eic_demo_interface.msg import CmdVel
from eic_demo_interface.srv import GetTime

SAMPLES = 5  # CmdVel messages to check
REQUESTS = 2  # GetTime calls (the app's -D APP_PEER_REQUESTS waits for as many)
DEADLINE = 25.0  # seconds: DDS discovery takes up to ~3 s here
SAMPLE_WAIT = 8.0  # seconds for the CmdVel samples (discovery took 0.2-3 s here)
# The app answers with its clock set from the agent's (rmw_uros_sync_session): the host's epoch in
# ms. QEMU's clock lags the host's when the machine is busy (3 s in 3.5 s here at load 12), so the
# answer must be an epoch (not an uptime), not later than the host's clock, and going forward.
EPOCH_2020_MS = 1_577_836_800_000
AHEAD_SLACK_MS = 1000


def fail(text: str) -> None:
    print(f"peer: FAIL {text}", flush=True)
    sys.exit(1)


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("stm32h7_peer")
    samples: list[CmdVel] = []
    node.create_subscription(CmdVel, "pub_topic", samples.append, 10)
    client = node.create_client(GetTime, "get_time")
    end = time.monotonic() + DEADLINE
    # the samples first (the app publishes until it has served our requests, then exits), for at
    # most SAMPLE_WAIT: the requests are made whatever came, so that the app ends by itself
    sampling = time.monotonic() + SAMPLE_WAIT
    while len(samples) < SAMPLES and time.monotonic() < sampling:
        rclpy.spin_once(node, timeout_sec=0.1)
    while not client.service_is_ready():
        if time.monotonic() > end:
            fail("get_time never appeared")
        rclpy.spin_once(node, timeout_sec=0.1)
    answers: list[int] = []
    for _ in range(REQUESTS):
        asked = time.time_ns() // 1_000_000
        future = client.call_async(GetTime.Request(time_ms_req=asked))
        while not future.done():
            if time.monotonic() > end:
                fail(f"get_time asked at {asked} was not answered")
            rclpy.spin_once(node, timeout_sec=0.1)
        answered, now = future.result().time_ms_res, time.time_ns() // 1_000_000
        print(f"peer: get_time asked at {asked}, answered {answered} ({now - answered} ms behind)", flush=True)
        if answered < EPOCH_2020_MS or answered > now + AHEAD_SLACK_MS:
            fail(f"get_time answered {answered}: not the agent's epoch (the host's clock: {now})")
        if answers and answered <= answers[-1]:
            fail(f"get_time answered {answered} after {answers[-1]}: the app's clock went back")
        answers.append(answered)
    if len(samples) < SAMPLES:
        fail(f"{len(samples)} of {SAMPLES} CmdVel came in {SAMPLE_WAIT:g} s")
    samples = samples[:SAMPLES]
    left = [m.left_rpm for m in samples]
    wrong = [m for m in samples if m.right_rpm != -2 * m.left_rpm or m.left_rpm <= 0]
    if wrong or left != sorted(set(left)):
        fail(f"CmdVel fields wrong (right_rpm = -2 * left_rpm, left_rpm counting up): {samples[:SAMPLES]}")
    print(f"peer: PASS {len(samples)} CmdVel (left_rpm {left[0]}..{left[-1]}), {len(answers)} get_time answers", flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
