"""The one precedence of settings.py: the command line over the environment over the workspace's
uros.yaml over uros's defaults, each value saying who chose it (issues 18 and 30). Pure: no file
is read."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest

from uros_build.config import settings as rows
from uros_build.config.buildargs import BuildArgs, build_settings, unmatched
from uros_build.config.resolver import Chosen, resolve_one
from uros_build.config.settings import SETTINGS, Setting
from uros_build.errors import ConfigError
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
BY_NAME = {s.name: s for s in SETTINGS}


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
        assert settings[BY_NAME[name]] == value, name


def test_sets_add_up_uros_yaml_first() -> None:
    """--set does not replace uros.yaml's set: list; it comes after it, so that it wins per option."""
    settings = build_settings(BuildArgs(sets=("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=3",)), CFG, ROOT)
    assert settings[rows.SETS] == Chosen(
        ("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=3"),
        "/ws/uros.yaml: set, then --set",
    )


def test_an_empty_value_is_given_an_empty_list_is_not() -> None:
    assert build_settings(BuildArgs(cache=""), CFG, ROOT)[rows.CACHE] == Chosen("", "--cache")
    assert build_settings(BuildArgs(packages=()), CFG, ROOT)[rows.PACKAGES].source.endswith("packages")


# a row with all four places, to pin the order between the environment and uros.yaml (no shipped
# row has both today)
BOTH: Setting[str | None] = Setting("transport", "--transport", "transport", rows.ENV, None, "x", "test")


@pytest.mark.parametrize(
    ("flag", "env", "cfg", "expected"),
    [
        ("udp", {"UROS_TRANSPORT": "custom"}, CFG, Chosen("udp", "--transport")),
        (None, {"UROS_TRANSPORT": "custom"}, CFG, Chosen("custom", "$UROS_TRANSPORT")),
        (None, {"UROS_TRANSPORT": ""}, CFG, Chosen("serial", "/ws/uros.yaml: transport")),  # empty: unset
        (None, {}, CFG, Chosen("serial", "/ws/uros.yaml: transport")),
        (None, {}, None, Chosen(None, "default")),
    ],
)
def test_the_command_line_then_the_environment_then_uros_yaml_then_the_default(
    flag: str | None, env: dict[str, str], cfg: WorkspaceConfig | None, expected: Chosen[str | None]
) -> None:
    assert resolve_one(BOTH, {"transport": flag}, cfg, ROOT, env) == expected


@pytest.mark.parametrize("setting", [rows.HOST_STAGE, rows.COMPILER_SEED, rows.GEN_CACHE])
def test_the_environment_switches_take_the_usual_words_and_refuse_the_rest(setting: Setting[bool]) -> None:
    """Round 5 (issue 43): UROS_HOST_STAGE=0 or false and UROS_GEN_CACHE=no were on (only `off` was off)."""
    assert setting.env is not None
    assert build_settings(BuildArgs(), None, ROOT, {})[setting] == Chosen(True, "default")
    for text in ("off", "OFF", " Off ", "0", "false", "False", "no", "NO"):
        assert build_settings(BuildArgs(), None, ROOT, {setting.env: text})[setting] == Chosen(
            False, f"${setting.env}"
        )
    for text in ("on", "1", "true", "YES"):
        assert build_settings(BuildArgs(), None, ROOT, {setting.env: text})[setting].value is True
    for text in ("maybe", "2", "disable", "of"):
        with pytest.raises(ConfigError, match=rf"\${setting.env}='{text}' is no {setting.name} value"):
            build_settings(BuildArgs(), None, ROOT, {setting.env: text})


def test_the_generation_cache_folder_from_the_environment_else_the_xdg_cache() -> None:
    env = {"XDG_CACHE_HOME": "/xdg"}
    assert build_settings(BuildArgs(), None, ROOT, env)[rows.GEN_CACHE_DIR] == Chosen(
        Path("/xdg/uros/gen"), "default"
    )
    given = {**env, "UROS_GEN_CACHE_DIR": "/mine"}
    assert build_settings(BuildArgs(), None, ROOT, given)[rows.GEN_CACHE_DIR] == Chosen(
        Path("/mine"), "$UROS_GEN_CACHE_DIR"
    )


def test_the_target_of_one_build_of_several_names_uros_yaml() -> None:
    cfg = WorkspaceConfig(distro="humble", targets=("cortex-m7", "rp2040"))
    every = build_settings(BuildArgs(), cfg, ROOT)[rows.TARGETS]
    assert every == Chosen(("cortex-m7", "rp2040"), "/ws/uros.yaml: targets")
    one = BuildArgs(toolchain="rp2040", toolchain_from="/ws/uros.yaml: targets")
    assert build_settings(one, cfg, ROOT)[rows.TARGETS] == Chosen(("rp2040",), "/ws/uros.yaml: targets")
    # --profile names the target: uros.yaml's targets do not apply
    assert build_settings(BuildArgs(profile=Path("b.yaml")), cfg, ROOT)[rows.TARGETS].value == ()


def test_every_build_setting_has_one_line_saying_who_chose_it() -> None:
    args = BuildArgs(workspace=ROOT, transport="udp", verbose=True)
    lines = build_settings(args, CFG, ROOT, {"UROS_HOST_STAGE": "off"}).lines()
    assert "transport = udp  (--transport)" in lines
    assert "host_stage = off  ($UROS_HOST_STAGE)" in lines
    assert "cache = file:///team  (/ws/uros.yaml: cache)" in lines
    assert "jobs = colcon's  (default)" in lines
    assert "workspace = /ws  (-w/--workspace)" in lines
    assert "verbose = on  (-v/--verbose)" in lines
    names = [line.split(" = ")[0] for line in lines]
    assert names == [s.name for s in SETTINGS if "build" in s.commands]


def test_the_table_is_one_row_a_name_and_every_build_argument_is_a_row() -> None:
    names = [s.name for s in SETTINGS]
    assert len(names) == len(set(names))
    flags = set(BuildArgs().flags())
    assert flags - set(names) == {"toolchain", "toolchain_from"}  # the targets row's parts
    for setting in SETTINGS:
        assert setting.flag or setting.env, setting.name  # every setting can be given somewhere
        assert setting.meaning and setting.default_text, setting.name


@pytest.mark.parametrize(("text", "seconds"), [("2", 2.0), (" 0.5 ", 0.5), ("86399", 86399.0)])
def test_the_team_cache_wait_from_the_environment(text: str, seconds: float) -> None:
    chosen = build_settings(BuildArgs(), None, ROOT, {"UROS_CACHE_TIMEOUT": text})[rows.CACHE_TIMEOUT]
    assert chosen == Chosen(seconds, "$UROS_CACHE_TIMEOUT")


@pytest.mark.parametrize("text", ["soon", "0", "-1", "86400", "nan", "inf", "1e999"])
def test_a_team_cache_wait_that_is_none_is_refused_not_made_60_s(text: str) -> None:
    """Round 5 (issue 43): UROS_CACHE_TIMEOUT=abc, -1 or 0 silently became 60 s."""
    with pytest.raises(ConfigError, match=rf"\$UROS_CACHE_TIMEOUT='{text}' is no cache_timeout value") as err:
        build_settings(BuildArgs(), None, ROOT, {"UROS_CACHE_TIMEOUT": text})
    assert "more than 0 and less than 86400" in str(err.value.hint)


def test_the_distro_is_uros_yaml_s_and_none_without_a_line() -> None:
    assert resolve_one(rows.DISTRO, {}, CFG, ROOT, {}) == Chosen("humble", "/ws/uros.yaml: distro")
    no_line = WorkspaceConfig(target="cortex-m7")  # a plain colcon workspace's uros.yaml
    assert resolve_one(rows.DISTRO, {}, no_line, ROOT, {}) == Chosen(None, "default")
    assert resolve_one(rows.DISTRO, {"distro": "jazzy"}, CFG, ROOT, {}) == Chosen("jazzy", "--distro")


def test_a_build_option_missing_from_the_table_or_from_buildargs_is_named() -> None:
    """`uros build`'s options are made from the rows (issue 38 item 4): a BuildArgs field without a
    row, or a row with an option and no field, is refused when config/buildargs.py is imported."""
    assert (
        unmatched(tuple(f.name for f in fields(BuildArgs) if f.name not in BuildArgs.DERIVED), SETTINGS) == []
    )
    row = Setting(
        "shiny", "--shiny", None, None, False, "off", "a new switch", option=rows.CommandLine(kind="flag")
    )
    assert unmatched(("jobs", "shiny_typo"), (rows.JOBS, row)) == [
        "BuildArgs.shiny_typo has no row with an option in config/settings.py",
        "setting shiny has an option but no BuildArgs field",
    ]


def test_a_row_s_environment_variable_is_derived_from_its_name() -> None:
    assert rows.HOST_STAGE.env == "UROS_HOST_STAGE"
    assert (
        Setting("new_thing", None, None, rows.ENV, None, "none", "x", commands=("probe",)).env
        == "UROS_NEW_THING"
    )
    with pytest.raises(TypeError, match="UROS_NEW_THING"):
        Setting("new_thing", None, None, "UROS_OTHER", None, "none", "x")
    with pytest.raises(TypeError, match="needs a flag"):
        Setting("new_thing", None, None, None, None, "none", "x", option=rows.CommandLine())


def test_an_option_s_help_is_its_meaning_as_a_sentence_unless_it_says_more() -> None:
    assert rows.FORCE.help == "Write into an --output folder holding other files (kept)."
    assert rows.WORKSPACE.help == "The firmware workspace."
