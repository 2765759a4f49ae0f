"""The ROS 2 side of examples/parameter-server: an rclpy node that does what `ros2 param` does to the
firmware's node "param_node": lists its parameters, gets each (one name a request: the server runs in
rclc's low-memory mode, which takes one), describes one, sets param_0 to 123 and reads it back. Exit 0
when all holds.

    uros probe -w firmware --toolchain cortex-m7 --app examples/parameter-server \
        -D APP_PEER_WAIT_MS=90000 --peer examples/parameter-server/peer.py

uros runs it with the Python of its ROS 2 environment (PyPI's ros-* wheels), in the run's own network
namespace, once the agent is up (docs/probe.md, "A ROS 2 peer").
"""

from __future__ import annotations

import sys
import time

import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters

PARAMS = 6  # the app's APP_PARAMS
DEADLINE = 20.0  # seconds for each call: DDS discovery of each service takes up to ~3 s here


def fail(text: str) -> None:
    print(f"peer: FAIL {text}", flush=True)
    sys.exit(1)


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("parameter_peer")
    # the services one by one, not rclpy's AsyncParameterClient: its wait_for_services waits for
    # set_parameters_atomically too, which rclc's server (humble) does not offer
    clients = {
        srv: node.create_client(srv, f"/param_node/{name}")
        for srv, name in (
            (ListParameters, "list_parameters"),
            (GetParameters, "get_parameters"),
            (DescribeParameters, "describe_parameters"),
            (SetParameters, "set_parameters"),
        )
    }
    started = time.monotonic()

    def call(srv, request, what: str):  # type: ignore[no-untyped-def]
        client = clients[srv]
        end = time.monotonic() + DEADLINE
        while not client.service_is_ready():
            if time.monotonic() > end:
                fail(f"{what}: the service never appeared")
            rclpy.spin_once(node, timeout_sec=0.1)
        future = client.call_async(request)
        while not future.done():
            if time.monotonic() > end:
                fail(f"{what}: no answer in {DEADLINE:g} s")
            rclpy.spin_once(node, timeout_sec=0.1)
        print(f"peer: {what} answered at {time.monotonic() - started:.1f} s", flush=True)
        return future.result()

    names = sorted(call(ListParameters, ListParameters.Request(), "list_parameters").result.names)
    print(f"peer: list_parameters: {names}", flush=True)
    if names != [f"param_{i}" for i in range(PARAMS)]:
        fail(f"list_parameters gave {names}, not param_0 .. param_{PARAMS - 1}")
    for i, name in enumerate(names):
        values = call(GetParameters, GetParameters.Request(names=[name]), f"get_parameters {name}").values
        if (
            len(values) != 1
            or values[0].type != ParameterType.PARAMETER_INTEGER
            or values[0].integer_value != 10 * i
        ):
            fail(f"get_parameters {name}: {values}, not the integer {10 * i}")
    print(f"peer: get_parameters: {PARAMS} values right, one name a request", flush=True)
    described = call(DescribeParameters, DescribeParameters.Request(names=["param_1"]), "describe_parameters")
    print(f"peer: describe_parameters param_1: {described.descriptors}", flush=True)
    if len(described.descriptors) != 1 or described.descriptors[0].type != ParameterType.PARAMETER_INTEGER:
        fail(f"describe_parameters param_1: {described.descriptors}")
    value = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=123)
    results = call(
        SetParameters, SetParameters.Request(parameters=[Parameter(name="param_0", value=value)]), "set"
    ).results
    if len(results) != 1 or not results[0].successful:
        fail(f"set_parameters param_0=123 refused: {results}")
    values = call(GetParameters, GetParameters.Request(names=["param_0"]), "get_parameters param_0").values
    if len(values) != 1 or values[0].integer_value != 123:
        fail(f"param_0 read back {values} after setting 123")
    print("peer: PASS listed, got, described, set param_0=123 and read it back", flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
