"""The firmware's rclc calls against the library's pools and its executors' handles (pure)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uros_build.output import executors, fit
from uros_build.output.buildinfo import parse_build_info
from uros_build.sources.firmware_scan import Call, FirmwareUse, scan_calls, scan_defines, scan_folder
from uros_build.sources.options import by_package, known_options

RMW = by_package(known_options())["rmw_microxrcedds"]

FIRMWARE = """\
#define EXTRA 2
void app(void) {
  rclc_node_init_default(&node, "n", "", &support);
  rclc_publisher_init_default(&pub, &node, ts, "a");
  rclc_timer_init_default(&timer, &support, RCL_MS_TO_NS(100), cb);
  rclc_parameter_server_init_default(&param_server, &node);
  rclc_action_server_init_default(&action, &node, &support, ts, "fib");
  rclc_executor_init(&executor, &support.context, RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES + EXTRA, &a);
  rclc_executor_add_timer(&executor, &timer);
  rclc_executor_add_parameter_server(&executor, &param_server, on_changed);
  rclc_executor_add_action_server(&executor, &action, 2, &goal, sizeof(goal), g, c, NULL);
}
"""


def _use(text: str = FIRMWARE) -> FirmwareUse:
    return FirmwareUse(calls=scan_calls(text, "main.c"), defines=scan_defines(text))


def test_each_call_takes_what_rclc_and_rcl_action_create() -> None:
    counted = {kind: [(what, n) for what, n, _ in uses] for kind, uses in fit.count(_use().calls).items()}
    assert counted == {
        "nodes": [("node", 1)],
        "publishers": [("publisher", 1), ("parameter server", 1), ("action server", 2)],
        "services": [("parameter server", 5), ("action server", 3)],
        "guard conditions": [("timer", 1), ("action server", 1)],
        "wait sets": [("executor", 1)],
    }
    client = fit.count(scan_calls('rclc_action_client_init_default(&c, &node, ts, "fib");', "c.c"))
    assert {k: sum(n for _, n, _ in v) for k, v in client.items()} == {"subscriptions": 2, "clients": 3}


def test_limits_against_the_library_s_values_with_the_set_that_fits_and_its_ram() -> None:
    headers = {"rmw_microxrcedds_c/config.h": {"RMW_UXRCE_MAX_SERVICES": "1", "RMW_UXRCE_MAX_NODES": "1"}}
    meta = {"RMW_UXRCE_MAX_PUBLISHERS": "2"}
    found = {
        limit.kind: limit for limit in fit.limits(_use(), RMW, headers, meta, {"RMW_UXRCE_MAX_SERVICES": 200})
    }
    services = found["services"]
    assert (services.needed, services.value, services.value_from, services.fits) == (8, 1, "header", False)
    assert services.extra_bytes == 7 * 200
    assert fit.limit_line(services) == (
        "services: 8 (5 for a parameter server at main.c:6, 3 for an action server at main.c:7); the "
        "library has RMW_UXRCE_MAX_SERVICES=1: 7 too few; --set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=8 "
        "fits (+1,400 B of RAM: 200 B a slot, measured in this library)"
    )
    publishers = found["publishers"]  # build-info's meta, no pool measured
    assert (publishers.needed, publishers.value, publishers.value_from) == (4, 2, "meta")
    assert "RMW_UXRCE_MAX_PUBLISHERS=2 (its build-info): 2 too few" in fit.limit_line(publishers)
    assert fit.limit_line(publishers).endswith(
        "(RAM per slot not measured: its pool is not among the library's symbols)"
    )
    assert fit.limit_line(publishers, priced=False).endswith(
        "(its RAM: uros check LIBRARY --for-firmware DIR)"
    )
    nodes = found["nodes"]
    assert nodes.fits and fit.limit_line(nodes) == (
        "nodes: 1 (1 for a node at main.c:3); the library has RMW_UXRCE_MAX_NODES=1"
    )
    guards = found["guard conditions"]  # upstream's default: 4
    assert (guards.needed, guards.value, guards.value_from, guards.fits) == (2, 4, "default", True)
    assert "upstream default" in fit.limit_line(guards)


def test_a_value_that_is_no_number_is_not_judged() -> None:
    headers = {"rmw_microxrcedds_c/config.h": {"RMW_UXRCE_MAX_NODES": "N"}}
    (nodes,) = [x for x in fit.limits(_use(), RMW, headers, {}, {}) if x.kind == "nodes"]
    assert nodes.value is None and nodes.fits


@pytest.mark.parametrize(
    ("expr", "value"),
    [
        ("3", 3),
        ("3U", 3),
        ("0x10", 16),
        ("010", 8),
        ("RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES + EXTRA", 7),
        ("(EXTRA + 1) * 2 - -1", 7),
        ("NESTED", 14),
        ("n_handles", None),  # a variable: not a number uros can read
        ("sizeof(x)", None),
        ("3 +", None),
        ("(3", None),
        ("LOOP", None),  # a define that names itself
    ],
)
def test_an_executor_s_size_as_c_evaluates_it(expr: str, value: int | None) -> None:
    defines = {"RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES": "5", "EXTRA": "2", "NESTED": "(EXTRA + 5) * 2"}
    assert executors.evaluate(expr, {**defines, "LOOP": "LOOP + 1"}) == value


def test_an_executor_given_more_handles_than_it_was_initialised_for_names_the_call_that_fails() -> None:
    (executor,) = executors.executors(_use(), parameter_handles=5)
    assert (executor.name, executor.handles, executor.given, executor.short) == ("executor", 7, 7, False)
    assert executors.executor_line(executor) == (
        False,
        "main.c:8: executor is initialised for 7 handles and given 7",
    )
    short = _use(FIRMWARE.replace("#define EXTRA 2", "#define EXTRA 0"))
    (executor,) = executors.executors(short, parameter_handles=5)
    warn, line = executors.executor_line(executor)
    assert warn and line == (
        "main.c:8: executor is initialised for 5 handles and given 7: rclc_executor_add_parameter_server at "
        "main.c:10 returns RCL_RET_ERROR (\"Buffer overflow of 'executor->handles'\"); initialise it for 7"
    )


def test_executors_that_are_not_initialised_or_not_readable_are_said_not_judged() -> None:
    calls = (
        Call("rclc_executor_add_timer", "a.c", 3, ("&other", "&t")),
        Call("rclc_executor_init", "a.c", 1, ("&ex", "&c", "count", "&a")),
        Call("rclc_executor_add_timer", "a.c", 2, ("&ex", "&t")),
    )
    found = {e.name: e for e in executors.executors(FirmwareUse(calls=calls), 5)}
    assert executors.executor_line(found["other"]) == (
        False,
        "other: 1 rclc_executor_add_* calls (1 handles, first at a.c:3); its rclc_executor_init is not in "
        "the sources read",
    )
    assert executors.executor_line(found["ex"]) == (
        False,
        "a.c:1: ex is initialised for count handles (not a number uros can read) and given 1",
    )


def _output(tmp_path: Path, config: str, packages: list[str]) -> Path:
    include = tmp_path / "include" / "rmw_microxrcedds_c"
    include.mkdir(parents=True)
    (include / "config.h").write_text(config, encoding="utf-8")
    params = tmp_path / "include" / "rclc_parameter" / "rclc_parameter.h"
    params.parent.mkdir(parents=True)
    params.write_text("#define RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES 6\n", encoding="utf-8")
    return tmp_path


def test_the_library_s_own_headers_and_pools_decide(tmp_path: Path) -> None:
    out = _output(tmp_path, "#define RMW_UXRCE_MAX_SERVICES 5\n#define RMW_UXRCE_MAX_PUBLISHERS 1\n", [])
    info = parse_build_info(
        {
            "generated_by": "uros",
            "target": "cortex-m7",
            "packages": ["rmw_microxrcedds", "rcl_interfaces", "rclc"],
            "library": {"file": "libmicroros.a", "sha256": "0" * 64, "members": 1, "inputs": []},
            "include": {"dir": "include", "files": 2, "bytes": 1, "packages": 2},
            "cmake_options": {"rmw_microxrcedds": {"RMW_UXRCE_MAX_SERVICES": "1"}},
        },
        "build-info.json",
    )
    use = _use(FIRMWARE.replace("rclc_action_server_init_default", "other"))
    found = fit.library_fit(
        out, info, use, known_options(), {"custom_services": 1000, "custom_publishers": 400}
    )
    by_kind = {limit.kind: limit for limit in found.limits}
    # the header's 5 over build-info's 1, against the library's 6 handles (services) a parameter server;
    # the publisher pool is 1 slot of 400 B
    assert (by_kind["services"].value, by_kind["services"].needed) == (5, 6)
    assert (by_kind["publishers"].value, by_kind["publishers"].each, by_kind["publishers"].extra_bytes) == (
        1,
        400,
        400,
    )
    assert found.has_rmw and not found.fits
    assert found.missing_packages == (("rclc_parameter", "the parameter server"),)
    (executor,) = found.executors  # the library's 6 handles a parameter server: 6 + 2 = 8 given 8
    assert (executor.handles, executor.given) == (8, 8)
    data = fit.report(found)
    assert (
        json.loads(json.dumps(data))["limits"]["publishers"]["set"]
        == "rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=2"
    )
    lines = fit.summary(found)
    assert [warn for warn, _ in lines] == [True, True, True, False]  # services, publishers, rclc_parameter
    assert lines[-1][1].startswith("a static count of the rclc calls")


def test_the_summary_of_a_firmware_that_fits_is_one_line() -> None:
    found = fit.Fit(
        tuple(fit.limits(_use('rclc_node_init_default(&n, "n", "", &s);'), RMW, {}, {}, {})), (), True
    )
    ((warn, line),) = fit.summary(found)
    assert not warn and line.startswith(
        "the firmware's entities fit the library: nodes 1 of 4 (a static count"
    )


def test_the_parameter_server_example_is_counted_as_it_runs() -> None:
    """examples/parameter-server: what `uros probe --app` ran (5 services, the events publisher, the
    self-check's client, two executors that fit) is what the static count says."""
    use = scan_folder(Path(__file__).resolve().parents[2] / "examples" / "parameter-server")
    counted = {kind: sum(n for _, n, _ in uses) for kind, uses in fit.count(use.calls).items()}
    assert counted == {"nodes": 1, "publishers": 1, "services": 5, "clients": 1, "wait sets": 2}
    found = {e.name: (e.handles, e.given) for e in executors.executors(use, parameter_handles=5)}
    assert found == {"executor": (5, 5), "checker": (1, 1)}


def test_a_publisher_costs_its_topic_slot_too_when_topics_follow_publishers_and_subscriptions(
    tmp_path: Path,
) -> None:
    config = "#define RMW_UXRCE_MAX_PUBLISHERS 1\n#define RMW_UXRCE_MAX_SUBSCRIPTIONS 1\n#define RMW_UXRCE_MAX_TOPICS -1\n"
    out = _output(tmp_path, config, [])
    info = parse_build_info(
        {
            "generated_by": "uros",
            "target": "cortex-m7",
            "packages": ["rmw_microxrcedds"],
            "library": {"file": "libmicroros.a", "sha256": "0" * 64},
            "include": {"dir": "include"},
        },
        "build-info.json",
    )
    use = _use(
        'rclc_publisher_init_default(&a, &n, ts, "a");\nrclc_publisher_init_default(&b, &n, ts, "b");\n'
    )
    pools = {
        "custom_publishers": 216,
        "custom_subscriptions": 216,
        "custom_topics": 56,
    }  # the lab's humble library
    (publishers,) = fit.library_fit(out, info, use, known_options(), pools).limits
    assert (publishers.each, publishers.extra_bytes) == (216 + 28, 244)
    # a topics pool sized on its own is not the publishers' to pay
    (tmp_path / "include" / "rmw_microxrcedds_c" / "config.h").write_text(config.replace("-1", "2"))
    (publishers,) = fit.library_fit(out, info, use, known_options(), pools).limits
    assert publishers.each == 216


def test_a_parameter_server_takes_a_service_for_each_of_the_library_s_handles(tmp_path: Path) -> None:
    """rclc_parameter.h: 5 handles in humble, 6 from iron on, each a service (read from the library)."""
    out = _output(tmp_path, "#define RMW_UXRCE_MAX_SERVICES 5\n", [])
    info = parse_build_info(
        {
            "generated_by": "uros",
            "target": "cortex-m7",
            "packages": ["rmw_microxrcedds", "rclc_parameter", "rcl_interfaces"],
            "library": {"file": "libmicroros.a", "sha256": "0" * 64},
            "include": {"dir": "include"},
        },
        "build-info.json",
    )
    use = _use("rclc_parameter_server_init_default(&ps, &node);\n")
    services = {x.kind: x for x in fit.library_fit(out, info, use, known_options(), {}).limits}["services"]
    assert (services.needed, services.value, services.fits) == (6, 5, False)  # _output's header says 6


def test_rclc_s_action_client_is_named_as_a_hazard_where_it_is_created() -> None:
    """rclc's set_uuid: two 64-bit stores at offset 9 of the goal handle (hard-faulted on cortex-m7)."""
    use = _use('x;\nrclc_action_client_init_default(&client, &node, ts, "fibonacci");\n')
    (line,) = fit.hazards(use.calls)
    assert line.startswith("main.c:2: rclc's action client writes each goal id with two 64-bit stores")
    assert "rcl_action_send_goal_request) is not affected" in line
    assert fit.hazards(_use().calls) == ()  # an action server alone is not
    found = fit.Fit((), (), True, (), fit.hazards(use.calls))
    assert fit.summary(found)[0] == (True, line) and fit.report(found)["hazards"] == [line]
