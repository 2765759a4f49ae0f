from __future__ import annotations

from pathlib import Path

import pytest

from uros_build import distros, firmware
from uros_build.distros import Mirror, MirrorRule, Repo
from uros_build.errors import ConfigError

# micro_ros_setup's generate_lib lists (humble, config/client_ros2_packages.txt and
# config/client_uros_packages.repos): what the mcu workspace must hold.
HUMBLE_MCU = {
    "ros2/rcl",
    "ros2/rmw",
    "ros2/rosidl_defaults",
    "ros2/rosidl",
    "ros2/rosidl_dds",
    "ros2/rmw_implementation",
    "ros2/common_interfaces",
    "ros2/libyaml_vendor",
    "ros2/rcl_interfaces",
    "ros2/unique_identifier_msgs",
    "ros2/rcl_logging",
    "ros2/test_interface_files",
    "ros2/example_interfaces",
    "ros2/rcpputils",
    "eProsima/Micro-CDR",
    "eProsima/Micro-XRCE-DDS-Client",
    "uros/rcl",
    "uros/rclc",
    "uros/micro_ros_utilities",
    "uros/rcutils",
    "uros/micro_ros_msgs",
    "uros/rmw_microxrcedds",
    "uros/rosidl_typesupport",
    "uros/rosidl_typesupport_microxrcedds",
    "uros/tracetools",
}
HUMBLE_DEV = {
    "ament/ament_cmake",
    "ament/ament_index",
    "ament/ament_lint",
    "ament/ament_package",
    "ament/googletest",
    "ament/uncrustify_vendor",
    "ros2/ament_cmake_ros",
}


def test_humble_matches_micro_ros_setup() -> None:
    d = distros.load_distro("humble")
    assert {r.path for r in d.mcu} == HUMBLE_MCU
    assert {r.path for r in d.dev} == HUMBLE_DEV
    assert all(r.version == "humble" for r in d.mcu if not r.path.startswith("eProsima/"))
    assert all(r.version == "ros2" for r in d.mcu if r.path.startswith("eProsima/"))
    assert "ros2/rcl" in d.colcon_ignore and "uros/rclc/rclc_examples" in d.colcon_ignore
    assert d.preset == "humble" and d.status == "built-here"
    assert "https://github.com/yaml/libyaml.git" in d.build_time_clones


@pytest.mark.parametrize("name", ["humble", "iron", "jazzy", "kilted", "rolling"])
def test_every_distro_is_consistent(name: str) -> None:
    d = distros.load_distro(name)
    paths = {r.path for r in d.mcu}
    # the micro-ROS core of every distro
    for core in (
        "eProsima/Micro-CDR",
        "eProsima/Micro-XRCE-DDS-Client",
        "uros/rclc",
        "uros/rcutils",
        "uros/rmw_microxrcedds",
        "uros/rosidl_typesupport",
        "uros/micro_ros_utilities",
    ):
        assert core in paths, (name, core)
    # every ignored path lies inside a repository of the workspace
    for ignored in d.colcon_ignore:
        assert any(ignored == p or ignored.startswith(p + "/") for p in paths), (name, ignored)
    for ignored in d.dev_colcon_ignore:
        assert any(ignored.startswith(r.path + "/") for r in d.dev), (name, ignored)
    # GitHub URLs the {owner}/{repo} mirror rule can map
    for repo in (*d.dev, *d.mcu):
        assert distros.owner_repo(repo.url), repo
    assert d.preset in ("humble", name)
    from uros_build import meta

    meta.load_preset(d.preset)


def test_unknown_distro_lists_known() -> None:
    with pytest.raises(ConfigError) as info:
        distros.load_distro("ardent")
    assert info.value.hint is not None and "humble" in info.value.hint


def test_mirror_rule_and_overrides() -> None:
    rule = distros.parse_rule("https://github.com/{owner}/{repo}=/m/{owner}+{repo}/repo")
    assert rule.apply("https://github.com/ros2/rcl.git") == "/m/ros2+rcl/repo"
    assert rule.apply("https://github.com/micro-ROS/rcl") == "/m/micro-ROS+rcl/repo"
    assert rule.apply("https://gitlab.com/micro-ROS/ros_tracing/ros2_tracing.git/") is None
    mirror = Mirror(
        (rule,),
        (distros.parse_override("ament/googletest=@ros2"), distros.parse_override("uros/tracetools=/t/repo")),
    )
    g = distros.resolve(Repo("ament/googletest", "https://github.com/ament/googletest.git", "humble"), mirror)
    assert (g.url, g.version) == ("/m/ament+googletest/repo", "ros2")
    t = distros.resolve(
        Repo("uros/tracetools", "https://gitlab.com/micro-ROS/ros_tracing/ros2_tracing.git/", "humble"),
        mirror,
    )
    assert (t.url, t.version) == ("/t/repo", "humble")
    locked = distros.resolve(
        Repo("ros2/rcl", "https://github.com/ros2/rcl.git", "humble"),
        mirror,
        {"mcu_ws/ros2/rcl": "a" * 40},
        prefix="mcu_ws/",
    )
    assert locked.is_commit and locked.version == "a" * 40


def test_override_parsing() -> None:
    assert distros.parse_override("a/b=git@host:x/y.git") == distros.Override("a/b", "git@host:x/y.git", None)
    assert distros.parse_override("a/b=/p/repo@ros2") == distros.Override("a/b", "/p/repo", "ros2")
    with pytest.raises(ConfigError, match="REPO=URL"):
        distros.parse_override("nothing")
    with pytest.raises(ConfigError, match="UPSTREAM=LOCAL"):
        distros.parse_rule("https://github.com/{owner}/{repo}")


def test_insteadof_for_build_time_clones() -> None:
    mirror = Mirror((MirrorRule("https://github.com/{owner}/{repo}", "/m/{owner}+{repo}/repo"),))
    cfg = distros.insteadof(["https://github.com/yaml/libyaml.git"], mirror)
    assert cfg == {"url./m/yaml+libyaml/repo.insteadOf": "https://github.com/yaml/libyaml.git"}


def test_clone_argv_branch_and_commit() -> None:
    src = distros.Source(Repo("ros2/rcl", "u", "humble"), "/m/rcl", "humble")
    assert firmware.clone_argv("git", src, Path("/w/rcl")) == [
        [
            "git",
            "-c",
            "advice.detachedHead=false",
            "clone",
            "--quiet",
            "--branch",
            "humble",
            "/m/rcl",
            "/w/rcl",
        ]
    ]
    pinned = distros.Source(Repo("ros2/rcl", "u", "humble"), "/m/rcl", "b" * 40)
    argvs = firmware.clone_argv("git", pinned, Path("/w/rcl"))
    assert argvs[0][-3:] == ["--no-checkout", "/m/rcl", "/w/rcl"] and argvs[1][-1] == "b" * 40


def test_dev_env_is_sourced_setup_without_a_shell(tmp_path: Path) -> None:
    site = tmp_path / "lib" / "python3.11" / "site-packages"
    site.mkdir(parents=True)
    env = firmware.dev_env({"PATH": "/usr/bin", "PYTHONPATH": "/x"}, tmp_path)
    assert env["AMENT_PREFIX_PATH"] == str(tmp_path) and env["CMAKE_PREFIX_PATH"] == str(tmp_path)
    assert env["PATH"] == f"{tmp_path}/bin:/usr/bin"
    assert env["PYTHONPATH"] == f"{site}:/x"
