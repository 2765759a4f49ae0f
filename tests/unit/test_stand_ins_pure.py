"""Declared stand-ins (issue 33 item 5): a repository cloned from another branch, tag or fork than
the manifest's is chosen on request, printed with its reason, recorded in uros.yaml and uros.lock and
listed by `uros distros` (pure: plans, parsing and display; the jazzy build is
tests/integration/test_jazzy.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from uros_build.cli import cli
from uros_build.config.sourceplan import CreateArgs, plan_create, stand_in_report
from uros_build.errors import ConfigError
from uros_build.sources.wsfiles import Lock, parse_lock

MIRROR = "https://github.com/{owner}/{repo}=https://git.example/{owner}+{repo}"


def test_stand_ins_are_applied_only_on_request(tmp_path: Path) -> None:
    plain = plan_create(CreateArgs(directory=tmp_path / "fw", distro="jazzy"))
    assert plain.sources["mcu_ws/ros2/rcl"].version == "jazzy"
    assert not any(s.stand_in for s in plain.sources.values())
    plan = plan_create(CreateArgs(directory=tmp_path / "fw", distro="jazzy", stand_ins=True))
    rcl = plan.sources["mcu_ws/ros2/rcl"]
    assert rcl.version == "9.2.0" and rcl.stand_in is not None and "no jazzy branch" in rcl.stand_in.reason
    assert plan.sources["mcu_ws/uros/rmw_microxrcedds"].version == "rolling"
    assert plan.sources["mcu_ws/ros2/rmw"].stand_in is None  # the mirror has jazzy: the real branch
    assert sum(1 for s in plan.sources.values() if s.stand_in) == 10


def test_the_users_own_override_wins_over_a_declared_stand_in(tmp_path: Path) -> None:
    args = CreateArgs(
        directory=tmp_path / "fw",
        distro="jazzy",
        stand_ins=True,
        mirrors=(MIRROR,),
        overrides=("uros/rclc=@7.0.0",),
    )
    plan = plan_create(args)
    assert plan.sources["mcu_ws/uros/rclc"].version == "7.0.0"
    assert [o.use for o in plan.mirror.overrides if o.key in ("uros/rclc", "ros2/rclc")] == ["@7.0.0"]
    # the declared fork is named by its GitHub URL and cloned from the mirror
    assert (
        plan.sources["mcu_ws/uros/rosidl_typesupport"].url
        == "https://git.example/fictionlab+rosidl_typesupport"
    )
    lines, unused = stand_in_report(plan.distro, plan.mirror, plan.sources)
    assert (
        "mcu_ws/uros/rclc: 7.0.0 from https://git.example/ros2+rclc instead of jazzy (no reason given"
        in "\n".join(lines)
    )
    assert (
        "mcu_ws/ros2/rcl: 9.2.0 from https://git.example/ros2+rcl instead of jazzy (no jazzy branch in the mirror; "
        "tag 9.2.0" in "\n".join(lines)
    )
    assert unused == []


def test_a_mistyped_override_is_reported_not_silently_ignored(tmp_path: Path) -> None:
    plan = plan_create(CreateArgs(directory=tmp_path / "fw", distro="jazzy", overrides=("uros/rlcc=@6.1.0",)))
    lines, unused = stand_in_report(plan.distro, plan.mirror, plan.sources)
    assert lines == []
    assert unused == ["mirror override uros/rlcc=@6.1.0 names no repository of jazzy: it changes nothing"]


def test_stand_ins_flag_on_a_distro_without_any(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--stand-ins: the humble manifest declares no stand-ins"):
        plan_create(CreateArgs(directory=tmp_path / "fw", distro="humble", stand_ins=True))
    assert not (tmp_path / "fw").exists()


def test_lock_records_each_stand_in_and_reads_it_back(tmp_path: Path) -> None:
    plan = plan_create(
        CreateArgs(directory=tmp_path / "fw", distro="jazzy", stand_ins=True, mirrors=(MIRROR,))
    )
    commits = {p: f"{i:040x}" for i, p in enumerate(plan.sources)}
    lock = Lock.from_clones("jazzy", plan.sources, commits)
    data = json.loads(lock.to_json())
    rcl = data["repositories"]["mcu_ws/ros2/rcl"]
    assert rcl["version"] == "jazzy" and rcl["stand_in"]["use"] == "9.2.0"
    assert rcl["stand_in"]["why"].startswith("no jazzy branch in the mirror")
    assert "stand_in" not in data["repositories"]["mcu_ws/ros2/rmw"]
    fork = data["repositories"]["mcu_ws/uros/rosidl_typesupport"]
    assert fork["stand_in"]["use"] == "fictionlab/rosidl_typesupport@jazzy"
    assert fork["source"] == "https://git.example/fictionlab+rosidl_typesupport"
    assert parse_lock(data, "uros.lock") == lock


def test_uros_yaml_keeps_the_reasons(tmp_path: Path) -> None:
    import yaml

    from uros_build.sources.wsfiles import WorkspaceConfig, config_text, parse_config

    plan = plan_create(CreateArgs(directory=tmp_path / "fw", distro="jazzy", stand_ins=True))
    text = config_text(WorkspaceConfig("jazzy", mirror=plan.mirror))
    back = parse_config(yaml.safe_load(text), "uros.yaml")
    assert sorted(back.mirror.overrides, key=lambda o: o.key) == sorted(
        plan.mirror.overrides, key=lambda o: o.key
    )
    assert yaml.safe_load(text)["mirror"]["overrides"]["ros2/rcl"]["use"] == "@9.2.0"


def test_distros_lists_and_shows_stand_ins() -> None:
    runner = CliRunner()
    lines = runner.invoke(cli, ["distros"]).output.splitlines()
    jazzy = next(line.split() for line in lines if line.startswith("jazzy "))
    assert jazzy[-1] == "10"
    rows = json.loads(runner.invoke(cli, ["distros", "--json"]).output)
    declared = {r["name"]: r["stand_ins"] for r in rows}
    assert declared["humble"] == [] and len(declared["jazzy"]) == 10
    shown = runner.invoke(cli, ["distros", "show", "jazzy"])
    assert shown.exit_code == 0
    rcl = next(line for line in shown.output.splitlines() if line.startswith("mcu_ws/ros2/rcl "))
    assert rcl.split()[1:3] == ["jazzy", "@9.2.0"] and "no jazzy branch in the mirror" in rcl
    rows = json.loads(runner.invoke(cli, ["distros", "show", "jazzy", "--json"]).output)
    assert {r["path"] for r in rows if r["stand_in"] != "-"} >= {"mcu_ws/uros/rosidl_typesupport"}
    bad = runner.invoke(cli, ["distros", "show", "jazy"])
    assert isinstance(bad.exception, ConfigError)
    assert bad.exception.message == "NAME: unknown distro 'jazy' (did you mean jazzy?)"


def test_uros_info_names_the_packages_built_from_a_stand_in() -> None:
    from uros_build.commands import info

    data = {
        "output": "/o",
        "generated_by": "uros",
        "build_key": None,
        "from_cache": None,
        "ccache": None,
        "target": "cortex-m7",
        "profile": "cortex-m7",
        "toolchain_file": "t.cmake",
        "compiler": None,
        "flags": {"cpu": [], "c": [], "optimization": "", "micro_ros_only": []},
        "library": {"file": "libmicroros.a", "bytes": 1, "members": 1, "size": None},
        "include": {"dir": "include", "files": 1},
        "transport": "custom",
        "rtos": None,
        "options": {},
        "packages": [
            {
                "name": "rclc",
                "repository": "mcu_ws/uros/rclc",
                "commit": "4b8670d" + "0" * 33,
                "stand_in": "6.1.0",
            },
            {"name": "rmw", "repository": "mcu_ws/ros2/rmw", "commit": "a" * 40, "stand_in": None},
        ],
        "types": [],
    }
    text = info.render(data)
    assert "  rclc  mcu_ws/uros/rclc @ 4b8670d00000 (stand-in: 6.1.0, not the manifest's branch)\n" in text
    assert "  rmw   mcu_ws/ros2/rmw @ aaaaaaaaaaaa\n" in text
