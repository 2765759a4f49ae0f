"""The one precedence of settings.py: the command line over the workspace's uros.yaml over uros's
defaults, each value saying who chose it (issue 18). Pure: no file is read."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.config.settings import BuildArgs, Chosen, build_settings, pick
from uros_build.sources.wsfiles import WorkspaceConfig

ROOT = Path("/ws")
CFG = WorkspaceConfig(
    distro="humble",
    transport="serial",
    set=("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2",),
    packages=("std_msgs",),
    idf_build="idf/build",
    cache="file:///team",
)


@pytest.mark.parametrize(
    ("args", "cfg", "expected"),
    [
        # nothing said anywhere: the defaults
        (BuildArgs(), None, {"transport": Chosen(None, "default"), "packages": Chosen((), "default"),
                             "cache": Chosen(None, "default"), "idf_build": Chosen(None, "default")}),
        # uros.yaml only
        (BuildArgs(), CFG, {"transport": Chosen("serial", "/ws/uros.yaml: transport"),
                            "packages": Chosen(("std_msgs",), "/ws/uros.yaml: packages"),
                            "cache": Chosen("file:///team", "/ws/uros.yaml: cache"),
                            "idf_build": Chosen(Path("/ws/idf/build"), "/ws/uros.yaml: idf_build")}),
        # the command line wins over uros.yaml
        (BuildArgs(transport="udp", packages=("nav_msgs",), cache="none", idf_build=Path("/b")), CFG,
         {"transport": Chosen("udp", "--transport"), "packages": Chosen(("nav_msgs",), "--packages"),
          "cache": Chosen("none", "--cache"), "idf_build": Chosen(Path("/b"), "--idf-build")}),
        # --for-firmware reads the firmware: uros.yaml's packages: do not add to it
        (BuildArgs(for_firmware=Path("/app")), CFG, {"packages": Chosen((), "default")}),
    ],
)  # fmt: skip
def test_the_command_line_over_uros_yaml_over_defaults(
    args: BuildArgs, cfg: WorkspaceConfig | None, expected: dict[str, Chosen[object]]
) -> None:
    settings = build_settings(args, cfg, ROOT)
    for name, value in expected.items():
        assert getattr(settings, name) == value, name


def test_sets_add_up_uros_yaml_first() -> None:
    """--set does not replace uros.yaml's set: list; it comes after it, so that it wins per option."""
    settings = build_settings(BuildArgs(sets=("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=3",)), CFG, ROOT)
    assert settings.sets == (
        "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2",
        "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=3",
    )


def test_pick_takes_an_empty_value_as_given() -> None:
    assert pick("", "--cache", "file:///x", "uros.yaml: cache", None) == Chosen("", "--cache")
    assert pick(None, "--cache", None, "uros.yaml: cache", "d") == Chosen("d", "default")
