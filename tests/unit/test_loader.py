"""loader.py: every unreadable or malformed input is one ConfigError line naming the file (and line)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from uros_build import loader, resources
from uros_build.errors import ConfigError


def _error(func: Any, *args: Any, **kwargs: Any) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        func(*args, **kwargs)
    assert "\n" not in info.value.message, info.value.message
    return info.value


def test_bad_yaml_names_file_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "board.yaml"
    path.write_text("name: a\nflags: [1, 2\nother: 3\n", encoding="utf-8")
    err = _error(loader.load_yaml, path)
    assert err.message.startswith(f"{path}:3:6: not valid YAML: expected ',' or ']'")


def test_bad_yaml_with_flag_and_hint(tmp_path: Path) -> None:
    path = tmp_path / "uros.yaml"
    path.write_text("a: b: c\n", encoding="utf-8")
    err = _error(loader.load_yaml, path, "--config", "fix it")
    assert err.message == f"--config {path}:1:5: not valid YAML: mapping values are not allowed here"
    assert err.hint == "fix it"


def test_bad_json_names_file_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "uros.lock"
    path.write_text('{\n  "a": 1,\n}\n', encoding="utf-8")
    err = _error(loader.load_json, path)
    assert err.message.startswith(f"{path}:3:1: not valid JSON:")


def test_good_files_load(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text("a: [1, x]\n", encoding="utf-8")
    (tmp_path / "a.json").write_text('{"a": [1, "x"]}', encoding="utf-8")
    assert loader.load_yaml(tmp_path / "a.yaml") == loader.load_json(tmp_path / "a.json") == {"a": [1, "x"]}
    (tmp_path / "empty.yaml").write_text("", encoding="utf-8")
    assert loader.load_yaml(tmp_path / "empty.yaml") is None


@pytest.mark.parametrize("read", [loader.read_text, loader.load_yaml, loader.load_json])
def test_non_utf8_file(tmp_path: Path, read: Any) -> None:
    path = tmp_path / "board.yaml"
    path.write_bytes(b"name: caf\xe9\n")
    err = _error(read, path)
    assert err.message == f"{path}: not UTF-8 text (byte 9)"
    assert err.hint == "save it as UTF-8"


@pytest.mark.parametrize("read", [loader.read_text, loader.load_yaml, loader.load_json])
def test_missing_file(tmp_path: Path, read: Any) -> None:
    err = _error(read, tmp_path / "nope.yaml", "--profile", "check the path")
    assert err.message == f"--profile {tmp_path / 'nope.yaml'}: no such file"
    assert err.hint == "check the path"


def test_folder_instead_of_file(tmp_path: Path) -> None:
    err = _error(loader.load_yaml, tmp_path)
    assert err.message == f"{tmp_path}: is a folder, not a file"


def test_list_where_a_mapping_is_expected() -> None:
    err = _error(loader.mapping, ["a", "b"], "f.yaml: mirror")
    assert err.message == "f.yaml: mirror: expected a mapping (key: value lines), got list"
    assert loader.mapping(None, "f.yaml") == {}


def test_unknown_and_missing_keys() -> None:
    err = _error(loader.mapping, {"name": "x", "stauts": "y"}, "f.yaml", {"name", "status"})
    assert err.message == "f.yaml: stauts: unknown key (known: name, status)"
    err = _error(loader.mapping, {"status": "y"}, "f.yaml", {"name", "status"}, ("name",))
    assert err.message == "f.yaml: name: is required but missing"


def test_string() -> None:
    assert loader.string({"a": "x"}, "a", "f") == "x"
    assert loader.string({}, "a", "f", "dflt") == "dflt"
    assert _error(loader.string, {}, "a", "f").message == "f: a: is required but missing"
    assert _error(loader.string, {"a": 3}, "a", "f").message == "f: a: must be a non-empty string, got 3"
    assert _error(loader.string, {"a": ""}, "a", "f").message == "f: a: must be a non-empty string, got ''"


def test_string_list() -> None:
    assert loader.string_list({"a": ["x", "y"]}, "a", "f") == ("x", "y")
    assert loader.string_list({}, "a", "f") == ()
    # a bare string is not a list of its characters
    err = _error(loader.string_list, {"a": "abc"}, "a", "f")
    assert err.message == "f: a: must be a list of strings, got 'abc'"
    _error(loader.string_list, {"a": ["x", 1]}, "a", "f")


def test_boolean() -> None:
    assert loader.boolean({"a": True}, "a", "f") is True
    assert loader.boolean({}, "a", "f") is False
    assert loader.boolean({}, "a", "f", default=True) is True
    assert _error(loader.boolean, {"a": "yes"}, "a", "f").message == "f: a: must be true or false, got 'yes'"


def test_integer() -> None:
    assert loader.integer({"a": 3}, "a", "f") == 3
    assert loader.integer({}, "a", "f", 7) == 7
    assert _error(loader.integer, {}, "a", "f").message == "f: a: is required but missing"
    # YAML's true is a Python int; it is not a number here
    assert _error(loader.integer, {"a": True}, "a", "f").message == "f: a: must be a whole number, got True"
    _error(loader.integer, {"a": 1.5}, "a", "f")


def test_one_of() -> None:
    assert loader.one_of({"a": "udp"}, "a", "f", ("custom", "udp")) == "udp"
    assert loader.one_of({}, "a", "f", ("custom", "udp"), "custom") == "custom"
    err = _error(loader.one_of, {"a": "can"}, "a", "f", ("custom", "udp"))
    assert err.message == "f: a: 'can' is not one of custom, udp"


def test_string_map() -> None:
    assert loader.string_map({"a": {"y": "1", "x": "2"}}, "a", "f") == {"y": "1", "x": "2"}
    assert list(loader.string_map({"a": {"y": "1", "x": "2"}}, "a", "f")) == ["y", "x"]  # file order
    assert loader.string_map({}, "a", "f") == {}
    err = _error(loader.string_map, {"a": {"x": 1}}, "a", "f")
    assert err.message == "f: a: must be a mapping of names to strings, got {'x': 1}"
    _error(loader.string_map, {"a": ["x"]}, "a", "f")


def test_mapping_list() -> None:
    items = loader.mapping_list({"a": [{"url": "u"}]}, "a", "f", {"url", "by"}, ("url",))
    assert items == ({"url": "u"},)
    assert loader.mapping_list({}, "a", "f") == ()
    assert (
        _error(loader.mapping_list, {"a": "u"}, "a", "f").message
        == "f: a: must be a list of mappings, got 'u'"
    )
    err = _error(loader.mapping_list, {"a": [{"url": "u"}, {"by": "x"}]}, "a", "f", {"url", "by"}, ("url",))
    assert err.message == "f: a[1]: url: is required but missing"
    err = _error(loader.mapping_list, {"a": ["u"]}, "a", "f")
    assert err.message == "f: a[0]: must be a mapping (key: value lines), got 'u'"


@pytest.mark.parametrize(
    ("text", "line", "key"),
    [
        ("distro: humble\ntarget: cortex-m7\ntarget: rp2040\n", 3, "target"),  # the last won, silently
        ("mirror:\n  rules: []\n  overrides: {}\n  rules: [a]\n", 4, "rules"),  # nested
        ("set: [a.B=1]\ndistro: humble\n'set': [a.B=2]\n", 3, "set"),  # quoted or not: one key
        ("a: {x: 1, x: 2}\n", 1, "x"),  # flow style
    ],
)
def test_a_key_given_twice_names_its_line(tmp_path: Path, text: str, line: int, key: str) -> None:
    """Round 3 (issue 34, 7): every YAML file uros reads (uros.yaml, --config, profiles, meta/)."""
    path = tmp_path / "uros.yaml"
    path.write_text(text, encoding="utf-8")
    err = _error(loader.load_yaml, path, "--config", "fix it")
    assert err.message.startswith(f"--config {path}:{line}: {key}: given twice (first on line "), err.message
    assert err.hint == f"keep one {key}: (YAML would use only the last, silently)"


def test_a_merge_key_may_be_overridden(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text("base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  x: 3\n", encoding="utf-8")
    assert loader.load_yaml(path)["other"] == {"x": 3, "y": 2}


def _shipped_yaml() -> list[Path]:
    found = sorted(resources.toolchains_dir().glob("*.yaml"))
    for pattern in ("*.yaml", "*.repos"):
        found += sorted(resources.meta_dir().rglob(pattern))
    return found


def _with_lines(data: Any) -> Any:
    """``data`` with each mapping's key lines beside it."""
    if isinstance(data, dict):
        return ({k: _with_lines(v) for k, v in data.items()}, getattr(data, "key_lines", None))
    if isinstance(data, list):
        return [_with_lines(v) for v in data]
    return data


@pytest.mark.skipif(loader._loaders().libyaml is None, reason="PyYAML without libyaml")
def test_shipped_files_parse_the_same_with_libyaml() -> None:
    """The data files uros ships are read through libyaml (start-up cost): each gives the same data,
    and the same key lines, as through PyYAML's pure-Python loader (the one user files get)."""
    files, found = _shipped_yaml(), loader._loaders()
    assert len(files) > 30
    for path in files:
        assert loader._loader_for(path) is found.libyaml, path
        text = path.read_text(encoding="utf-8")
        pure = yaml.load(text, Loader=found.pure)
        assert _with_lines(yaml.load(text, Loader=found.libyaml)) == _with_lines(pure), path
        assert loader.load_yaml(path) == pure


def test_user_files_get_the_pure_python_loader(tmp_path: Path) -> None:
    """A file of the user's is parsed by the pure-Python loader, whose verdicts and messages uros
    prints: libyaml takes some text it refuses (a block scalar's header followed by `#`)."""
    path = tmp_path / "profile.yaml"
    path.write_text("name: |#x\n", encoding="utf-8")
    assert loader._loader_for(path) is loader._loaders().pure
    err = _error(loader.load_yaml, path)
    assert err.message.startswith(f"{path}:1:8: not valid YAML: expected ")
