"""`uros update` on real git repositories served from file paths: clones move to the newest commits of
their branches (or another distro's) without re-cloning, the lock follows, and nothing the user wrote
changes. Nothing moves when a clone holds the user's work or a fetch fails."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from uros_helpers import git_commit, git_out, run_uros, run_uros_here, upstream_mirror

pytestmark = pytest.mark.integration

_USER_YAML_LINE = "# my note: we build for the H7 board\n"


def _workspace(upstream: Path, fw: Path) -> Path:
    run_uros(
        "create-firmware", "--distro", "humble", "-w", str(fw), "--no-dev-build", *upstream_mirror(upstream)
    )
    return _users_config(fw)


def _users_config(fw: Path) -> Path:
    """The user's own lines in the uros.yaml of ``fw``, a workspace create-firmware made for humble."""
    config = fw / "uros.yaml"
    config.write_text(
        _USER_YAML_LINE + config.read_text().replace("distro: humble", "distro: humble  # pinned")
    )
    return fw


def _heads(fw: Path) -> dict[str, str]:
    lock = json.loads((fw / "uros.lock").read_text())
    return {path: git_out("rev-parse", "HEAD", cwd=fw / path) for path in lock["repositories"]}


def test_update_moves_only_what_moved_and_writes_the_lock(upstream: Path, tmp_path: Path) -> None:
    fw = _workspace(upstream, tmp_path / "fw")
    before = json.loads((fw / "uros.lock").read_text())
    heads = _heads(fw)
    (fw / "mcu_ws/notes.txt").write_text("mine\n")
    rcl_upstream = upstream / "micro-ROS+rcl"
    git_out("checkout", "-q", "humble", cwd=rcl_upstream)
    git_commit(rcl_upstream, "fix one")
    new = git_commit(rcl_upstream, "fix two")

    dry = run_uros("update", "-w", str(fw), "--dry-run")
    old = before["repositories"]["mcu_ws/uros/rcl"]["commit"]
    assert f"mcu_ws/uros/rcl: {old[:12]} -> {new[:12]} (+2 commits)" in dry.stderr
    assert "1 of 32 repositories would change" in dry.stderr
    assert json.loads((fw / "uros.lock").read_text()) == before and _heads(fw) == heads

    done = run_uros("update", "-w", str(fw))
    assert "updated 1 of 32 repositories" in done.stderr
    after = json.loads((fw / "uros.lock").read_text())
    assert after["repositories"]["mcu_ws/uros/rcl"]["commit"] == new
    assert after["generated_by"].endswith(" update") and after["distro"] == "humble"
    moved = _heads(fw)
    assert moved["mcu_ws/uros/rcl"] == new
    assert {p: c for p, c in moved.items() if p != "mcu_ws/uros/rcl"} == {
        p: c for p, c in heads.items() if p != "mcu_ws/uros/rcl"
    }
    # the user's files are as they were
    assert (fw / "mcu_ws/notes.txt").read_text() == "mine\n"
    assert (fw / "uros.yaml").read_text().startswith(_USER_YAML_LINE)

    again = run_uros("update", "-w", str(fw))
    assert "nothing changed" in again.stderr
    # a `uros build --locked`-style re-creation reproduces the updated lock
    assert json.loads((fw / "uros.lock").read_text())["repositories"] == after["repositories"]


def test_update_refuses_a_clone_with_the_users_work(upstream: Path, tmp_path: Path) -> None:
    fw = _workspace(upstream, tmp_path / "fw")
    before = (fw / "uros.lock").read_text()
    (fw / "mcu_ws/uros/rclc/README").write_text("my edit\n")
    git_commit(upstream / "ros2+rclc", "upstream moves")
    proc = run_uros("update", "-w", str(fw), check=False)
    assert proc.returncode == 2, proc.stderr
    assert "mcu_ws/uros/rclc has 1 changed file(s)" in proc.stderr
    assert (fw / "uros.lock").read_text() == before
    assert (fw / "mcu_ws/uros/rclc/README").read_text() == "my edit\n"


def test_a_failed_fetch_changes_nothing(upstream: Path, tmp_path: Path) -> None:
    fw = _workspace(upstream, tmp_path / "fw")
    before, heads = (fw / "uros.lock").read_text(), _heads(fw)
    rmw = upstream / "ros2+rmw"
    git_out("checkout", "-q", "--detach", cwd=rmw)
    git_out("branch", "-m", "humble", "gone", cwd=rmw)  # the branch the workspace follows is deleted
    try:
        git_commit(upstream / "micro-ROS+rcutils", "moves on")
        proc = run_uros("update", "-w", str(fw), check=False)
    finally:
        git_out("branch", "-m", "gone", "humble", cwd=rmw)
    assert proc.returncode == 4, proc.stderr
    line = next(x for x in proc.stderr.splitlines() if x.startswith("error:"))
    assert "fetching mcu_ws/ros2/rmw" in line
    assert "nothing was changed" in proc.stderr
    assert (fw / "uros.lock").read_text() == before and _heads(fw) == heads


def test_update_to_another_distro_keeps_the_users_config(created: Path) -> None:
    fw = _users_config(created)  # create-firmware's workspace, made once per worker (conftest): a copy
    proc = run_uros("update", "-w", str(fw), "--distro", "iron")
    lock = json.loads((fw / "uros.lock").read_text())
    assert lock["distro"] == "iron" and len(lock["repositories"]) == 34
    assert (
        "mcu_ws/uros/tracetools" not in lock["repositories"] and not (fw / "mcu_ws/uros/tracetools").exists()
    )
    assert (fw / "mcu_ws/ros2/rosidl_core/README").is_file()
    assert "mcu_ws/ros2/rosidl_core: new clone" in proc.stderr
    assert "mcu_ws/uros/tracetools: removed" in proc.stderr
    for path, entry in lock["repositories"].items():
        assert git_out("rev-parse", "HEAD", cwd=fw / path) == entry["commit"]
        if not path.startswith("mcu_ws/eProsima"):
            assert entry["version"] == "iron", path
    text = (fw / "uros.yaml").read_text()
    assert text.startswith(_USER_YAML_LINE) and "distro: iron  # pinned" in text
    assert yaml.safe_load(text)["distro"] == "iron"
    # the humble-only ignore marker went with its clone; iron's are written
    assert (fw / "mcu_ws/ros2/rcl/COLCON_IGNORE").is_file()


def test_update_outside_a_workspace_is_one_line(tmp_path: Path) -> None:
    proc = run_uros_here("update", "-w", str(tmp_path), check=False)
    assert proc.returncode == 2
    assert f"--workspace {tmp_path}: not a firmware workspace (no uros.yaml)" in proc.stderr


def test_a_colcon_ignore_the_repository_starts_tracking_is_no_obstacle(
    upstream: Path, tmp_path: Path
) -> None:
    """micro-ROS/rcl tracks rcl_yaml_param_parser/COLCON_IGNORE on some branches, where humble's
    table asks uros to ignore that folder: uros's own untracked marker must neither block the
    checkout nor count as the user's change."""
    fw = _workspace(upstream, tmp_path / "fw")
    rcl = upstream / "micro-ROS+rcl"
    (rcl / "rcl_yaml_param_parser").mkdir()
    (rcl / "rcl_yaml_param_parser/package.xml").write_text("<package/>\n")
    git_commit(rcl, "the folder appears")
    run_uros("update", "-w", str(fw))
    marker = fw / "mcu_ws/uros/rcl/rcl_yaml_param_parser/COLCON_IGNORE"
    assert marker.read_text().startswith("uros:")  # uros's marker, untracked
    (rcl / "rcl_yaml_param_parser/COLCON_IGNORE").write_text("")
    tracked = git_commit(rcl, "the repository ignores it itself")
    run_uros("update", "-w", str(fw))
    assert git_out("rev-parse", "HEAD", cwd=fw / "mcu_ws/uros/rcl") == tracked
    assert marker.read_text() == ""  # the repository's file, not rewritten
    git_commit(rcl, "and moves on")
    run_uros("update", "-w", str(fw))  # not "1 changed file"
    assert git_out("status", "--porcelain", cwd=fw / "mcu_ws/uros/rcl") == ""


def test_before_a_day_with_no_commits_changes_nothing(created: Path) -> None:
    fw = _users_config(created)  # create-firmware's workspace, made once per worker (conftest): a copy
    before = (fw / "uros.lock").read_text()
    proc = run_uros("update", "-w", str(fw), "--before", "2001-01-01", check=False)
    assert proc.returncode == 2, proc.stderr
    assert "has no commit before that day" in proc.stderr and "nothing was changed" in proc.stderr
    assert (fw / "uros.lock").read_text() == before
    bad = run_uros_here("update", "-w", str(fw), "--before", "2024-13-01", check=False)
    assert bad.returncode == 2 and "--before '2024-13-01': not a day" in bad.stderr
    late = run_uros_here("update", "-w", str(fw), "--before", "2100-01-01", check=False)
    assert late.returncode == 2 and "outside the years git reads (1970-2099)" in late.stderr
    # a day after every commit is the newest commits
    assert "nothing changed" in run_uros("update", "-w", str(fw), "--before", "2099-12-31").stderr
