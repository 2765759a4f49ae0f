"""meta/options.yaml: the known memory/entity options, and --set checked against them."""

from __future__ import annotations

import pytest

from uros_build.errors import ConfigError
from uros_build.sources import options


def _known() -> dict[str, dict[str, options.KnownOption]]:
    return options.by_package(options.known_options())


def test_the_shipped_options_load() -> None:
    known = _known()
    rmw = known["rmw_microxrcedds"]
    for name in ("RMW_UXRCE_MAX_NODES", "RMW_UXRCE_MAX_PUBLISHERS", "RMW_UXRCE_MAX_SUBSCRIPTIONS",
                 "RMW_UXRCE_MAX_SERVICES", "RMW_UXRCE_MAX_CLIENTS", "RMW_UXRCE_MAX_HISTORY",
                 "RMW_UXRCE_STREAM_HISTORY", "RMW_UXRCE_STREAM_HISTORY_INPUT", "RMW_UXRCE_STREAM_HISTORY_OUTPUT"):  # fmt: skip
        assert rmw[name].cost, name
    assert rmw["RMW_UXRCE_MAX_HISTORY"].default == "8" and rmw["RMW_UXRCE_STREAM_HISTORY"].power_of_two
    assert known["microxrcedds_client"]["UCLIENT_UDP_TRANSPORT_MTU"].default == "512"


def test_unknown_option_of_a_known_package_is_a_warning_with_the_closest() -> None:
    warnings = options.check_sets(
        ["rmw_microxrcedds.RMW_UXRCE_MAX_NODE=2", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2", "rcl.ANYTHING=1"],
        _known(),
    )
    assert len(warnings) == 1 and "did you mean RMW_UXRCE_MAX_NODES" in warnings[0]


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=two", "must be a whole number"),
        ("rmw_microxrcedds.RMW_UXRCE_STREAM_HISTORY=3", "must be a power of two"),
        ("rmw_microxrcedds.RMW_UXRCE_TRANSPORT=can", "must be one of udp, tcp, serial, custom"),
        ("microxrcedds_client.UCLIENT_PROFILE_DISCOVERY=maybe", "must be ON or OFF"),
        # round 3 (issue 34, 7): accepted, and compiled into a negative pool size or a C error
        (
            "rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=-1",
            r"RMW_UXRCE_MAX_PUBLISHERS must be 0 or more, got -1$",
        ),
        # round 5 (issue 43): ranges from meta/options.yaml, and no number of thousands of digits
        (
            "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=0",
            r"RMW_UXRCE_MAX_NODES must be 1 or more, got 0: a micro-ROS",
        ),
        (
            "microxrcedds_client.UCLIENT_CUSTOM_TRANSPORT_MTU=0",
            r"must be 28 or more, got 0: the client's first",
        ),
        ("microxrcedds_client.UCLIENT_UDP_TRANSPORT_MTU=65536", r"must be 65535 or less, got 65536"),
        (
            "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=" + "9" * 5000,
            r"\.\.\. \(5,0\d\d characters\): .* 5,000 digits$",
        ),
        ("rmw_microxrcedds.RMW_UXRCE_MAX_TOPICS=-2", r"RMW_UXRCE_MAX_TOPICS must be -1 or more, got -2$"),
        (
            "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=1_000",
            r"must be a whole number \(0 or more\), got '1_000'",
        ),
        ("rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=+4", r"must be a whole number \(0 or more\), got '\+4'"),
        (
            "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=FOO BAR",
            r"must be a whole number \(0 or more\), got 'FOO BAR'",
        ),
        ("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=\u0664", r"must be a whole number"),  # an Arabic-Indic 4
        ("rmw_microxrcedds.FOO BAR=1", r"'FOO BAR' is not a CMake option name"),
        ("rmw microxrcedds.X=1", r"'rmw microxrcedds' is not a package name"),
        ("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=4 ", r"starts or ends with a space"),
        ("fx.NAME=a\nb", r"holds a line break"),
    ],
)
def test_clearly_wrong_values_are_errors(item: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        options.check_sets([item], _known())


def test_a_broken_options_file_is_one_line() -> None:
    with pytest.raises(ConfigError, match=r"packages.p.X: default: must be a string"):
        options.parse_options({"packages": {"p": {"X": {"default": 4, "cost": "c"}}}}, "options.yaml")
    with pytest.raises(ConfigError, match=r"packages.p.X: colour: unknown key"):
        options.parse_options(
            {"packages": {"p": {"X": {"default": "4", "cost": "c", "colour": 1}}}}, "options.yaml"
        )
    with pytest.raises(ConfigError, match=r"default '3' must be a power of two"):
        options.parse_options(
            {"packages": {"p": {"X": {"default": "3", "cost": "c", "type": "int", "power_of_two": True}}}},
            "o.yaml",
        )


def test_a_set_from_uros_yaml_is_named_so() -> None:
    """Round 3 (issue 34, 7): uros.yaml's set: entries were blamed on a --set the user never typed."""
    item = "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=many"
    with pytest.raises(ConfigError) as info:
        options.check_sets([item], _known(), {item: "/w/uros.yaml: set:"})
    assert info.value.message.startswith(f"/w/uros.yaml: set: {item}: RMW_UXRCE_MAX_NODES must be")
    typo = "rmw_microxrcedds.RMW_UXRCE_MAX_NODE=2"
    assert options.check_sets([typo], _known(), {typo: "/w/uros.yaml: set:"})[0].startswith(
        f"/w/uros.yaml: set: {typo}: rmw_microxrcedds has no option"
    )
    assert options.check_sets(["rmw_microxrcedds.RMW_UXRCE_MAX_TOPICS=-1", "fx.NAME=a b"], _known()) == []
