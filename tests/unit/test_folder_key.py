"""The one name → folder-key rule (plan.folder_key): what `uros build` names .uros/targets/<key> and
build/<key> for a target, and what clean, info, size and probe look for, from the same name."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.config.buildargs import BuildArgs
from uros_build.config.outputs import resolve_output
from uros_build.config.plan import plan_build
from uros_build.config.targets import folder_key, named_keys, resolve_target
from uros_build.errors import ConfigError
from uros_build.output.folders import write_marker
from uros_build.sources.workspace import Workspace
from uros_build.target.profiles import shipped_profiles

PROFILE = """\
name: my-board
description: a board of mine
compiler_prefix: arm-none-eabi-
system_processor: arm
cpu_flags: [-mcpu=cortex-m4, -mthumb]
elf: {machine: ARM}
"""


@pytest.mark.parametrize(
    ("name", "key"),
    [
        ("cortex-m7", "cortex-m7"),
        ("my-board.cmake", "my-board"),
        ("boards/my board (v2).cmake", "my_board__v2_"),
        ("/abs/path/to/toolchain.cmake", "toolchain"),
        ("boards/toolchain", "toolchain"),  # a path without .cmake is a toolchain file too
        ("gone/missing.yaml", "missing"),  # a profile file no longer there: its file name
    ],
)
def test_the_name_to_folder_key_rule(name: str, key: str) -> None:
    assert folder_key(name) == key


def test_a_profile_file_is_its_name_not_its_file_name(tmp_path: Path) -> None:
    (tmp_path / "board.yaml").write_text(PROFILE, encoding="utf-8")
    assert folder_key(str(tmp_path / "board.yaml")) == "my-board"
    assert folder_key("board.yaml", "uros.yaml: target", base=tmp_path) == "my-board"
    # --profile takes a file of any name
    (tmp_path / "board.profile").write_text(PROFILE, encoding="utf-8")
    assert folder_key(str(tmp_path / "board.profile"), "--profile", profile=True) == "my-board"
    assert resolve_target(None, tmp_path / "board.profile").key == "my-board"
    # a .yaml target (--toolchain, uros.yaml's target:) is a profile file: the plan agrees
    assert resolve_target(str(tmp_path / "board.yaml"), None).key == "my-board"


def test_a_name_that_cannot_be_a_folder_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"--toolchain \.hidden\.cmake: '\.hidden' cannot name"):
        folder_key(".hidden.cmake")


def test_the_plan_gives_every_target_the_key_the_rule_gives_its_name(tmp_path: Path) -> None:
    for name in shipped_profiles():
        assert resolve_target(name, None).key == folder_key(name)
    for name in ("my-board.cmake", "my board (v2).cmake", "toolchain"):
        (tmp_path / name).write_text("set(CMAKE_SYSTEM_NAME Generic)\n", encoding="utf-8")
        path = str(tmp_path / name)
        assert resolve_target(path, None).key == folder_key(path)


def _ws(tmp_path: Path, config: str) -> Path:
    ws = tmp_path / "ws"
    (ws / "pkg").mkdir(parents=True)
    (ws / "pkg" / "package.xml").write_text("<package><name>pkg</name></package>", encoding="utf-8")
    (ws / "uros.yaml").write_text(config, encoding="utf-8")
    return ws


def test_uros_yaml_s_toolchain_file_is_found_from_the_workspace(tmp_path: Path) -> None:
    ws = _ws(tmp_path, "distro: humble\ntargets: [cortex-m7, boards/my-board.cmake]\n")
    (ws / "boards").mkdir()
    (ws / "boards" / "my-board.cmake").write_text("set(CMAKE_SYSTEM_NAME Generic)\n", encoding="utf-8")
    keys = named_keys(Workspace(ws), None, {})
    assert keys == [("cortex-m7", "cortex-m7"), ("boards/my-board.cmake", "my-board")]
    assert named_keys(Workspace(ws), "other/x.cmake", {}) == [("other/x.cmake", "x")]
    one = BuildArgs(
        workspace=ws, toolchain="boards/my-board.cmake", toolchain_from=f"{ws}/uros.yaml: targets"
    )
    assert plan_build(one, {}).target.key == "my-board"


def test_resolve_output_finds_the_output_of_a_toolchain_file(tmp_path: Path) -> None:
    ws = _ws(tmp_path, "distro: humble\ntarget: boards/my-board.cmake\n")
    output = ws / "build" / "my-board"
    output.mkdir(parents=True)
    write_marker(output, "my-board", ["libmicroros.a"])
    assert resolve_output(None, ws, None, {}) == Workspace(ws.resolve()).default_output("my-board")
    assert resolve_output(None, ws, "path/to/my-board.cmake", {}).name == "my-board"


def test_clean_chooses_by_the_same_rule(tmp_path: Path) -> None:
    from uros_build.commands.clean import _chosen

    ws = _ws(tmp_path, "distro: humble\ntargets: [cortex-m7, boards/my-board.cmake]\n")
    for key in ("cortex-m7", "my-board"):
        (ws / ".uros" / "targets" / key).mkdir(parents=True)
    workspace = Workspace(ws)
    assert _chosen(workspace, None, False) == ["cortex-m7", "my-board"]  # uros.yaml's, as build's
    assert _chosen(workspace, "elsewhere/my-board.cmake", False) == ["my-board"]
    (tmp_path / "board.yaml").write_text(PROFILE, encoding="utf-8")
    assert _chosen(workspace, None, False, tmp_path / "board.yaml") == ["my-board"]
    with pytest.raises(ConfigError, match=r"--profile .*missing\.yaml: no such file"):
        _chosen(workspace, None, False, tmp_path / "missing.yaml")
    with pytest.raises(ConfigError, match="--toolchain and --profile name a target twice"):
        _chosen(workspace, "cortex-m7", False, tmp_path / "board.yaml")
    with pytest.raises(ConfigError, match=r"--toolchain x/cortex-m4\.cmake: nothing of it .*did you mean"):
        _chosen(workspace, "x/cortex-m4.cmake", False)


def test_clean_finds_a_profile_named_in_uros_yaml(tmp_path: Path) -> None:
    from uros_build.commands.clean import _chosen

    ws = _ws(tmp_path, "targets: [boards/board.yaml]\n")
    (ws / "boards").mkdir()
    (ws / "boards" / "board.yaml").write_text(PROFILE, encoding="utf-8")
    (ws / ".uros" / "targets" / "my-board").mkdir(parents=True)
    assert _chosen(Workspace(ws), None, False) == ["my-board"]
    args = BuildArgs(workspace=ws, toolchain="boards/board.yaml", toolchain_from=f"{ws}/uros.yaml: targets")
    assert plan_build(args, {}).target.key == "my-board"
