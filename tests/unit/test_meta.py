from __future__ import annotations

import json
from pathlib import Path

import pytest
from golden import check_golden

from uros_build.errors import ConfigError
from uros_build.sources import meta
from uros_build.target.profiles import find_profile


def test_default_cortex_m7_meta_golden() -> None:
    m = meta.build_meta(
        meta.load_preset("default"), meta.target_fragments(find_profile("cortex-m7"), None), []
    )
    text = meta.dump_meta(m)
    check_golden("cortex-m7.colcon.meta", text)
    names = json.loads(text)["names"]
    client = names["microxrcedds_client"]["cmake-args"]
    assert "-DUCLIENT_PROFILE_CUSTOM_TRANSPORT=ON" in client
    assert "-DUCLIENT_PROFILE_UDP=OFF" in client
    assert "-DRMW_UXRCE_TRANSPORT=custom" in names["rmw_microxrcedds"]["cmake-args"]
    assert "-DRCUTILS_NO_64_ATOMIC=ON" in names["rcutils"]["cmake-args"]


def test_later_define_replaces_earlier_in_place() -> None:
    base = meta.parse_meta('{"names": {"p": {"cmake-args": ["-DA=1", "-DB=2", "-Wx"]}}}', "base")
    top = meta.parse_meta('{"names": {"p": {"cmake-args": ["-DA:BOOL=0", "-DC=3", "-Wx"]}}}', "top")
    merged = meta.merge([base, top])
    assert merged.names["p"]["cmake-args"] == ("-DA:BOOL=0", "-DB=2", "-Wx", "-DC=3")


def test_set_option() -> None:
    m = meta.build_meta(meta.Meta(), [], [], ["rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2"])
    assert m.names["rmw_microxrcedds"]["cmake-args"] == ("-DRMW_UXRCE_MAX_NODES=2",)
    with pytest.raises(ConfigError, match=r"PACKAGE\.OPTION=VALUE"):
        meta.parse_set("nodot=1")


def test_dump_is_deterministic_and_sorted() -> None:
    a = meta.parse_meta(
        '{"names": {"b": {"cmake-args": ["-DX=1"]}, "a": {"cmake-force-configure": true}}}', "m"
    )
    b = meta.parse_meta(
        '{"names": {"a": {"cmake-force-configure": true}, "b": {"cmake-args": ["-DX=1"]}}}', "m"
    )
    assert meta.dump_meta(a) == meta.dump_meta(b)
    assert meta.dump_meta(a).index('"a"') < meta.dump_meta(a).index('"b"')


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('{"names": {"a": {"cmake-args": ["-DX=1"],}}}', r"m.meta:1:\d+: not valid JSON"),
        ('{\n"names": {\n"a": 1}}', "names.a must be an object"),
        ('{"nmes": {}}', "unsupported top-level key 'nmes'"),
        ('{"names": {"a": {"cmake-args": [1]}}}', "must be a list of strings"),
        ('{"names": {"a": {}, "a": {}}}', "duplicate key 'a'"),
    ],
)
def test_bad_meta_names_file_and_problem(text: str, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        meta.parse_meta(text, "m.meta")


def test_an_unknown_package_key_names_file_package_and_key() -> None:
    """Round 3 (issue 34, 7): colcon drops a key it does not know, so "cmake-argz" built with nothing set."""
    text = '{"names": {"rcl": {"cmake-args": ["-DA=1"], "cmake-argz": ["-DB=2"]}}}'
    with pytest.raises(ConfigError) as info:
        meta.parse_meta(text, "my.meta")
    assert info.value.message == (
        "my.meta: names.rcl.cmake-argz: unknown key (colcon would ignore it) (did you mean cmake-args, "
        "cmake-target or ament-cmake-args?)"
    )
    assert info.value.hint is not None and "cmake-args" in info.value.hint and "ctest-args" in info.value.hint
    # a comment key, as at the top level, and every key colcon reads
    assert meta.parse_meta('{"names": {"rcl": {"_why": "x", "ctest-args": ["-V"]}}}', "m").names == {
        "rcl": {"ctest-args": ("-V",)}
    }


def test_the_package_keys_are_colcons() -> None:
    """What colcon's build and test tasks take from a package's entry (asked of colcon itself)."""
    import argparse

    from colcon_core.task import add_task_arguments

    for task, keys in (("build", meta.BUILD_KEYS), ("test", meta.TEST_KEYS)):
        parser = argparse.ArgumentParser()
        add_task_arguments(parser, f"colcon_core.task.{task}")
        names = {a.option_strings[0][2:] for a in parser._actions if a.option_strings != ["-h", "--help"]}
        assert names == set(keys), task


def test_meta_file_problems_are_one_line(tmp_path: Path) -> None:
    path = tmp_path / "colcon.meta"
    path.write_bytes(b'{"names": {"caf\xe9": {}}}')
    with pytest.raises(ConfigError) as info:
        meta.load_meta_file(path)
    assert info.value.message == f"--meta {path}: not UTF-8 text (byte 15)"
    with pytest.raises(ConfigError, match=r"no such file") as info:
        meta.load_meta_file(tmp_path / "nope.meta")
    assert info.value.hint == "pass the path of an existing colcon.meta file"
    with pytest.raises(ConfigError, match=r"is a folder, not a file"):
        meta.load_meta_file(tmp_path)
    path.write_text('{"names": {"a": {}},\n "names": {}}', encoding="utf-8")
    with pytest.raises(ConfigError, match=r"colcon.meta: duplicate key 'names'"):
        meta.load_meta_file(path)


def test_unknown_transport() -> None:
    with pytest.raises(ConfigError, match="unknown transport 'carrier-pigeon'"):
        meta.target_fragments(None, "carrier-pigeon")


def test_esp32s3_meta_is_udp_without_rcutils_atomics() -> None:
    m = meta.build_meta(meta.load_preset("default"), meta.target_fragments(find_profile("esp32s3"), None), [])
    names = json.loads(meta.dump_meta(m))["names"]
    assert "-DRMW_UXRCE_TRANSPORT=udp" in names["rmw_microxrcedds"]["cmake-args"]
    assert "-DUCLIENT_PROFILE_UDP=ON" in names["microxrcedds_client"]["cmake-args"]
    # ESP-IDF's newlib defines __atomic_*_8: rcutils must not build its own (RCUTILS_NO_64_ATOMIC off)
    assert not any("RCUTILS_NO_64_ATOMIC" in a for a in names["rcutils"]["cmake-args"])


def test_serial_transport_overrides_the_targets() -> None:
    m = meta.build_meta(
        meta.load_preset("default"), meta.target_fragments(find_profile("esp32s3"), "serial"), []
    )
    names = json.loads(meta.dump_meta(m))["names"]
    assert "-DRMW_UXRCE_TRANSPORT=serial" in names["rmw_microxrcedds"]["cmake-args"]
    assert "-DRMW_UXRCE_TRANSPORT=udp" not in names["rmw_microxrcedds"]["cmake-args"]
    assert "-DUCLIENT_PROFILE_SERIAL=ON" in names["microxrcedds_client"]["cmake-args"]
