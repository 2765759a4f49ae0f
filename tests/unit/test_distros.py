from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from uros_build import resources
from uros_build.errors import ConfigError
from uros_build.sources import distros
from uros_build.sources.distros import Mirror, MirrorRule, Repo

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


def test_distros_are_discovered_from_meta() -> None:
    names = distros.known_distros()
    assert {"humble", "iron", "jazzy", "kilted", "rolling"} <= set(names)
    assert names == sorted(names)


@pytest.mark.parametrize("name", distros.known_distros())
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
    from uros_build.sources import meta

    meta.load_preset(d.preset)


def _distro_data() -> dict[str, Any]:
    return {
        "name": "humble",
        "status": "built-here",
        "preset": "humble",
        "colcon_ignore": ["ros2/rcl"],
        "dev_colcon_ignore": [],
        "build_time_clones": [{"url": "https://github.com/yaml/libyaml.git", "by": "libyaml_vendor"}],
    }


def test_parse_distro() -> None:
    d = distros.parse_distro(_distro_data(), "distro.yaml", "humble", (), ())
    assert d.colcon_ignore == ("ros2/rcl",)
    assert d.build_time_clones == ("https://github.com/yaml/libyaml.git",)
    minimal = distros.parse_distro({"name": "humble"}, "distro.yaml", "humble", (), ())
    assert minimal.status == "manifest-only" and minimal.preset == "humble" and minimal.colcon_ignore == ()


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"name": None}, "distro.yaml: name: is required but missing"),
        ({"name": "iron"}, "distro.yaml: name: 'iron' differs from its folder name 'humble'"),
        ({"name": 2}, "distro.yaml: name: must be a non-empty string, got 2"),
        ({"colcon_ignore": "abc"}, "distro.yaml: colcon_ignore: must be a list of strings, got 'abc'"),
        ({"dev_colcon_ignore": [1]}, "distro.yaml: dev_colcon_ignore: must be a list of strings"),
        (
            {"status": "built"},
            "distro.yaml: status: 'built' is not one of built-here, buildable-here, manifest-only",
        ),
        ({"preset": "ardent"}, "distro.yaml: preset: 'ardent' is not a shipped preset"),
        ({"build_time_clones": [{"by": "x"}]}, r"distro.yaml: build_time_clones\[0\]: url: is required"),
        ({"build_time_clones": [{"url": "u", "why": "x"}]}, r"build_time_clones\[0\]: why: unknown key"),
        ({"build_time_clones": "u"}, "distro.yaml: build_time_clones: must be a list of mappings"),
        ({"build_time_clones": [{"url": 3}]}, r"build_time_clones\[0\]: url: must be a non-empty string"),
        ({"colcon_ignores": []}, r"distro.yaml: colcon_ignores: unknown key \(known: build_time_clones,"),
    ],
)
def test_bad_distro_names_file_and_key(change: dict[str, Any], expected: str) -> None:
    data = {k: v for k, v in {**_distro_data(), **change}.items() if v is not None}
    with pytest.raises(ConfigError, match=expected) as info:
        distros.parse_distro(data, "distro.yaml", "humble", (), ())
    assert "\n" not in info.value.message


def test_distro_that_is_not_a_mapping() -> None:
    with pytest.raises(ConfigError, match=r"distro.yaml: expected a mapping"):
        distros.parse_distro(["name: humble"], "distro.yaml", "humble", (), ())


def _fake_meta(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, distro_yaml: str, mcu_repos: str) -> Path:
    folder = tmp_path / "meta" / "distros" / "demo"
    folder.mkdir(parents=True)
    (tmp_path / "meta" / "presets").mkdir()
    (tmp_path / "meta" / "presets" / "demo.json").write_text('{"names": {}}', encoding="utf-8")
    (folder / "distro.yaml").write_text(distro_yaml, encoding="utf-8")
    (folder / "dev.repos").write_text("repositories: {}\n", encoding="utf-8")
    (folder / "mcu.repos").write_text(mcu_repos, encoding="utf-8")
    monkeypatch.setattr(resources, "meta_dir", lambda: tmp_path / "meta")
    return folder


def test_load_distro_from_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repos = "repositories:\n  uros/rclc:\n    type: git\n    url: https://github.com/ros2/rclc.git\n    version: humble\n"
    _fake_meta(tmp_path, monkeypatch, "name: demo\nstatus: buildable-here\n", repos)
    d = distros.load_distro("demo")
    assert d.status == "buildable-here" and d.mcu == (
        Repo("uros/rclc", "https://github.com/ros2/rclc.git", "humble"),
    )


def test_load_distro_names_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = _fake_meta(tmp_path, monkeypatch, "name: demo\ncolcon_ignore: abc\n", "repositories: {}\n")
    with pytest.raises(ConfigError) as info:
        distros.load_distro("demo")
    assert (
        info.value.message == f"{folder / 'distro.yaml'}: colcon_ignore: must be a list of strings, got 'abc'"
    )


def test_load_distro_bad_repos_yaml(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = _fake_meta(tmp_path, monkeypatch, "name: demo\n", "repositories:\n  a: [\n")
    with pytest.raises(ConfigError, match=rf"^{re.escape(str(folder / 'mcu.repos'))}:3:1: not valid YAML"):
        distros.load_distro("demo")


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({}, "r.repos: repositories: is required but missing"),
        ({"repositories": []}, "r.repos: repositories: expected a mapping"),
        ({"repositories": {"a/b": {"version": "x"}}}, r"r.repos: repositories.a/b: url: is required"),
        (
            {"repositories": {"a/b": {"url": "u", "version": 2.0}}},
            r"repositories.a/b: version: must be a string",
        ),
        (
            {"repositories": {"a/b": {"type": "hg", "url": "u", "version": "x"}}},
            "type: 'hg' is not one of git",
        ),
        ({"repositories": {"a/b": {"url": "u", "version": "x", "branch": "y"}}}, "branch: unknown key"),
    ],
)
def test_bad_repos_file(data: Any, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        distros.parse_repos(data, "r.repos")


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


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        (
            "https://github.com/{user}/{repo}=/m/{user}+{repo}",
            r"unknown placeholder \{user\} in UPSTREAM \(known: \{owner\}, \{repo\}\)",
        ),
        ("https://github.com/{owner}/{repo}=/m/{name}", r"unknown placeholder \{name\} in LOCAL"),
        ("https://github.com/{owner}/{repo}=/m/{}", r"unknown placeholder \{\} in LOCAL"),
        (
            "https://github.com/{owner}=/m/{owner}+{repo}",
            r"LOCAL uses \{repo\}, which UPSTREAM does not match",
        ),
        ("https://github.com/{owner}/{owner}=/m/{owner}", r"\{owner\} appears twice in UPSTREAM"),
        ("https://github.com/{owner}/{repo}=/m/{owner", r"unbalanced \{ or \} in LOCAL"),
    ],
)
def test_mirror_rule_placeholders(spec: str, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected) as info:
        distros.parse_rule(spec)
    assert info.value.message.startswith(f"--mirror {spec!r}: ")


def test_mirror_config_unknown_placeholder_names_file_and_rule() -> None:
    rule = "https://github.com/{user}/{repo}=/m/{repo}"
    with pytest.raises(ConfigError) as info:
        distros.load_mirror_config({"rules": [rule]}, "uros.yaml")
    assert info.value.message == (
        f"uros.yaml: mirror.rules {rule!r}: unknown placeholder {{user}} in UPSTREAM (known: {{owner}}, {{repo}})"
    )


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"rule": []}, r"uros.yaml: mirror: rule: unknown key \(known: overrides, rules\)"),
        ({"rules": "https://a/{repo}=/m/{repo}"}, "uros.yaml: mirror: rules: must be a list of strings"),
        ({"overrides": ["a/b=@x"]}, "uros.yaml: mirror: overrides: expected a mapping"),
        (
            {"overrides": {"a/b": 2}},
            r"uros.yaml: mirror: overrides.a/b: expected \{use: URL\[@VERSION\], why",
        ),
        ({"overrides": {"a/b": {"use": "@x"}}}, "uros.yaml: mirror: overrides.a/b: why: is required"),
        ({"overrides": {"a/b": {"use": "@x", "why": "w", "as": 1}}}, "overrides.a/b: as: unknown key"),
        ([], "uros.yaml: mirror: expected a mapping"),
    ],
)
def test_bad_mirror_config(data: Any, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        distros.load_mirror_config(data, "uros.yaml")


def test_mirror_config_round_trip() -> None:
    data = {"rules": ["https://github.com/{owner}/{repo}=/m/{owner}+{repo}"], "overrides": {"a/b": "/x@ros2"}}
    mirror = distros.load_mirror_config(data, "uros.yaml")
    assert distros.mirror_to_config(mirror) == data
    assert distros.load_mirror_config(None, "uros.yaml") == Mirror()


def test_insteadof_for_build_time_clones() -> None:
    mirror = Mirror((MirrorRule("https://github.com/{owner}/{repo}", "/m/{owner}+{repo}/repo"),))
    cfg = distros.insteadof(["https://github.com/yaml/libyaml.git"], mirror)
    assert cfg == {"url./m/yaml+libyaml/repo.insteadOf": "https://github.com/yaml/libyaml.git"}


# -- declared stand-ins (issue 33 item 5: jazzy built from a mirror that lacks some jazzy branches) --


def test_override_with_a_reason_round_trips() -> None:
    data = {"overrides": {"ros2/rcl": {"use": "@9.2.0", "why": "no jazzy branch"}, "a/b": "/x@ros2"}}
    mirror = distros.load_mirror_config(data, "uros.yaml")
    rcl, plain = mirror.overrides
    assert (rcl.key, rcl.url, rcl.version, rcl.reason) == ("ros2/rcl", None, "9.2.0", "no jazzy branch")
    assert (plain.use, plain.reason) == ("/x@ros2", "")
    assert distros.mirror_to_config(mirror) == {"rules": [], **data}


def test_an_override_url_goes_through_the_mirror_rules() -> None:
    """A declared stand-in names the upstream fork; with a mirror it is cloned from the mirror."""
    rule = distros.parse_rule("https://github.com/{owner}/{repo}=/m/{owner}+{repo}")
    fork = distros.parse_override(
        "uros/rosidl_typesupport=https://github.com/fictionlab/rosidl_typesupport.git@jazzy"
    )
    repo = Repo("uros/rosidl_typesupport", "https://github.com/micro-ROS/rosidl_typesupport.git", "jazzy")
    source = distros.resolve(repo, Mirror((rule,), (fork,)))
    assert (source.url, source.version, source.stand_in) == (
        "/m/fictionlab+rosidl_typesupport",
        "jazzy",
        fork,
    )
    plain = distros.resolve(
        Repo("ros2/rmw", "https://github.com/ros2/rmw.git", "jazzy"), Mirror((rule,), (fork,))
    )
    assert (plain.url, plain.stand_in) == ("/m/ros2+rmw", None)
    assert distros.describe_stand_in("mcu_ws/x", source) == (
        "mcu_ws/x: jazzy from /m/fictionlab+rosidl_typesupport instead of jazzy "
        "(no reason given: say why in uros.yaml, mirror.overrides.<repo>.why)"
    )


def _stand_in_distro(stand_ins: Any) -> distros.Distro:
    repos = (Repo("ros2/rcl", "https://github.com/ros2/rcl.git", "jazzy"),)
    return distros.parse_distro({"name": "jazzy", "stand_ins": stand_ins}, "distro.yaml", "jazzy", (), repos)


def test_distro_declares_stand_ins_with_reasons() -> None:
    d = _stand_in_distro({"ros2/rcl": {"use": "@9.2.0", "why": "no jazzy branch"}})
    assert [(o.key, o.use, o.reason) for o in d.stand_ins] == [("ros2/rcl", "@9.2.0", "no jazzy branch")]


@pytest.mark.parametrize(
    ("stand_ins", "expected"),
    [
        (
            {"ros2/rcl": "@9.2.0"},
            r"distro.yaml: stand_ins.ros2/rcl: expected \{use: URL\[@VERSION\], why: REASON\}, got",
        ),
        ({"ros2/rcl": {"use": "@9.2.0"}}, "distro.yaml: stand_ins.ros2/rcl: why: is required but missing"),
        (
            {"ros2/rlc": {"use": "@9", "why": "w"}},
            "stand_ins.ros2/rlc: names no repository of this distro .*ros2/rcl",
        ),
        (["ros2/rcl"], "distro.yaml: stand_ins: expected a mapping"),
    ],
)
def test_bad_stand_ins_name_the_file_and_key(stand_ins: Any, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        _stand_in_distro(stand_ins)


def test_jazzy_declares_its_stand_ins_and_keeps_its_jazzy_branches() -> None:
    jazzy = distros.load_distro("jazzy")
    assert {o.key for o in jazzy.stand_ins} == {
        "ament/googletest",
        "ros2/rcl",
        "ros2/rosidl_core",
        "ros2/rosidl_dynamic_typesupport",
        "uros/rclc",
        "uros/rosidl_typesupport",
        "uros/micro_ros_msgs",
        "uros/micro_ros_utilities",
        "uros/rmw_microxrcedds",
        "uros/rosidl_typesupport_microxrcedds",
    }
    assert all(o.reason for o in jazzy.stand_ins)
    # the manifest itself names the real branches: a stand-in is used only on request
    for repo in (*jazzy.dev, *jazzy.mcu):
        assert repo.version == ("ros2" if repo.path.startswith("eProsima/") else "jazzy"), repo
    assert not any(distros.load_distro(name).stand_ins for name in ("humble", "kilted"))
