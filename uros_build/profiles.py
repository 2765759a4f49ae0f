"""Target profiles: ``toolchains/*.yaml`` loaded into frozen dataclasses, validated on load.

A profile is everything uros knows about one MCU target: which cross compiler, which CPU/FPU/ABI
flags, which defines only micro-ROS needs (MICROROSFLAGS), what the colcon.meta must add, and
which ELF facts every object built for it must show. Unknown keys and wrong types are errors
naming the file and the key; nothing past this module sees a raw dict.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from uros_build import resources
from uros_build.errors import ConfigError

TRANSPORTS = ("custom", "udp", "serial")


@dataclass(frozen=True)
class MicroRosFlags:
    """Compile settings that apply to micro-ROS only, never to the firmware (seed 001's MICROROSFLAGS)."""

    # Plain -D defines, e.g. "CLOCK_MONOTONIC=0" for newlib, which has no monotonic clock id.
    defines: tuple[str, ...] = ()
    # Force-include a header declaring clock_gettime(): newlib without _POSIX_TIMERS declares none,
    # and rcutils/XRCE-DDS call it, which GCC >= 14 rejects as an implicit declaration.
    declare_clock_gettime: bool = False
    # -D'__attribute__(x)=' worked around GCC < 6 choking on attributes in micro-ROS headers; it
    # also strips rcl's constructor attributes, so uros only adds it where the compiler is older.
    strip_attributes_below_gcc: int = 0


@dataclass(frozen=True)
class ElfFacts:
    """What ``readelf`` must report for every object built for the target."""

    machine: str  # readelf -h "Machine:" substring, e.g. "ARM", "RISC-V", "Tensilica Xtensa"
    elf_class: str = "ELF32"
    header_flags: tuple[str, ...] = ()  # substrings of readelf -h "Flags:" (RISC-V float ABI, ...)
    # readelf -A attributes that must match exactly, e.g. Tag_ABI_VFP_args: VFP registers.
    attributes: tuple[tuple[str, str], ...] = ()
    # attributes that must be absent or equal to one of the listed values (e.g. no FPU at all)
    attributes_absent: tuple[str, ...] = ()


@dataclass(frozen=True)
class TargetProfile:
    name: str
    description: str
    compiler_prefix: str  # e.g. "arm-none-eabi-"; the tools are <prefix>gcc, <prefix>ar, ...
    system_processor: str  # CMAKE_SYSTEM_PROCESSOR
    cpu_flags: tuple[str, ...]  # -mcpu/-march/-mfpu/-mfloat-abi: on every compile and link
    elf: ElfFacts
    install_hint: str = ""
    c_flags: tuple[str, ...] = ()
    cxx_flags: tuple[str, ...] = ()
    defines: tuple[str, ...] = ()  # defines the firmware needs too (ESP_PLATFORM, ...)
    link_flags: tuple[str, ...] = ()  # firmware links (specs files); never used for the library
    optimization: str = "-Os"
    c_standard: int = 11
    cxx_standard: int = 14
    micro_ros: MicroRosFlags = MicroRosFlags()
    transport: str = "custom"
    native_64bit_atomics: bool = False
    # where the compiler may live besides PATH (e.g. an ESP-IDF tools directory glob)
    compiler_search: tuple[str, ...] = ()
    source: str = ""  # the file it was loaded from, for messages

    def tool(self, name: str) -> str:
        return f"{self.compiler_prefix}{name}"


def _fail(source: Path | str, key: str, problem: str, hint: str | None = None) -> ConfigError:
    return ConfigError(
        f"{source}: {key}: {problem}",
        hint or "see toolchains/cortex-m7.yaml for a complete profile (uros targets lists them)",
    )


def _str_list(source: Path | str, key: str, value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _fail(source, key, f"must be a list of strings, got {value!r}")
    return tuple(value)


def _convert(source: Path | str, key: str, annotation: str, value: Any) -> Any:
    if annotation == "str":
        if not isinstance(value, str):
            raise _fail(source, key, f"must be a string, got {value!r}")
        return value
    if annotation == "int":
        if not isinstance(value, int) or isinstance(value, bool):
            raise _fail(source, key, f"must be a whole number, got {value!r}")
        return value
    if annotation == "bool":
        if not isinstance(value, bool):
            raise _fail(source, key, f"must be true or false, got {value!r}")
        return value
    if annotation == "tuple[str, ...]":
        return _str_list(source, key, value)
    if annotation == "tuple[tuple[str, str], ...]":
        if not isinstance(value, dict) or not all(isinstance(v, str) for v in value.values()):
            raise _fail(source, key, f"must be a mapping of names to strings, got {value!r}")
        return tuple(sorted((str(k), v) for k, v in value.items()))
    if annotation == "MicroRosFlags":
        return _build(MicroRosFlags, source, value, prefix=f"{key}.")
    if annotation == "ElfFacts":
        return _build(ElfFacts, source, value, prefix=f"{key}.")
    raise AssertionError(f"no converter for {annotation}")  # a programming error, not input


def _build(cls: Any, source: Path | str, data: Any, prefix: str = "") -> Any:
    if not isinstance(data, Mapping):
        raise _fail(source, prefix.rstrip(".") or "(top level)", "must be a mapping")
    known = {f.name: f for f in fields(cls) if f.name != "source"}
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise _fail(source, prefix + str(unknown[0]), f"unknown key (known: {', '.join(sorted(known))})")
    values: dict[str, Any] = {}
    for name, f in known.items():
        if name in data:
            values[name] = _convert(source, prefix + name, str(f.type), data[name])
        elif f.default is f.default_factory:  # both MISSING: a required field
            raise _fail(source, prefix + name, "is required but missing")
    return cls(**values)


def parse_profile(data: Any, source: Path | str) -> TargetProfile:
    profile: TargetProfile = _build(TargetProfile, source, data)
    if profile.transport not in TRANSPORTS:
        raise _fail(source, "transport", f"{profile.transport!r} is not one of {', '.join(TRANSPORTS)}")
    if not profile.optimization.startswith("-O"):
        raise _fail(source, "optimization", f"{profile.optimization!r} is not a -O flag")
    return TargetProfile(**{**profile.__dict__, "source": str(source)})


def load_profile_file(path: Path) -> TargetProfile:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read profile: {exc.strerror}", "check the --profile path") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{path}{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from exc
    return parse_profile(data, path)


def shipped_profiles() -> dict[str, TargetProfile]:
    profiles = {}
    for path in sorted(resources.toolchains_dir().glob("*.yaml")):
        profile = load_profile_file(path)
        if profile.name != path.stem:
            raise _fail(path, "name", f"{profile.name!r} differs from the file name {path.stem!r}")
        profiles[profile.name] = profile
    return profiles


def find_profile(name: str) -> TargetProfile:
    profiles = shipped_profiles()
    if name not in profiles:
        raise ConfigError(
            f"--toolchain: unknown target {name!r}",
            f"known targets: {', '.join(profiles)}; or pass a CMake toolchain file (path ending in .cmake)",
        )
    return profiles[name]
