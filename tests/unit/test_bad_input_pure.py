"""The pure parts of answering bad input (issue 8): the first error line, the failing package,
typos in --set/--meta, constants out of range, files where folders go, malformed build-info."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uros_build.colcon import command as colcon
from uros_build.config.plan import set_origins, unknown_packages
from uros_build.errors import ConfigError
from uros_build.output.buildinfo import parse_build_info
from uros_build.sources import interfaces, packages
from uros_build.sources.meta import Meta, parse_meta
from uros_build.sources.workspace import check_file_target, check_folder_target
from uros_build.sources.wsfiles import WorkspaceConfig, parse_config
from uros_build.tooltext import first_error


def test_a_cmake_error_carries_its_message() -> None:
    lines = [
        "-- Configuring incomplete",
        "CMake Error at CMakeLists.txt:4 (message):",
        "  fx_dup needs FOO set",
        "  (see the README)",
        "",
        "",
        "-- Configuring incomplete, errors occurred!",
    ]
    assert (
        first_error(lines)
        == "CMake Error at CMakeLists.txt:4 (message): fx_dup needs FOO set (see the README)"
    )
    stack = ["CMake Error at a.cmake:3 (include):", "  Parse error.", "Call Stack (most recent call first):"]
    assert first_error(stack) == "CMake Error at a.cmake:3 (include): Parse error."


def test_colcons_duplicate_names_error_is_one_line() -> None:
    lines = [
        "[0.509s] ERROR:colcon:colcon build: Duplicate package names not supported:",
        "- fx_dup:",
        "  - /w/mcu_ws/src/fx_dup",
        "  - /w/mcu_ws/src/fx_dup2",
    ]
    assert first_error(lines) == (
        "colcon build: Duplicate package names not supported: - fx_dup: - /w/mcu_ws/src/fx_dup - /w/mcu_ws/src/fx_dup2"
    )


def test_failed_packages_from_colcons_summary() -> None:
    lines = [
        "Starting >>> fx_core",
        "Failed   <<< fx_dup [0.05s, exited with code 1]",
        "Aborted  <<< fx_core [0.06s]",
        "Failed   <<< fx_util [1.2s, exited with code 2]",
    ]
    assert colcon.failed_packages(lines) == ["fx_dup", "fx_util"]
    assert colcon.package_log(Path("/t/log"), "fx_dup") == Path(
        "/t/log/latest_build/fx_dup/stdout_stderr.log"
    )


def test_set_and_meta_entries_naming_no_package() -> None:
    names = {"fx_core", "fx_time", "rcl"}
    meta = Meta(names={"fx_tme": {}, "rcl": {}}, source="my.meta")
    assert unknown_packages([meta], ("fx_cor.X=1", "rcl.Y=2", "zzz.Q=1"), names) == [
        "--meta my.meta: names.fx_tme: no package fx_tme in the workspace (closest: fx_time, fx_core)",
        "--set fx_cor.X=1: no package fx_cor in the workspace (closest: fx_core)",
        "--set zzz.Q=1: no package zzz in the workspace",
    ]
    cfg = WorkspaceConfig(distro="humble", set=("zzz.Q=1", "rcl.Y=2", "fx_cor.X=1"))
    origins = set_origins(cfg, Path("/w"), ("fx_cor.X=1",))  # also on the command line: --set
    assert origins == {"zzz.Q=1": "/w/uros.yaml: set:", "rcl.Y=2": "/w/uros.yaml: set:"}
    assert unknown_packages([], ("zzz.Q=1", "fx_cor.X=1"), names, origins) == [
        "/w/uros.yaml: set: zzz.Q=1: no package zzz in the workspace",
        "--set fx_cor.X=1: no package fx_cor in the workspace (closest: fx_core)",
    ]


@pytest.mark.parametrize("option", ["cmake-args", "ament-cmake-args", "ctest-args"])
def test_args_options_must_be_lists(option: str) -> None:
    with pytest.raises(ConfigError, match=f"names.p.{option} must be a list of strings, got '-DA=1'"):
        parse_meta(json.dumps({"names": {"p": {option: "-DA=1"}}}), "m.meta")
    assert (
        parse_meta(json.dumps({"names": {"p": {"cmake-target": "all"}}}), "m").names["p"]["cmake-target"]
        == "all"
    )


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("int8 V = 300", "constant value '300' is outside -128..127 for type int8"),
        ("int8 V=-129", "constant value '-129' is outside -128..127 for type int8"),
        ("uint16 V = 65536", "constant value '65536' is outside 0..65535 for type uint16"),
        ("byte V = 256", "constant value '256' is outside 0..255 for type byte"),
        ("bool V = 2", "constant value '2' is not true/false for type bool"),
        ("float32 V = fast", "constant value 'fast' is not a number for type float32"),
        ("int8[2] V = [1, 2]", "constant 'V' must have a primitive type, no array"),
        ("std_msgs/Header V = 1", "constant 'V' must have a primitive type, no array"),
    ],
)
def test_constants_are_checked_like_rosidl(tmp_path: Path, line: str, expected: str) -> None:
    msg = tmp_path / "Limits.msg"
    msg.write_text(line + "\n")
    with pytest.raises(
        ConfigError, match=f"Limits.msg:1: {expected}".replace("[", "\\[").replace("]", "\\]")
    ):
        interfaces.read_interface(msg, "msg")
    msg.write_text("int8 V = 127\nuint8 W = 255\nstring S = 'a = b'\nbool B = true\n")
    interfaces.read_interface(msg, "msg")


def test_a_msg_that_is_not_utf8(tmp_path: Path) -> None:
    msg = tmp_path / "Wheel.msg"
    msg.write_bytes(b"int32 rpm # caf\xe9\n")
    with pytest.raises(ConfigError, match=r"--msg .*Wheel.msg: not UTF-8 text \(byte 15\)"):
        interfaces.read_interface(msg, "msg")


def test_files_where_folders_go_and_back(tmp_path: Path) -> None:
    mine = tmp_path / "notes.txt"
    mine.write_text("mine")
    with pytest.raises(ConfigError, match=r"notes\.txt: is a file"):
        check_folder_target(mine, "--output")
    with pytest.raises(ConfigError, match=r"notes.txt/a/b: is inside .*notes.txt, which is a file"):
        check_folder_target(mine / "a" / "b", "--output")
    with pytest.raises(ConfigError, match="is a folder"):
        check_file_target(tmp_path, "-o")
    with pytest.raises(ConfigError, match=r"notes\.txt is a file, not a folder"):
        check_file_target(mine / "x" / "t.cmake", "-o")
    check_folder_target(tmp_path / "new" / "deeper", "--output")
    check_file_target(tmp_path / "new" / "t.cmake", "-o")


def _info() -> dict[str, object]:
    return {
        "generated_by": "uros 0.1.0",
        "target": "cortex-m7",
        "library": {"file": "libmicroros.a", "sha256": "s"},
    }


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            {"library": {"file": "l", "sha256": "s", "bytes": "many"}},
            "library: bytes: must be a whole number",
        ),
        ({"library": {"file": "l", "sha256": "s", "members": -1}}, "library: members: must be 0 or more"),
        (
            {"library": {"file": "l", "sha256": "s", "size": {"text": "x"}}},
            "library: size: text: must be a whole",
        ),
        ({"idf_target": 5}, "idf_target: must be a string, got 5"),
        ({"transport": ["udp"]}, "transport: must be a string"),
        ({"include": {"files": True}}, "include: files: must be a whole number"),
        ({"flags": {"optimization": 2}}, "flags: optimization: must be a string"),
        ({"idf": {"version": "5.3.1", "target": "esp32s3"}}, "idf: sdkconfig_sha256: is required"),
        (
            {"idf": {"version": "5.3.1", "target": "esp32s3", "sdkconfig_sha256": "s", "components": "x"}},
            "idf: components: must be a whole number",
        ),
    ],
)
def test_malformed_build_info_names_the_key(change: dict[str, object], expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        parse_build_info({**_info(), **change}, "build-info.json")
    assert parse_build_info(_info(), "b").library.bytes == 0


def test_build_info_idf_round_trip() -> None:
    from uros_build.output.buildinfo import IdfInfo

    idf = {"version": "5.3.1", "target": "esp32s3", "sdkconfig_sha256": "ab", "components": 39,
           "include_dirs": 68, "c_flags": ["-mlongcalls"], "cxx_flags": []}  # fmt: skip
    info = parse_build_info({**_info(), "idf": idf}, "b")
    assert info.idf == IdfInfo("5.3.1", "esp32s3", "ab", 39, 68, ("-mlongcalls",), ())
    assert parse_build_info(json.loads(info.to_json()), "b") == info
    assert "idf" not in json.loads(parse_build_info(_info(), "b").to_json())


def test_a_config_file_is_checked_whole_but_needs_no_distro() -> None:
    assert parse_config({"mirror": {"rules": []}}, "--config c").distro == ""
    with pytest.raises(ConfigError, match="extra_packages: must be a list of strings, got 'abc'"):
        parse_config({"extra_packages": "abc"}, "--config c")
    # nor does uros.yaml: a build needs no distro (`uros update` asks for one)
    assert parse_config({"target": "cortex-m7"}, "uros.yaml").distro == ""


def test_a_broken_package_xml_is_named(tmp_path: Path) -> None:
    pkg = tmp_path / "src" / "fx"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>fx")
    with pytest.raises(ConfigError, match=r"fx/package.xml: not a valid package.xml \(no element found"):
        packages.discover(tmp_path)
    (pkg / "package.xml").write_text("<package><version>1</version></package>")
    with pytest.raises(ConfigError, match="has no <name>"):
        packages.discover(tmp_path)
    (pkg / "COLCON_IGNORE").write_text("")
    assert packages.discover(tmp_path) == []


def test_cmake_packages_without_package_xml_count_as_packages(tmp_path: Path) -> None:
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain" / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nPROJECT( my_plain C)\n"
    )
    (tmp_path / "plain" / "sub").mkdir()  # colcon does not look inside a package
    (tmp_path / "plain" / "sub" / "CMakeLists.txt").write_text("project(inner)\n")
    (tmp_path / "ros").mkdir()
    (tmp_path / "ros" / "package.xml").write_text("<package><name>ros_pkg</name></package>")
    (tmp_path / "ros" / "CMakeLists.txt").write_text("project(ros_pkg)\n")
    (tmp_path / "ignored").mkdir()
    (tmp_path / "ignored" / "COLCON_IGNORE").write_text("")
    (tmp_path / "ignored" / "CMakeLists.txt").write_text("project(ignored)\n")
    assert packages.plain_cmake_packages(tmp_path) == {"my_plain"}


def test_build_info_holds_no_timings() -> None:
    """Round 3 (issue 34, 7): package_seconds made build-info.json differ from run to run; the
    timings are the target's timings.json now, and an older build-info.json that holds them reads."""
    info = parse_build_info({**_info(), "package_seconds": {"rcl": 12.5, "rclc": "slow"}}, "b")
    assert "package_seconds" not in json.loads(info.to_json())
    assert parse_build_info(json.loads(info.to_json()), "b") == info
    from uros_build.steps.colcon_run import timings_json

    assert json.loads(timings_json({"rclc": 3, "rcl": 12.3456})) == {
        "package_seconds": {"rcl": 12.35, "rclc": 3}
    }
