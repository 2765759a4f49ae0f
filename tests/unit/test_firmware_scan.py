"""The firmware scanner: which interface packages a firmware's C/C++ sources use (pure)."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.sources import firmware_scan
from uros_build.sources.firmware_scan import scan_folder, scan_text, snake_case

REPO = Path(__file__).resolve().parents[2]


def test_includes_of_messages_services_and_actions() -> None:
    text = """
    #include <stdio.h>
    #include <rcl/rcl.h>
    #include <std_msgs/msg/int32.h>
    #  include "geometry_msgs/msg/twist.h"
    #include <example_interfaces/srv/add_two_ints.h>
    #include <my_actions/action/fibonacci.h>
    #include <sensor_msgs/msg/detail/imu__struct.h>
    #include <std_msgs/msg/string.hpp>
    """
    assert scan_text(text) == {
        "std_msgs": {"msg/int32", "msg/string"},
        "geometry_msgs": {"msg/twist"},
        "example_interfaces": {"srv/add_two_ints"},
        "my_actions": {"action/fibonacci"},
        "sensor_msgs": {"msg/imu"},
    }


def test_type_support_macros() -> None:
    text = """
    rclc_publisher_init_default(&pub, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32), "t");
    rclc_service_init_default(&srv, &node,
        ROSIDL_GET_SRV_TYPE_SUPPORT( example_interfaces , srv , AddTwoInts ), "add");
    x = ROSIDL_GET_ACTION_TYPE_SUPPORT(my_actions, action, Fibonacci);
    y = ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_c, nav_msgs, msg, Odometry)();
    """
    assert scan_text(text) == {
        "std_msgs": {"msg/int32"},
        "example_interfaces": {"srv/add_two_ints"},
        "my_actions": {"action/fibonacci"},
        "nav_msgs": {"msg/odometry"},
    }


def test_comments_do_not_count() -> None:
    text = """
    // #include <std_msgs/msg/int32.h>
    /* #include <geometry_msgs/msg/twist.h>
       ROSIDL_GET_MSG_TYPE_SUPPORT(geometry_msgs, msg, Twist) */
    #include <sensor_msgs/msg/imu.h> // the IMU
    """
    assert scan_text(text) == {"sensor_msgs": {"msg/imu"}}


def test_headers_that_are_not_interfaces_do_not_count() -> None:
    assert scan_text("#include <rclc/executor.h>\n#include <uxr/client/transport.h>\n") == {}
    assert scan_text('puts("#include <std_msgs/msg/int32.h>");\n') == {}  # not at a line start


@pytest.mark.parametrize(
    ("camel", "snake"),
    [("CmdVel", "cmd_vel"), ("Int32", "int32"), ("HSVColor", "hsv_color"), ("GetTime", "get_time")],
)
def test_snake_case_is_rosidls(camel: str, snake: str) -> None:
    assert snake_case(camel) == snake


def test_the_stm32h7_example_uses_its_own_interface_package() -> None:
    use = scan_folder(REPO / "examples" / "stm32h7-custom-interfaces")
    assert dict(use.packages) == {"eic_demo_interface": frozenset({"msg/cmd_vel", "srv/get_time"})}
    assert use.files["eic_demo_interface"] == ("main.c",)
    assert use.scanned == 3  # main.c, board.c, board.h


def test_build_trees_and_uros_outputs_are_not_the_firmware(tmp_path: Path) -> None:
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "app.cpp").write_text("#include <std_msgs/msg/int32.hpp>\n")
    out = tmp_path / "micro_ros" / "include" / "nav_msgs" / "msg"
    out.mkdir(parents=True)
    (tmp_path / "micro_ros" / "build-info.json").write_text("{}")
    (out / "odometry.h").write_text("#include <geometry_msgs/msg/pose.h>\n")
    cmake = tmp_path / "build" / "CMakeFiles"
    cmake.mkdir(parents=True)
    (tmp_path / "build" / "CMakeCache.txt").write_text("")
    (cmake / "x.c").write_text("#include <diagnostic_msgs/msg/key_value.h>\n")
    (tmp_path / ".git").mkdir()
    (tmp_path / ".git" / "y.h").write_text("#include <tf2_msgs/msg/tf.h>\n")
    assert dict(scan_folder(tmp_path).packages) == {"std_msgs": frozenset({"msg/int32"})}


def test_describe_names_packages_and_types() -> None:
    use = firmware_scan.FirmwareUse({"b": frozenset({"msg/x"}), "a": frozenset({"srv/y", "msg/z"})})
    assert use.describe() == "a (msg/z, srv/y); b (msg/x)"


def test_rclc_calls_with_their_line_and_arguments() -> None:
    text = """#include <rclc/executor.h>
    /* rclc_service_init_default(&s, &node, ts, "x");
       in a comment */
    // rclc_publisher_init_default(&p, &node, ts, "y");
    RCCHECK(rclc_executor_init(&executor, &support.context, HANDLES + 1, &allocator));
    printf("rclc_client_init_default(&c) failed, try again");
    rclc_publisher_init_best_effort(&pub, &node,
        ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32), "a,b");
    rclc_executor_add_parameter_server(&executor, &param_server, on_changed);
    rclc_executor_add_timer( & app.executor , &timer);
    """
    calls = firmware_scan.scan_calls(text, "src/main.c")
    assert [(c.function, c.where) for c in calls] == [
        ("rclc_executor_init", "src/main.c:5"),
        ("rclc_publisher_init_best_effort", "src/main.c:7"),
        ("rclc_executor_add_parameter_server", "src/main.c:9"),
        ("rclc_executor_add_timer", "src/main.c:10"),
    ]
    assert calls[0].args == ("&executor", "&support.context", "HANDLES + 1", "&allocator")
    # a comma in a string or in a nested call does not split an argument
    assert calls[1].args[2:] == ("ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32)", '" "')
    assert calls[3].args == ("& app.executor", "&timer")


def test_object_like_defines_only() -> None:
    text = "#define HANDLES (3 + 2) // three and two\n#define TWICE(x) ((x) * 2)\n#  define N 4\n"
    assert firmware_scan.scan_defines(text) == {"HANDLES": "(3 + 2)", "N": "4"}


def test_a_folder_s_calls_are_relative_to_it_and_the_first_define_wins(tmp_path: Path) -> None:
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "a.c").write_text('#define N 2\nrclc_node_init_default(&node, "n", "", &s);\n')
    (tmp_path / "src" / "b.c").write_text("#define N 3\n\nrclc_timer_init_default(&t, &s, 1, cb);\n")
    use = scan_folder(tmp_path)
    assert [c.where for c in use.calls] == ["src/a.c:2", "src/b.c:3"]
    assert use.defines == {"N": "2"}
