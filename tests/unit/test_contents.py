"""What `uros info` reads from an output: interface types, options in force, package sources."""

from __future__ import annotations

from pathlib import Path

from uros_build.output import contents
from uros_build.sources import clones
from uros_build.sources.meta import Meta


def _header(include: Path, rel: str, text: str = "") -> None:
    path = include / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_interface_types_come_from_the_generated_structs(tmp_path: Path) -> None:
    inc = tmp_path / "include"
    _header(inc, "std_msgs/msg/u_int8.h")
    _header(inc, "std_msgs/msg/detail/u_int8__struct.h", "typedef struct std_msgs__msg__UInt8\n{\n")
    _header(inc, "std_msgs/msg/int32_multi_array.h")  # no struct header: named from the file
    _header(inc, "action_msgs/srv/cancel_goal.h")
    _header(
        inc,
        "action_msgs/srv/detail/cancel_goal__struct.h",
        "typedef struct action_msgs__srv__CancelGoal_Request\n",
    )
    _header(inc, "example_interfaces/action/fibonacci.h")
    _header(
        inc,
        "example_interfaces/action/detail/fibonacci__struct.h",
        "typedef struct example_interfaces__action__Fibonacci_Goal\n",
    )
    _header(inc, "rcl/rcl.h")  # not an interface
    assert contents.interface_types(inc) == (
        "std_msgs/msg/Int32MultiArray",
        "std_msgs/msg/UInt8",
        "action_msgs/srv/CancelGoal",
        "example_interfaces/action/Fibonacci",
    )


def test_options_in_force() -> None:
    meta = Meta(
        names={
            "rmw_microxrcedds": {"cmake-args": ("-DRMW_UXRCE_MAX_NODES=2", "-DRMW_UXRCE_TRANSPORT=custom")},
            "rcutils": {"cmake-args": ("-DENABLE_TESTING:BOOL=OFF", "--no-warn-unused-cli")},
        }
    )
    options = contents.cmake_options(meta)
    assert options == {
        "rcutils": {"ENABLE_TESTING": "OFF"},
        "rmw_microxrcedds": {"RMW_UXRCE_MAX_NODES": "2", "RMW_UXRCE_TRANSPORT": "custom"},
    }
    assert contents.memory_options(options) == {"rmw_microxrcedds": options["rmw_microxrcedds"]}


def test_built_from_reads_each_clones_head_from_its_files(tmp_path: Path) -> None:
    rcl = tmp_path / "mcu_ws/uros/rcl/.git"
    rcl.mkdir(parents=True)
    (rcl / "HEAD").write_text("a" * 40 + "\n")  # detached, as uros pins clones
    rclc = tmp_path / "mcu_ws/uros/rclc/.git"
    (rclc / "refs/heads").mkdir(parents=True)
    (rclc / "HEAD").write_text("ref: refs/heads/humble\n")
    (rclc / "packed-refs").write_text("# pack-refs with: peeled\n" + "b" * 40 + " refs/heads/humble\n")
    found = [
        ("rcl", tmp_path / "mcu_ws/uros/rcl/rcl"),
        ("rclc", tmp_path / "mcu_ws/uros/rclc/rclc"),
        ("mine", tmp_path / "mcu_ws/extra_packages/mine"),
    ]
    assert clones.built_from(found, tmp_path, ["mcu_ws/uros/rcl", "mcu_ws/uros/rclc"]) == {
        "rcl": {"repository": "mcu_ws/uros/rcl", "commit": "a" * 40},
        "rclc": {"repository": "mcu_ws/uros/rclc", "commit": "b" * 40},
    }
    (rclc / "refs/heads/humble").write_text("c" * 40 + "\n")  # a loose ref wins over packed-refs
    assert clones.head_commit(tmp_path / "mcu_ws/uros/rclc") == "c" * 40
