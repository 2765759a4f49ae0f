"""The JSON Schemas shipped in meta/schemas/ (for editors) agree with the code that loads the files."""

from __future__ import annotations

import json
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml
from profile_data import minimal_profile

from uros_build import resources
from uros_build.errors import ConfigError
from uros_build.sources import distros, wsfiles
from uros_build.target.profiles import Chip, ElfFacts, MicroRosFlags, TargetProfile, parse_profile


def _schema(name: str) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((resources.meta_dir() / "schemas" / name).read_text(encoding="utf-8"))
    return data


def _validator(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(_schema(name))


def _errors(name: str, data: Any) -> list[str]:
    return [e.message for e in _validator(name).iter_errors(data)]


def _shipped_profiles() -> list[Path]:
    return sorted(resources.toolchains_dir().glob("*.yaml"))


@pytest.mark.parametrize("name", ["profile.schema.json", "uros.schema.json"])
def test_schemas_are_draft_2020_12(name: str) -> None:
    schema = _schema(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)


@pytest.mark.parametrize("path", _shipped_profiles(), ids=lambda p: p.stem)
def test_every_shipped_profile_validates(path: Path) -> None:
    assert _errors("profile.schema.json", yaml.safe_load(path.read_text(encoding="utf-8"))) == []


def test_there_are_shipped_profiles() -> None:
    assert len(_shipped_profiles()) >= 10


# Python annotation of a dataclass field -> what its schema property must say.
_TYPES = {
    "str": "string",
    "int": "integer",
    "bool": "boolean",
    "tuple[str, ...]": "array",
    "tuple[tuple[str, str], ...]": "object",
}


@pytest.mark.parametrize(
    ("cls", "pointer"),
    [
        (TargetProfile, ()),
        (MicroRosFlags, ("$defs", "MicroRosFlags")),
        (ElfFacts, ("$defs", "ElfFacts")),
        (Chip, ("$defs", "Chip")),
    ],
    ids=["TargetProfile", "MicroRosFlags", "ElfFacts", "Chip"],
)
def test_profile_schema_equals_the_dataclasses(cls: Any, pointer: tuple[str, ...]) -> None:
    node = _schema("profile.schema.json")
    for part in pointer:
        node = node[part]
    # "source" is where a profile was loaded from, set by the loader, never written in a file
    names = [f for f in fields(cls) if f.name != "source"]
    assert set(node["properties"]) == {f.name for f in names}
    required = {f.name for f in names if f.default is MISSING and f.default_factory is MISSING}
    assert set(node.get("required", [])) == required
    assert node["additionalProperties"] is False
    for f in names:
        prop = node["properties"][f.name]
        assert prop.get("description") or "$ref" in prop, f.name
        annotation = str(f.type)
        if annotation in _TYPES:
            assert prop["type"] == _TYPES[annotation], f.name
        else:
            assert prop == {"$ref": f"#/$defs/{annotation}"}, f.name


def test_profile_with_an_unknown_key_fails_the_schema() -> None:
    data = {**minimal_profile(), "cpu_flag": ["-mthumb"]}
    assert any("'cpu_flag' was unexpected" in e for e in _errors("profile.schema.json", data))
    nested = {**minimal_profile(), "elf": {"machine": "ARM", "flags": []}}
    assert any("'flags' was unexpected" in e for e in _errors("profile.schema.json", nested))
    with pytest.raises(ConfigError, match="cpu_flag: unknown key"):  # the loader agrees
        parse_profile(data, "board.yaml")


@pytest.mark.parametrize(
    "change",
    [
        {"cpu_flags": "-mcpu=cortex-m4"},
        {"transport": "can"},
        {"optimization": "fast"},
        {"native_64bit_atomics": "yes"},
        {"c_standard": True},
        {"description": ""},
        {"compiler_prefix": "arm-none-eabi"},
        {"libc_flags": [""]},
        {"c_flags": ["-DA=1\n-DB"]},
        {"elf": {"machine": "ARM", "xtensa_abi": "2"}},
        {"elf": {"machine": "ARM", "attributes": {"Tag_CPU_arch": 7}}},
        {"micro_ros": {"declare_clock_gettime": "yes"}},
        {"elf": {}},
        {"optimization": "-O4"},
        {"c_standard": 12},
        {"cxx_standard": 15},
        {"defines": ["FOO BAR"]},
        {"defines": ["A=1\nB"]},
        {"micro_ros": {"defines": ["-DX"]}},
        {"chip": {"name": "RP2040", "ram": "264 kilobytes"}},
        {"chip": {"name": "RP2040", "flash": 2048}},
        {"chip": {"name": "RP2040", "size": "2M"}},
    ],
)
def test_schema_and_loader_reject_the_same_values(change: dict[str, Any]) -> None:
    data = {**minimal_profile(), **change}
    assert _errors("profile.schema.json", data) != []
    with pytest.raises(ConfigError):
        parse_profile(data, "board.yaml")


def test_profile_schema_allows_what_the_loader_allows() -> None:
    from uros_build.target import profiles

    props = _schema("profile.schema.json")["properties"]
    assert props["optimization"]["enum"] == list(profiles.OPTIMIZATIONS)
    assert props["c_standard"]["enum"] == list(profiles.C_STANDARDS)
    assert props["cxx_standard"]["enum"] == list(profiles.CXX_STANDARDS)
    good = {
        **minimal_profile(),
        "defines": ["A", "B=1", "C(x)=x", 'D="a b"'],
        "micro_ros": {"defines": ["E="]},
    }
    assert _errors("profile.schema.json", good) == []
    parse_profile(good, "board.yaml")


def test_minimal_profile_passes_both() -> None:
    assert _errors("profile.schema.json", minimal_profile()) == []
    parse_profile(minimal_profile(), "board.yaml")


SAMPLE_UROS_YAML = """\
distro: humble
platform: generate_lib
mirror:
  rules:
    - https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo
  overrides:
    ament/googletest: '@ros2'
    uros/tracetools: /srv/mirror/ros2+ros2_tracing/repo@humble
    ros2/rcl: {use: '@9.2.0', why: the mirror has no jazzy branch}
extra_packages:
  - ../my_interfaces
targets: [cortex-m7, rp2040]
transport: udp
set:
  - rmw_microxrcedds.RMW_UXRCE_MAX_PUBLISHERS=4
packages: [rclc, std_msgs]
idf_build: ../my-idf-project/build
"""


def test_sample_uros_yaml_validates() -> None:
    data = yaml.safe_load(SAMPLE_UROS_YAML)
    assert _errors("uros.schema.json", data) == []
    cfg = wsfiles.parse_config(data, "uros.yaml")  # and uros reads it
    assert cfg.distro == "humble" and len(cfg.mirror.rules) == 1 and len(cfg.mirror.overrides) == 3
    assert cfg.mirror.overrides[2].reason == "the mirror has no jazzy branch"
    assert cfg.targets == ("cortex-m7", "rp2040") and cfg.transport == "udp" and len(cfg.set) == 1
    assert cfg.idf_build == "../my-idf-project/build"
    # what create-firmware writes validates too
    assert _errors("uros.schema.json", yaml.safe_load(wsfiles.config_text(cfg))) == []
    assert _errors("uros.schema.json", {"distro": "iron"}) == []
    # a plain colcon workspace's uros.yaml: a build needs no distro
    assert _errors("uros.schema.json", {"target": "cortex-m7"}) == []
    assert wsfiles.parse_config({"target": "cortex-m7"}, "uros.yaml").distro == ""


def test_uros_schema_equals_the_workspace_config() -> None:
    schema = _schema("uros.schema.json")
    assert set(schema["properties"]) == {f.name for f in fields(wsfiles.WorkspaceConfig)}
    assert set(schema["properties"]["mirror"]["properties"]) == set(
        distros.mirror_to_config(distros.Mirror())
    )
    assert set(schema["properties"]["distro"]["examples"]) <= set(distros.known_distros())


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"distro": ""}, "should be non-empty"),
        ({"distro": "humble", "distros": "iron"}, "'distros' was unexpected"),
        ({"distro": "humble", "platform": "freertos"}, "'freertos' is not one of ['generate_lib']"),
        ({"distro": "humble", "mirror": {"rules": ["https://github.com/x"]}}, "does not match"),
        ({"distro": "humble", "mirror": {"rule": []}}, "'rule' was unexpected"),
        ({"distro": "humble", "mirror": {"overrides": {"a/b": 2}}}, "2 is not valid under any"),
        ({"distro": "humble", "mirror": {"overrides": {"a/b": {"use": "@x"}}}}, "is not valid under any"),
        ({"distro": "humble", "extra_packages": "../pkg"}, "'../pkg' is not of type 'array'"),
        ({"distro": "humble", "transport": "can"}, "'can' is not one of"),
        ({"distro": "humble", "set": ["RMW_UXRCE_MAX_NODES=2"]}, "does not match"),
        ({"distro": "humble", "set": ["rcl.FOO BAR=2"]}, "does not match"),
        ({"distro": "humble", "set": ["rcl.FOO=2 "]}, "does not match"),
        ({"distro": "humble", "target": "cortex-m7", "targets": ["rp2040"]}, "should not be valid"),
        ({"distro": "humble", "targets": "rp2040"}, "'rp2040' is not of type 'array'"),
        ({"distro": "humble", "idf_build": ["build"]}, "['build'] is not of type 'string'"),
        ({"distro": "humble", "idf_build": ""}, "'' should be non-empty"),
        ({"distro": "humble", "packages": "std_msgs"}, "'std_msgs' is not of type 'array'"),
        ({"distro": "humble", "packages": ["../x"]}, "does not match"),
    ],
)
def test_bad_uros_yaml_fails_the_schema(data: dict[str, Any], expected: str) -> None:
    assert any(expected in e for e in _errors("uros.schema.json", data)), _errors("uros.schema.json", data)
    if expected.startswith("'distro'"):
        return
    with pytest.raises(ConfigError):  # and uros refuses it too
        wsfiles.parse_config(data, "uros.yaml")


def test_unknown_uros_yaml_key_names_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "uros.yaml").write_text("distro: humble\ntarget: cortex-m7\ntargte: rp2040\n")
    with pytest.raises(ConfigError, match=r"uros.yaml:3: targte: unknown key") as info:
        wsfiles.load_config(tmp_path)
    assert info.value.hint == "did you mean target or targets?"
    (tmp_path / "uros.yaml").write_text("distro: humble\nmirror:\n  rule: []\n")
    with pytest.raises(ConfigError, match=r"uros.yaml:3: mirror: rule: unknown key"):
        wsfiles.load_config(tmp_path)
