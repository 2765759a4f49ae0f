"""Does the firmware's code fit the library (issue 41, item 1), through the real CLI on a real
cross-compiled fixture library: `uros build --for-firmware DIR` sums up the entities the
firmware's rclc calls create against the library's RMW_UXRCE_MAX_* pools, `uros check LIB
--for-firmware DIR` says each pool's count, the `--set` that fits and its RAM (the pools' sizes
read from the library's symbols) and fails with exit 5; an executor initialised for fewer handles
than it is given is a warning naming file:line; built again with the `--set` it names, it fits."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from fixture_ws import add_message_package, add_plain_package
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]  # it builds its own fixture library

# rmw_microxrcedds' pools in their shape (rmw_microxrcedds_c/src/types.c: an array of
# RMW_UXRCE_MAX_<KIND> slots each), with the fixture's slot sizes, and the configured header its
# include tree carries (config.h.in upstream). The fixture's values, not upstream's code.
POOLS = """\
typedef struct { unsigned char data[200]; } fx_service_t;
typedef struct { unsigned char data[216]; } fx_publisher_t;
typedef struct { unsigned char data[96]; } fx_node_t;
fx_service_t custom_services[RMW_UXRCE_MAX_SERVICES];
fx_publisher_t custom_publishers[RMW_UXRCE_MAX_PUBLISHERS];
fx_node_t custom_nodes[RMW_UXRCE_MAX_NODES];
int fx_rmw_pools(void) { return custom_services[0].data[0] + custom_publishers[0].data[0] + custom_nodes[0].data[0]; }
"""
CMAKE = """
foreach(kind NODES PUBLISHERS SERVICES)
  set(RMW_UXRCE_MAX_${kind} "1" CACHE STRING "slots")
  target_compile_definitions(rmw_microxrcedds PRIVATE RMW_UXRCE_MAX_${kind}=${RMW_UXRCE_MAX_${kind}})
  string(APPEND FX_CONFIG "#define RMW_UXRCE_MAX_${kind} ${RMW_UXRCE_MAX_${kind}}\\n")
endforeach()
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/config.h "${FX_CONFIG}")
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/config.h DESTINATION include/rmw_microxrcedds_c)
"""
# a node with a publisher, a timer and a parameter server, an executor for 2 handles given 6
FIRMWARE = """\
#include <fx_msgs/msg/small.h>
#define HANDLES 2

void app(void)
{
  rclc_node_init_default(&node, "fit", "", &support);
  rclc_publisher_init_default(&pub, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(fx_msgs, msg, Small), "out");
  rclc_timer_init_default(&timer, &support, RCL_MS_TO_NS(100), on_timer);
  rclc_parameter_server_init_default(&params, &node);
  rclc_executor_init(&executor, &support.context, HANDLES, &allocator);
  rclc_executor_add_timer(&executor, &timer);
  rclc_executor_add_parameter_server(&executor, &params, on_parameter);
}
"""


@pytest.fixture(scope="module")
def fit_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    need("arm-none-eabi-gcc", "cmake")
    ws = tmp_path_factory.mktemp("fit")
    add_message_package(ws)
    folder = add_plain_package(ws / "mcu_ws" / "src" / "rmw_microxrcedds", "rmw_microxrcedds", POOLS)
    with (folder / "CMakeLists.txt").open("a", encoding="utf-8") as cmake:
        cmake.write(CMAKE)
    (ws / "none.meta").write_text('{"names": {}}\n', encoding="utf-8")
    (ws / "app").mkdir()
    (ws / "app" / "main.c").write_text(FIRMWARE, encoding="utf-8")
    return ws


def _build(ws: Path, *more: str) -> subprocess.CompletedProcess[str]:
    return run_uros(
        "build", "--toolchain", "cortex-m7", "--workspace", str(ws), "--meta", str(ws / "none.meta"),
        "--for-firmware", str(ws / "app"), *more,
    )  # fmt: skip


def _check(ws: Path, *more: str) -> subprocess.CompletedProcess[str]:
    lib = str(ws / "build" / "cortex-m7" / "libmicroros.a")
    return run_uros(
        "check", lib, "--toolchain", "cortex-m7", "--for-firmware", str(ws / "app"), *more, check=False
    )


def test_the_firmware_s_calls_against_the_library_s_pools_and_the_set_that_fits(fit_ws: Path) -> None:
    built = _build(fit_ws)
    warnings = [line for line in built.stderr.splitlines() if line.startswith("warning:")]
    # the build's summary: what does not fit, a line each, and the executor that is too small
    assert any(
        w.startswith("warning: publishers: 2 (1 for a publisher at main.c:7, 1 for a parameter")
        for w in warnings
    )
    assert any(
        w.startswith("warning: services: 5 (5 for a parameter server at main.c:9); the library has "
                     "RMW_UXRCE_MAX_SERVICES=1: 4 too few; --set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5 fits")
        for w in warnings
    )  # fmt: skip
    assert any("main.c:10: executor is initialised for 2 handles and given 6" in w for w in warnings)
    assert "a static count of the rclc calls" in built.stderr and "uros probe --app" in built.stderr

    checked = _check(fit_ws)
    assert checked.returncode == 5, checked.stderr
    lines = checked.stderr.splitlines()
    # each pool priced by the library's own symbols: 200 B a service slot, 216 B a publisher slot
    assert any(
        line.startswith("warning: services: 5")
        and line.endswith("--set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5 fits "
                          "(+800 B of RAM: 200 B a slot, measured in this library)")
        for line in lines
    ), checked.stderr  # fmt: skip
    assert any(line.endswith("(+216 B of RAM: 216 B a slot, measured in this library)") for line in lines)
    assert "nodes: 1 (1 for a node at main.c:6); the library has RMW_UXRCE_MAX_NODES=1" in lines
    assert any(
        line.startswith("warning: main.c:10: executor is initialised for 2 handles and given 6: "
                        "rclc_executor_add_parameter_server at main.c:12 returns RCL_RET_ERROR")
        for line in lines
    )  # fmt: skip
    error = [line for line in lines if line.startswith("error:")]
    assert error == [
        f"error: --for-firmware {fit_ws / 'app'}: creates more than libmicroros.a has room for: "
        "2 publishers (RMW_UXRCE_MAX_PUBLISHERS=1), 5 services (RMW_UXRCE_MAX_SERVICES=1)"
    ]
    assert (
        "--set rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=2 --set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5"
        in (checked.stderr)
    )

    as_json = _check(fit_ws, "--json")
    assert as_json.returncode == 5
    entities = json.loads(as_json.stdout)["entities"]
    assert entities["fits"] is False and "uros probe --app" in entities["approximate"]
    assert entities["limits"]["services"] == {
        "needed": 5, "option": "RMW_UXRCE_MAX_SERVICES", "value": 1, "value_from": "header", "fits": False,
        "set": "rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5", "extra_ram": 800, "slot_ram": 200,
        "uses": [{"what": "parameter server", "slots": 5, "where": ["main.c:9"]}],
    }  # fmt: skip
    assert [(e["init"], e["handles"], e["given"], e["short"]) for e in entities["executors"]] == [
        ("main.c:10", 2, 6, True)
    ]

    # built with the --set it names, the library has the room: exit 0, the executor still warned of
    _build(
        fit_ws,
        "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=2",
        "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=5",
    )  # fmt: skip
    fits = _check(fit_ws)
    assert fits.returncode == 0, fits.stderr
    assert "services: 5 (5 for a parameter server at main.c:9); the library has RMW_UXRCE_MAX_SERVICES=5" in (
        fits.stderr.splitlines()
    )
    assert "warning: main.c:10: executor is initialised for 2 handles and given 6" in fits.stderr
