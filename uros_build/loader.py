"""Reading every YAML and JSON input uros takes (profiles, distro.yaml, uros.yaml, --config,
uros.lock, build-info.json): one place that turns unreadable, non-UTF-8 or malformed files into a
one-line ConfigError naming the file (and line), and small typed readers that the model modules
use to turn the parsed data into frozen dataclasses. Nothing past a loader sees a raw dict."""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from uros_build import resources
from uros_build.errors import ConfigError, did_you_mean


def is_count(value: object, limit: int) -> bool:
    """A value read from JSON that others can write (a team cache's manifest, a probe's report) is
    a count: a whole number (JSON's true is none) from 0 to ``limit``."""
    return type(value) is int and 0 <= value <= limit


def is_sha256(value: object) -> bool:
    """The same for a sha256: 64 lowercase hex digits."""
    return isinstance(value, str) and len(value) == 64 and all(c in "0123456789abcdef" for c in value)


def read_text(path: Path, flag: str = "", hint: str | None = None) -> str:
    where = f"{flag} {path}" if flag else str(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{where}: no such file", hint) from None
    except IsADirectoryError:
        raise ConfigError(f"{where}: is a folder, not a file", hint) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{where}: not UTF-8 text (byte {exc.start})", hint or "save it as UTF-8") from None
    except OSError as exc:
        raise ConfigError(f"{where}: cannot read: {exc.strerror}", hint) from None


class LineDict(dict[Any, Any]):
    """A YAML mapping that remembers the line of each key, for messages (``file:line:``)."""

    key_lines: dict[str, int]


if TYPE_CHECKING:
    import yaml

    _Constructor = yaml.SafeLoader  # what the mixin below extends, to the type checker
else:
    _Constructor = object  # at run time: the loader it is mixed into (PyYAML is imported on first use)


class _LineMappings(_Constructor):
    """Mappings as :class:`LineDict`, a key given twice refused (``DuplicateKey``)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        import yaml

        seen: dict[tuple[str, str], int] = {}
        for key_node, _value in node.value:
            # a merge key (<<) may bring keys that the mapping itself then overrides: YAML allows that
            if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                ident = (key_node.tag, key_node.value)
                if ident in seen:
                    raise _loaders().duplicate(str(key_node.value), seen[ident], key_node.start_mark)
                seen[ident] = key_node.start_mark.line + 1
        out = LineDict()
        out.update(super().construct_mapping(node, deep=deep))
        out.key_lines = {str(k.value): k.start_mark.line + 1 for k, _v in node.value}
        return out


class _Loaders(NamedTuple):
    pure: type[Any]  # PyYAML's pure-Python SafeLoader: the reference, whose error messages uros prints
    libyaml: type[Any] | None  # the same over libyaml's parser (None: PyYAML without it)
    duplicate: type[Any]  # the error of a key given twice


@functools.cache
def _loaders() -> _Loaders:
    """The loaders, made on the first YAML file read: a command that reads none (`uros info`,
    `uros export`, `--version`) does not import PyYAML (start-up cost, ~0.012 s).

    libyaml's is for the data files uros ships only (toolchains/, meta/: every `uros build` reads
    three, ~0.02 s of its start through the pure-Python scanner and parser, ~10x less through
    libyaml). Scalars are resolved and constructed by the same Python classes (SafeConstructor,
    Resolver); the two parsers differ only on text that PyYAML refuses and libyaml takes (a tab in
    some places, `|#`, ...), which a user's file could hold and the shipped ones do not:
    tests/unit/test_loader.py checks that every shipped file gives the same data and key lines both
    ways. A user's file always gets the pure-Python loader's verdict and message."""
    import yaml

    class DuplicateKey(yaml.MarkedYAMLError):
        """A key given twice in one mapping: YAML's own rule (keys are unique), which PyYAML does not
        enforce (https://github.com/yaml/pyyaml/issues/165): the last one would silently win."""

        def __init__(self, key: str, first: int, mark: yaml.Mark) -> None:
            super().__init__(problem=f"{key}: given twice (first on line {first})", problem_mark=mark)
            self.key = key

    class LineLoader(_LineMappings, yaml.SafeLoader):
        pass

    LineLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, LineLoader.construct_mapping)
    if not getattr(yaml, "__with_libyaml__", False):
        return _Loaders(LineLoader, None, DuplicateKey)

    class CLineLoader(_LineMappings, yaml.CSafeLoader):
        pass

    CLineLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, CLineLoader.construct_mapping)
    return _Loaders(LineLoader, CLineLoader, DuplicateKey)


def _loader_for(path: Path) -> type[Any]:
    """libyaml's loader for a data file uros ships (under its toolchains/ or meta/ folder), when
    PyYAML has it; else the pure-Python one."""
    found = _loaders()
    if found.libyaml is None:
        return found.pure
    where = path.resolve()
    for name in ("toolchains", "meta"):
        try:
            if where.is_relative_to(resources.data_dir(name)):
                return found.libyaml
        except FileNotFoundError:  # not in this installation: nothing of it is read
            pass
    return found.pure


def load_yaml(path: Path, flag: str = "", hint: str | None = None) -> Any:
    """Parsed YAML whose mappings know their keys' lines (:class:`LineDict`)."""
    import yaml

    text = read_text(path, flag, hint)
    try:
        return yaml.load(text, Loader=_loader_for(path))  # a SafeLoader: plain data types only
    except _loaders().duplicate as exc:
        prefix = f"{flag} " if flag else ""
        line = exc.problem_mark.line + 1 if exc.problem_mark is not None else 0
        raise ConfigError(
            f"{prefix}{path}:{line}: {exc.problem}",
            f"keep one {exc.key}: (YAML would use only the last, silently)",
        ) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}:{mark.column + 1}" if mark is not None else ""
        prefix = f"{flag} " if flag else ""
        raise ConfigError(
            f"{prefix}{path}{where}: not valid YAML: {getattr(exc, 'problem', None) or exc}", hint
        ) from None


def load_json(path: Path, flag: str = "", hint: str | None = None) -> Any:
    text = read_text(path, flag, hint)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        prefix = f"{flag} " if flag else ""
        raise ConfigError(
            f"{prefix}{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}", hint
        ) from None


def mapping(
    data: Any, source: str, known: set[str] | None = None, required: tuple[str, ...] = ()
) -> Mapping[str, Any]:
    """``data`` as a mapping with only ``known`` keys and every ``required`` one."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: expected a mapping (key: value lines), got {type(data).__name__}")
    if known is not None:
        unknown = sorted(str(k) for k in set(data) - known)
        if unknown:
            where = at_line(source, data, unknown[0])
            near = did_you_mean(unknown[0], known).strip(" ()")
            raise ConfigError(
                f"{where}: {unknown[0]}: unknown key (known: {', '.join(sorted(known))})",
                f"{near}" if near else None,
            )
    for key in required:
        if key not in data:
            raise ConfigError(f"{source}: {key}: is required but missing")
    return data


def at_line(source: str, data: Any, key: str) -> str:
    """``file: section`` -> ``file:LINE: section`` where the YAML loader saw ``key``."""
    line = getattr(data, "key_lines", {}).get(key)
    if line is None:
        return source
    head, sep, rest = source.partition(": ")
    return f"{head}:{line}{sep}{rest}"


def string(data: Mapping[str, Any], key: str, source: str, default: str | None = None) -> str:
    value = data.get(key, default)
    if not isinstance(value, str) or not value:
        if value is None:
            raise ConfigError(f"{source}: {key}: is required but missing")
        raise ConfigError(f"{source}: {key}: must be a non-empty string, got {value!r}")
    return value


def string_list(data: Mapping[str, Any], key: str, source: str) -> tuple[str, ...]:
    value = data.get(key)
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{source}: {key}: must be a list of strings, got {value!r}")
    return tuple(value)


def boolean(data: Mapping[str, Any], key: str, source: str, default: bool = False) -> bool:
    value = data.get(key, default)
    if not isinstance(value, bool):
        raise ConfigError(f"{source}: {key}: must be true or false, got {value!r}")
    return value


def integer(data: Mapping[str, Any], key: str, source: str, default: int | None = None) -> int:
    value = data.get(key, default)
    if value is None:
        raise ConfigError(f"{source}: {key}: is required but missing")
    if not isinstance(value, int) or isinstance(value, bool):
        raise ConfigError(f"{source}: {key}: must be a whole number, got {value!r}")
    return value


def one_of(
    data: Mapping[str, Any], key: str, source: str, choices: tuple[str, ...], default: str | None = None
) -> str:
    """A string that must be one of ``choices``."""
    value = string(data, key, source, default)
    if value not in choices:
        raise ConfigError(f"{source}: {key}: {value!r} is not one of {', '.join(choices)}")
    return value


def string_map(data: Mapping[str, Any], key: str, source: str) -> Mapping[str, str]:
    """A mapping of names to strings (``name: value`` lines), in file order; absent is empty."""
    value = data.get(key)
    if value is None:
        return {}
    if (
        not isinstance(value, Mapping)
        or not all(isinstance(k, str) for k in value)
        or not all(isinstance(v, str) for v in value.values())
    ):
        raise ConfigError(f"{source}: {key}: must be a mapping of names to strings, got {value!r}")
    return dict(value)


def mapping_list(
    data: Mapping[str, Any],
    key: str,
    source: str,
    known: set[str] | None = None,
    required: tuple[str, ...] = (),
) -> tuple[Mapping[str, Any], ...]:
    """A list of mappings, each checked like :func:`mapping` and named ``source: key[i]``."""
    value = data.get(key)
    if value is None:
        return ()
    if not isinstance(value, list):
        raise ConfigError(f"{source}: {key}: must be a list of mappings, got {value!r}")
    items = []
    for i, item in enumerate(value):
        if not isinstance(item, Mapping):
            raise ConfigError(f"{source}: {key}[{i}]: must be a mapping (key: value lines), got {item!r}")
        items.append(mapping(item, f"{source}: {key}[{i}]", known, required))
    return tuple(items)
