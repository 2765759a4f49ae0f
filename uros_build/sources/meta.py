"""colcon.meta: strict loading, merging and deterministic writing (pure).

colcon itself reads ``names`` and ``paths`` and silently ignores anything else it does not
understand, and a ``--metas`` path that does not exist. uros refuses both, naming file and line.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uros_build import __version__, defaults, loader, resources
from uros_build.errors import ConfigError, did_you_mean
from uros_build.target.profiles import TargetProfile

MetaValue = tuple[str, ...] | str | bool | int | float
_LIST_KEYS_MERGED_BY_DEFINE = ("cmake-args",)

# What colcon reads from a package's entry in a colcon.meta: the arguments of its build and test
# tasks (colcon_core.task.add_task_arguments for 'colcon_core.task.build' and '.test': a meta file
# may serve `colcon test` too), and the dependency and hook keys of
# colcon_core.package_augmentation.update_descriptor. colcon drops any other key without a word,
# so a typo ("cmake-argz") would build with nothing set. tests/unit/test_meta.py asks colcon.
BUILD_KEYS = (
    "ament-cmake-args",
    "catkin-cmake-args",
    "catkin-skip-building-tests",
    "cmake-args",
    "cmake-clean-cache",
    "cmake-clean-first",
    "cmake-force-configure",
    "cmake-target",
    "cmake-target-skip-unavailable",
)
TEST_KEYS = ("ctest-args", "pytest-args", "pytest-with-coverage", "python-testing", "unittest-args")
DESCRIPTOR_KEYS = ("build-dependencies", "dependencies", "hooks", "run-dependencies", "test-dependencies")
PACKAGE_KEYS = tuple(sorted((*BUILD_KEYS, *TEST_KEYS, *DESCRIPTOR_KEYS)))


@dataclass(frozen=True)
class Meta:
    """``names``: package -> colcon option (``cmake-args``, ...) -> value."""

    names: Mapping[str, Mapping[str, MetaValue]] = field(default_factory=dict)
    source: str = ""


def _reject_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    seen: dict[str, Any] = {}
    for key, value in pairs:
        if key in seen:
            raise ValueError(f"duplicate key {key!r}")
        seen[key] = value
    return seen


def parse_meta(text: str, source: str) -> Meta:
    try:
        data = json.loads(text, object_pairs_hook=_reject_duplicates)
    except json.JSONDecodeError as exc:
        raise ConfigError(
            f"{source}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}",
            "colcon.meta is JSON: check for trailing commas and unquoted names",
        ) from exc
    except ValueError as exc:
        raise ConfigError(f"{source}: {exc}", "each package and option may appear once") from exc
    hint = 'expected {"names": {"<package>": {"cmake-args": ["-DOPTION=VALUE", ...]}}}'
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a JSON object", hint)
    for key in data:
        if key != "names" and not key.startswith(("_", "//")):
            raise ConfigError(f"{source}: unsupported top-level key {key!r} (colcon would ignore it)", hint)
    names = data.get("names", {})
    if not isinstance(names, dict):
        raise ConfigError(f"{source}: 'names' must be an object", hint)
    out: dict[str, dict[str, MetaValue]] = {}
    for pkg, options in names.items():
        if not isinstance(options, dict):
            raise ConfigError(f"{source}: names.{pkg} must be an object of colcon options", hint)
        out[pkg] = {}
        for opt, value in options.items():
            if opt.startswith(("_", "//")):  # a comment, as at the top level
                continue
            if opt not in PACKAGE_KEYS:
                near = did_you_mean(opt, PACKAGE_KEYS)
                raise ConfigError(
                    f"{source}: names.{pkg}.{opt}: unknown key (colcon would ignore it){near}",
                    f"known: {', '.join(PACKAGE_KEYS)}",
                )
            if isinstance(value, list):
                if not all(isinstance(v, str) for v in value):
                    raise ConfigError(f"{source}: names.{pkg}.{opt} must be a list of strings", hint)
                out[pkg][opt] = tuple(value)
            elif opt.endswith("-args"):
                # colcon hands these to argparse as lists: a string is read one character at a
                # time, which CMake then rejects as "Unknown argument -"
                raise ConfigError(
                    f"{source}: names.{pkg}.{opt} must be a list of strings, got {value!r}",
                    f'write it as a list: "{opt}": [{json.dumps(value)}]',
                )
            elif isinstance(value, str | bool | int | float):
                out[pkg][opt] = value
            else:
                raise ConfigError(f"{source}: names.{pkg}.{opt} has an unsupported value {value!r}", hint)
    return Meta(names=out, source=source)


def load_meta_file(path: Path, flag: str = "--meta") -> Meta:
    if not path.exists():
        raise ConfigError(f"{flag} {path}: no such file", "pass the path of an existing colcon.meta file")
    # read through the loader (one-line errors for a folder, non-UTF-8 text, no permission); parsed
    # here, since colcon.meta needs duplicate keys rejected, which loader.load_json does not do
    return parse_meta(loader.read_text(path, flag), str(path))


def load_shipped(relative: str) -> Meta:
    path = resources.meta_dir() / relative
    return load_meta_file(path, flag="(shipped meta)")


def presets() -> list[str]:
    return sorted(p.stem for p in (resources.meta_dir() / "presets").glob("*.json"))


def load_preset(name: str, distro_preset: str | None = None) -> Meta:
    """``default`` means the workspace distro's preset, else the default distro's."""
    if name == defaults.PRESET:
        name = distro_preset or defaults.DISTRO
    if name not in presets():
        raise ConfigError(
            f"--preset: unknown preset {name!r}{did_you_mean(name, [defaults.PRESET, *presets()])}",
            f"known presets: {defaults.PRESET}, {', '.join(presets())}",
        )
    return load_shipped(f"presets/{name}.json")


def _define_name(arg: str) -> str | None:
    """'-DNAME=VALUE' / '-DNAME:BOOL=VALUE' -> 'NAME'; anything else -> None."""
    if arg.startswith("-D") and "=" in arg:
        return arg[2:].split("=", 1)[0].split(":", 1)[0]
    return None


def _merge_args(base: tuple[str, ...], overlay: tuple[str, ...]) -> tuple[str, ...]:
    """Later -DNAME=... replaces an earlier setting of NAME in place; other args are appended once."""
    result = list(base)
    for arg in overlay:
        name = _define_name(arg)
        index = next((i for i, a in enumerate(result) if name is not None and _define_name(a) == name), None)
        if index is not None:
            result[index] = arg
        elif arg not in result:
            result.append(arg)
    return tuple(result)


def merge(metas: Iterable[Meta]) -> Meta:
    names: dict[str, dict[str, MetaValue]] = {}
    for meta in metas:
        for pkg, options in meta.names.items():
            target = names.setdefault(pkg, {})
            for opt, value in options.items():
                old = target.get(opt)
                if opt in _LIST_KEYS_MERGED_BY_DEFINE and isinstance(old, tuple) and isinstance(value, tuple):
                    target[opt] = _merge_args(old, value)
                else:
                    target[opt] = value
    return Meta(names=names, source="(merged)")


@dataclass(frozen=True)
class SetItem:
    """One ``PKG.OPTION=VALUE`` (--set, uros.yaml's set:): the one place that reads the form."""

    package: str
    option: str
    value: str


# A package name (colcon's, as uros.yaml's packages: takes them) and a CMake variable name: what a
# -D can set from the command line and a C header can use. A space or another character there
# reached CMake as a variable no package reads, silently.
_SET_PACKAGE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_-]*")
_SET_OPTION = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def split_set(item: str, where: str = "--set") -> SetItem:
    """``PKG.OPTION=VALUE`` -> its parts; a ConfigError naming ``where`` when it is not that."""
    pkg, dot, rest = item.partition(".")
    name, eq, value = rest.partition("=")
    example = "for example --set rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2"
    if not (pkg and dot and name and eq):
        raise ConfigError(f"{where} {item!r}: expected PACKAGE.OPTION=VALUE", example)
    if not _SET_PACKAGE.fullmatch(pkg):
        raise ConfigError(f"{where} {item!r}: {pkg!r} is not a package name", example)
    if not _SET_OPTION.fullmatch(name):
        raise ConfigError(
            f"{where} {item!r}: {name!r} is not a CMake option name (letters, digits and '_')", example
        )
    if value != value.strip() or any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise ConfigError(
            f"{where} {item!r}: the value of {name} starts or ends with a space or holds a line break",
            "give the value as CMake should see it: PACKAGE.OPTION=VALUE, nothing around it",
        )
    return SetItem(pkg, name, value)


def parse_set(item: str) -> Meta:
    """``--set PKG.NAME=VALUE`` -> cmake-arg ``-DNAME=VALUE`` for PKG."""
    one = split_set(item)
    return Meta(names={one.package: {"cmake-args": (f"-D{one.option}={one.value}",)}}, source=f"--set {item}")


def transports() -> tuple[str, ...]:
    return resources.transports()


def target_fragments(profile: TargetProfile | None, transport: str | None) -> list[Meta]:
    """What a target needs on top of the preset: its transport and, where the core lacks them,
    rcutils' own 64-bit atomics (else the firmware link fails on __atomic_*_8)."""
    chosen = transport or (profile.transport if profile else None)
    frags = []
    if chosen is not None:
        if chosen not in transports():
            raise ConfigError(
                f"--transport: unknown transport {chosen!r}{did_you_mean(chosen, transports())}",
                f"known: {', '.join(transports())}",
            )
        frags.append(load_shipped(f"transports/{chosen}.json"))
    if profile is not None and not profile.native_64bit_atomics:
        frags.append(load_shipped("fragments/no-64bit-atomics.json"))
    if profile is not None and profile.idf_target:
        # The XRCE-DDS client compiles as C99 unless told; ESP-IDF's headers need C11's
        # static_assert (esp_macros.h: "expected declaration specifiers ... before numeric constant"
        # under gnu99). A cache entry the client creates before project() reads the toolchain
        # file, so it must come on the command line, as micro_ros_espidf_component passes it.
        standard = f"-DUCLIENT_C_STANDARD={profile.c_standard}"
        frags.append(Meta(names={"microxrcedds_client": {"cmake-args": (standard,)}}, source="(ESP-IDF)"))
    return frags


def build_meta(
    preset: Meta, fragments: Iterable[Meta], user: Iterable[Meta], sets: Iterable[str] = ()
) -> Meta:
    return merge([preset, *fragments, *user, *(parse_set(s) for s in sets)])


def dump_meta(meta: Meta, generated_by: str = "") -> str:
    data: dict[str, Any] = {
        "_generated_by": f"uros {__version__}" + (f": {generated_by}" if generated_by else ""),
        "names": {
            pkg: {opt: list(v) if isinstance(v, tuple) else v for opt, v in options.items()}
            for pkg, options in meta.names.items()
        },
    }
    return json.dumps(data, indent=2, sort_keys=True) + "\n"
