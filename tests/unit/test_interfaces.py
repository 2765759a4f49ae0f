from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.sources import interfaces


def _file(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_seed_interfaces_scaffold(tmp_path: Path) -> None:
    cmd_vel = _file(tmp_path, "CmdVel.msg", "# wheel speeds\nint32 left_rpm\nint32 right_rpm\n")
    get_time = _file(tmp_path, "GetTime.srv", "int64 time_ms_req\n---\nint64 time_ms_res\n")
    hsb = _file(
        tmp_path, "Hsb.msg", "float32 hue\nfloat32 saturation\nfloat32 brightness\nuint8 MAX_LEVEL=255\n"
    )
    files = [
        interfaces.read_interface(cmd_vel, "msg"),
        interfaces.read_interface(hsb, "msg"),
        interfaces.read_interface(get_time, "srv"),
    ]
    out = interfaces.package_files("eic_demo_interface", files)
    assert set(out) == {"package.xml", "CMakeLists.txt", "msg/CmdVel.msg", "msg/Hsb.msg", "srv/GetTime.srv"}
    assert "<member_of_group>rosidl_interface_packages</member_of_group>" in out["package.xml"]
    assert '"msg/CmdVel.msg"\n  "msg/Hsb.msg"\n  "srv/GetTime.srv"' in out["CMakeLists.txt"]


def test_dependencies_become_depends(tmp_path: Path) -> None:
    stamped = _file(tmp_path, "Stamped.msg", "std_msgs/Header header\ngeometry_msgs/Twist twist\n")
    out = interfaces.package_files("my_msgs", [interfaces.read_interface(stamped, "msg")])
    assert (
        "<depend>geometry_msgs</depend>" in out["package.xml"]
        and "<depend>std_msgs</depend>" in out["package.xml"]
    )
    assert "DEPENDENCIES geometry_msgs std_msgs" in out["CMakeLists.txt"]


@pytest.mark.parametrize(
    ("name", "text", "expected"),
    [
        ("Bad.msg", "int32 LeftRpm\n", r"Bad.msg:1: field name 'LeftRpm' is invalid"),
        ("Bad.msg", "int32\n", r"Bad.msg:1: expected 'TYPE NAME'"),
        ("Bad.msg", "int32 a\nin+t b\n", r"Bad.msg:2: 'in\+t' is not a valid field type"),
        ("Bad.msg", "int32 a\nfloat32 b__c\n", r"Bad.msg:2: field name 'b__c'"),
        ("Bad.msg", "uint8 max=3\n", r"constant 'max' must be UPPER_CASE"),
        ("bad_name.msg", "int32 a\n", r"'bad_name' is not a valid type name"),
        ("Bad.srv", "int32 a\n", r"needs one '---' line"),
        ("Bad.msg", "int32 a 3.5\n", r"Bad.msg:1: default value '3.5' is not an integer for type int32"),
        ("Bad.msg", "uint8 a 256\n", r"default value '256' is outside 0..255"),
        ("Bad.msg", "float32 a x\n", r"is not a number"),
        # round 3 (issue 34, 7): rosidl refused these deep in CMake, or kept a stray quote
        ("Bad.msg", "int32 a\nint32 b\nfloat32 a\n", r"Bad.msg:3: field 'a' is already defined on line 1"),
        ("Bad.msg", "int32 A=1\nint32 A=2\n", r"Bad.msg:2: constant 'A' is already defined on line 1"),
        ("Bad.srv", "int32 a\nint32 a\n---\nint32 r\n", r"Bad.srv:2: field 'a' is already defined on line 1"),
        ("Bad.msg", 'string name "left\n', r"Bad.msg:1: default value '\"left': the string is not closed"),
        ("Bad.msg", "string name 'a # b'\n", r"Bad.msg:1: default value \"'a\": the string is not closed"),
        ("Bad.msg", 'string S = "x\n', r"Bad.msg:1: constant value '\"x': the string is not closed"),
        (
            "Bad.msg",
            'string s "a"b"\n',
            r"Bad.msg:1: default value '\"a\"b\"': a \" inside the string is not",
        ),
        (
            "Bad.msg",
            'string[] names ["left", "right]\n',
            r"Bad.msg:1: default value .*: the string '\"right' is not",
        ),
        (
            "Bad.msg",
            "int32[3] v [1, 2]\n",
            r"Bad.msg:1: default value '\[1, 2\]' has 2 elements; the type's \[3\] holds exactly 3",
        ),
        ("Bad.msg", "int32[<=1] v [1, 2]\n", r"has 2 elements; the type's \[<=1\] holds at most 1"),
        (
            "Bad.msg",
            "uint8[] v [1, 300]\n",
            r"Bad.msg:1: array element '300' is outside 0..255 for type uint8",
        ),
        ("Bad.msg", "int32[] v 1, 2\n", r"Bad.msg:1: default value '1, 2' of an array is not in \[ \]"),
        (
            "Bad.msg",
            "geometry_msgs/Twist t 5\n",
            r"field 't' of type 'geometry_msgs/Twist' cannot have a default",
        ),
    ],
)
def test_bad_interface_files(tmp_path: Path, name: str, text: str, expected: str) -> None:
    kind = name.rsplit(".", 1)[1]
    with pytest.raises(ConfigError, match=expected):
        interfaces.read_interface(_file(tmp_path, name, text), kind)


def test_bad_package_name() -> None:
    with pytest.raises(ConfigError, match="not a valid package name"):
        interfaces.package_files("MyMsgs", [interfaces.InterfaceFile("msg", "A", "int32 a\n", ())])


def test_a_request_and_its_response_may_share_a_name(tmp_path: Path) -> None:
    srv = _file(tmp_path, "Echo.srv", "string text 'hi'\nint32 A=1\n---\nstring text \"it's\"\nint32 A=2\n")
    assert interfaces.read_interface(srv, "srv").name == "Echo"


def test_the_same_interface_file_twice_is_refused(tmp_path: Path) -> None:
    """Both went to msg/Wheel.msg: one of two different files was lost without a word."""
    first = _file(tmp_path, "Wheel.msg", "int32 rpm\n")
    (tmp_path / "b").mkdir()
    second = _file(tmp_path / "b", "Wheel.msg", "int32 speed\n")
    for again in (first, second):
        files = [interfaces.read_interface(first, "msg"), interfaces.read_interface(again, "msg")]
        with pytest.raises(ConfigError) as info:
            interfaces.package_files("my_msgs", files)
        assert info.value.message == f"--msg {again}: a second Wheel.msg (the first: --msg {first})"


def test_array_defaults_rosidl_takes(tmp_path: Path) -> None:
    text = "string[2] names [\"a, b\", 'c']\nint32[<=3] v [1, 2]\nbool[] b [true, 0]\nstring[] e []\n"
    assert interfaces.read_interface(_file(tmp_path, "Arrays.msg", text), "msg").name == "Arrays"
