"""Target profiles: ``toolchains/*.yaml`` loaded into frozen dataclasses, validated on load.

A profile is everything uros knows about one MCU target: which cross compiler, which CPU/FPU/ABI
flags, which defines only micro-ROS needs (MICROROSFLAGS), what the colcon.meta must add, and
which ELF facts every object built for it must show. Unknown keys and wrong types are errors
naming the file and the key; nothing past this module sees a raw dict.

The same keys, with these comments as descriptions, are a JSON Schema (draft 2020-12) in
``meta/schemas/profile.schema.json`` (``uros_build/_data/meta/schemas/`` in a wheel), for editors
that check YAML as it is typed; tests/unit/test_schemas.py keeps it equal to these dataclasses.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from uros_build import loader, resources, templating
from uros_build.errors import ConfigError, did_you_mean
from uros_build.target.memsize import SIZE_HELP, parse_bytes

TRANSPORTS = resources.transports()


@dataclass(frozen=True)
class MicroRosFlags:
    """Compile settings that apply to micro-ROS only, never to the firmware (the MICROROSFLAGS of
    micro-ROS's STM32 guides)."""

    # Plain -D defines, e.g. "CLOCK_MONOTONIC=0" for newlib, which has no monotonic clock id.
    defines: tuple[str, ...] = ()
    # Force-include a header declaring clock_gettime(): newlib without _POSIX_TIMERS declares none,
    # and rcutils/XRCE-DDS call it, which GCC >= 14 rejects as an implicit declaration.
    declare_clock_gettime: bool = False
    # The compiler has no C++ standard library headers (Debian's riscv64-unknown-elf, xtensa-lx106-elf):
    # micro-ROS's few C++ sources (rosidl_typesupport_c's dispatch, every interface's C type support)
    # include only <cstddef>, <cstdio> and <cstring>; uros hands them wrappers of the C headers.
    cxx_wrapper_headers: bool = False
    # -D'__attribute__(x)=' worked around GCC < 6 choking on attributes in micro-ROS headers; it
    # also strips rcl's constructor attributes, so uros only adds it where the compiler is older.
    strip_attributes_below_gcc: int = 0
    # The XRCE-DDS client's PLATFORM_NAME for its IP transports (udp, tcp), set in the micro-ROS
    # toolchain file: "LwIP" on ESP-IDF selects its lwIP BSD-socket transport
    # (UCLIENT_PLATFORM_POSIX_NOPOLL), as micro_ros_espidf_component's esp32_toolchain.cmake.in does.
    xrce_platform: str = ""


@dataclass(frozen=True)
class ElfFacts:
    """What ``readelf`` must report for every object built for the target."""

    machine: str  # readelf -h "Machine:" substring, e.g. "ARM", "RISC-V", "Tensilica Xtensa"
    elf_class: str = "ELF32"
    header_flags: tuple[str, ...] = ()  # substrings of readelf -h "Flags:" (RISC-V float ABI, ...)
    # readelf -A attributes that must match exactly, e.g. Tag_ABI_VFP_args: VFP registers.
    attributes: tuple[tuple[str, str], ...] = ()
    # readelf -A attributes that must not be there: Tag_FP_arch on a soft-float core, or
    # Tag_ABI_HardFP_use on a double-precision FPU (its "SP only" marks a single-precision one).
    attributes_absent: tuple[str, ...] = ()
    # readelf -A attributes whose value must match a regular expression (whole value), for values
    # that carry versions, e.g. Tag_RISCV_arch "rv32i2p1_m2p0_c2p0_zmmul1p0" with GCC 12.
    attribute_patterns: tuple[tuple[str, str], ...] = ()
    # The ABI= line of Xtensa's .xtensa.info section: "0" windowed (ESP32/S2/S3), "1" call0
    # (lx106/ESP8266). Xtensa objects carry no attributes and e_flags 0x300 on every core.
    xtensa_abi: str = ""


@dataclass(frozen=True)
class Chip:
    """The one chip a profile is for, where it names one (the RP2040, an ESP32-S3): what
    ``uros size`` measures a library against when no --ram/--flash is given."""

    # The chip's name as its maker writes it (RP2040, ESP32-S3).
    name: str = ""
    # On-chip SRAM, e.g. "264K" (K, KB, M, MB: 1024-based). The C library, the RTOS and, on an
    # ESP32, ESP-IDF's own drivers take some of it too.
    ram: str = ""
    # The flash the firmware runs from, e.g. "2M": on chips without flash of their own, the flash
    # of the common board or module the comment names.
    flash: str = ""

    @property
    def known(self) -> bool:
        return bool(self.ram or self.flash)

    @property
    def ram_bytes(self) -> int | None:
        return parse_bytes(self.ram) if self.ram else None

    @property
    def flash_bytes(self) -> int | None:
        return parse_bytes(self.flash) if self.flash else None


@dataclass(frozen=True)
class TargetProfile:
    name: str
    description: str
    compiler_prefix: str  # e.g. "arm-none-eabi-"; the tools are <prefix>gcc, <prefix>ar, ...
    system_processor: str  # CMAKE_SYSTEM_PROCESSOR
    cpu_flags: tuple[str, ...]  # -mcpu/-march/-mfpu/-mfloat-abi: on every compile and link
    elf: ElfFacts
    install_hint: str = ""
    # Selects the C library (picolibc's specs): on every C/C++ compile and link, micro-ROS and
    # firmware alike, since without it riscv64-unknown-elf-gcc finds no libc headers at all.
    libc_flags: tuple[str, ...] = ()
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
    # Operand sizes (bytes) whose __atomic_*/__sync_* library routines the platform defines none
    # of: an undefined reference to one in the library is reported, naming the objects. ESP-IDF
    # builds its 1/2/4-byte ones only for chips without S32C1I (ESP32-S2, RISC-V chips without A):
    # on an ESP32 or ESP32-S3 it expects the compiler to inline them.
    missing_atomics: tuple[str, ...] = ()
    # Folders (globs) holding <prefix>gcc when it is not on PATH, e.g. an ESP-IDF tools install:
    # "{IDF_TOOLS_PATH}/tools/xtensa-esp-elf/*/xtensa-esp-elf/bin" (see toolsearch.py).
    compiler_search: tuple[str, ...] = ()
    # ESP-IDF's IDF_TARGET (esp32s3, ...): the exported ESP-IDF component refuses other chips,
    # since an ESP32 and an ESP32-S3 object cannot be told apart by their ELF facts.
    idf_target: str = ""
    # The one chip the profile is for, where it names one (rp2040, esp32s3): its RAM and flash are
    # what `uros size` measures the library against when no --ram/--flash is given.
    chip: Chip = Chip()
    source: str = ""  # the file it was loaded from, for messages

    def tool(self, name: str) -> str:
        return f"{self.compiler_prefix}{name}"


_HINT = "start from a shipped profile: uros targets show cortex-m7 > my-board.yaml"


def _fail(source: Path | str, key: str, problem: str, hint: str | None = None) -> ConfigError:
    return ConfigError(f"{source}: {key}: {problem}", hint or _HINT)


def _convert(data: Mapping[str, Any], key: str, source: str, annotation: str) -> Any:
    if annotation == "str":
        return loader.string(data, key, source)
    if annotation == "int":
        return loader.integer(data, key, source)
    if annotation == "bool":
        return loader.boolean(data, key, source)
    if annotation == "tuple[str, ...]":
        return loader.string_list(data, key, source)
    if annotation == "tuple[tuple[str, str], ...]":
        return tuple(sorted(loader.string_map(data, key, source).items()))
    if annotation == "MicroRosFlags":
        return _build(MicroRosFlags, source, data[key], prefix=f"{key}.")
    if annotation == "ElfFacts":
        return _build(ElfFacts, source, data[key], prefix=f"{key}.")
    if annotation == "Chip":
        return _build(Chip, source, data[key], prefix=f"{key}.")
    raise AssertionError(f"no converter for {annotation}")  # a programming error, not input


def _build(cls: Any, source: str, data: Any, prefix: str = "") -> Any:
    """``cls`` from one mapping of the file. Keys are checked as dotted paths from the top of the
    file (``elf.machine``), so every message names the key as the file spells it."""
    where = f"{source}: {prefix.rstrip('.')}" if prefix else source
    top = loader.LineDict({f"{prefix}{k}": v for k, v in loader.mapping(data, where).items()})
    top.key_lines = {f"{prefix}{k}": n for k, n in getattr(data, "key_lines", {}).items()}
    known = {f.name: f for f in fields(cls) if f.name != "source"}
    required = tuple(
        prefix + name
        for name, f in known.items()
        if f.default is f.default_factory  # both MISSING: a required field
    )
    loader.mapping(top, source, {prefix + name for name in known}, required)
    values: dict[str, Any] = {}
    for name, f in known.items():
        key = prefix + name
        if key not in top:
            continue
        if top[key] is None:
            raise ConfigError(f"{source}: {key}: has no value (give one or leave the key out)")
        values[name] = _convert(top, key, source, str(f.type))
    return cls(**values)


_SEARCH_PLACEHOLDERS = ("{IDF_TOOLS_PATH}", "{IDF_PATH}")

# RISC-V: the float ABI each -mabi gives, as readelf -h prints it in "Flags:" (e_flags bits 1-2,
# EF_RISCV_FLOAT_ABI; binutils' readelf.c). ilp32f (the ESP32-P4, rv32imafc) passes floats in f
# registers, ilp32 in integer ones: GNU ld refuses to link the two ("can't link single-float modules
# with soft-float modules"), so a profile's -mabi and its elf.header_flags must say the same.
RISCV_FLOAT_ABI = {
    "ilp32": "soft-float ABI",
    "ilp32e": "soft-float ABI",
    "lp64": "soft-float ABI",
    "ilp32f": "single-float ABI",
    "lp64f": "single-float ABI",
    "ilp32d": "double-float ABI",
    "lp64d": "double-float ABI",
    "lp64q": "quad-float ABI",
}


def riscv_mabi(flags: tuple[str, ...]) -> str | None:
    """The last -mabi= of ``flags`` (GCC takes the last), or None."""
    found = [f.split("=", 1)[1] for f in flags if f.startswith("-mabi=")]
    return found[-1] if found else None


def riscv_float_abi(header_flags: str | tuple[str, ...]) -> str | None:
    """The float ABI named in readelf's "Flags:" text (or a profile's header_flags), or None."""
    text = header_flags if isinstance(header_flags, str) else ", ".join(header_flags)
    return next((abi for abi in sorted(set(RISCV_FLOAT_ABI.values())) if abi in text), None)


def _check_riscv_abi(profile: TargetProfile, source: Path | str) -> None:
    mabi = riscv_mabi(profile.cpu_flags)
    if profile.system_processor != "riscv" or mabi is None:
        return
    if mabi not in RISCV_FLOAT_ABI:
        raise _fail(
            source,
            "cpu_flags",
            f"-mabi={mabi} is not a RISC-V ABI GCC knows ({', '.join(RISCV_FLOAT_ABI)})",
            "e.g. -mabi=ilp32 (soft float) or -mabi=ilp32f (the ESP32-P4's single-precision FPU)",
        )
    said = riscv_float_abi(profile.elf.header_flags)
    if said is not None and said != RISCV_FLOAT_ABI[mabi]:
        raise _fail(
            source,
            "elf.header_flags",
            f"says '{said}', but cpu_flags' -mabi={mabi} makes objects with '{RISCV_FLOAT_ABI[mabi]}'",
            f"write header_flags: [RVC, {RISCV_FLOAT_ABI[mabi]}] (or change -mabi)",
        )


# A target's name is an identifier: it names <workspace>/.uros/targets/<name> and the default
# output <workspace>/build/<name>, so '..', '.', '' or 'a/b' would point those at the workspace
# itself (and `--force` once replaced it).
NAME = re.compile(r"[a-z0-9][a-z0-9._-]*")
NAME_MAX = 100


def check_name(name: str, source: Path | str) -> str:
    if not NAME.fullmatch(name) or len(name) > NAME_MAX:
        raise _fail(
            source,
            "name",
            f"{name!r} is not a target name: lower-case letters, digits, '.', '_' and '-', "
            f"starting with a letter or digit, at most {NAME_MAX} characters",
            "name the target like its file, e.g. name: my-board",
        )
    return name


# GCC's -O levels (https://gcc.gnu.org/onlinedocs/gcc/Optimize-Options.html): anything else is
# a typo that GCC would reject in every compile, or another flag passed where a level goes.
OPTIMIZATIONS = ("-O", "-O0", "-O1", "-O2", "-O3", "-Os", "-Oz", "-Og", "-Ofast")
# The values CMake's C_STANDARD and CXX_STANDARD take (CMake 3.25): another is refused by CMake
# only when a target is configured, deep in the build.
C_STANDARDS = (90, 99, 11, 17, 23)
CXX_STANDARDS = (98, 11, 14, 17, 20, 23, 26)
# One -D each: a macro name (function-like ones too, e.g. "__attribute__(x)="), then =VALUE; no
# control character, which would end a build.ninja line.
DEFINE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\([A-Za-z0-9_, .]*\))?(=[^\x00-\x1f\x7f]*)?")


def _validate(profile: TargetProfile, source: Path | str) -> TargetProfile:
    """Checks across fields, shared by profile files and command-line derivation."""
    check_name(profile.name, source)
    if profile.transport not in TRANSPORTS:
        raise _fail(source, "transport", f"{profile.transport!r} is not one of {', '.join(TRANSPORTS)}")
    if profile.optimization not in OPTIMIZATIONS:
        raise _fail(
            source,
            "optimization",
            f"{profile.optimization!r} is not one of GCC's levels: {', '.join(OPTIMIZATIONS)}",
            "e.g. optimization: -Os (small) or -O2 (fast)",
        )
    for key, allowed in (("c_standard", C_STANDARDS), ("cxx_standard", CXX_STANDARDS)):
        if getattr(profile, key) not in allowed:
            raise _fail(
                source,
                key,
                f"{getattr(profile, key)!r} is not one of CMake's: {', '.join(map(str, allowed))}",
                f"e.g. {key}: {allowed[2]}",
            )
    for key, defines in (("defines", profile.defines), ("micro_ros.defines", profile.micro_ros.defines)):
        for define in defines:
            if not DEFINE.fullmatch(define):
                raise _fail(
                    source,
                    key,
                    f"{define!r} is not a define: NAME or NAME=VALUE (NAME a C identifier, no line breaks)",
                    f"e.g. {key}: [USE_FOO, FOO_SIZE=4] (each becomes -D<define>)",
                )
    # A triplet prefix, optionally with its folder (/opt/arm-gnu-toolchain/bin/arm-none-eabi-).
    if not re.fullmatch(r"[^\n\r\0]*/?[A-Za-z0-9_.+-]+-", profile.compiler_prefix):
        raise _fail(
            source, "compiler_prefix", f"{profile.compiler_prefix!r} is not a prefix like 'arm-none-eabi-'"
        )
    # CMake writes CMAKE_SYSTEM_PROCESSOR unescaped into CMakeFiles/<version>/CMakeSystem.cmake,
    # which it then runs: anything but a plain word there would be code (measured, CMake 3.25).
    if not re.fullmatch(r"[A-Za-z0-9_.+-]+", profile.system_processor):
        raise _fail(source, "system_processor", f"{profile.system_processor!r} is not a word like 'arm'")
    unusable = templating.cmake_unusable(profile.compiler_prefix)
    if unusable is not None:
        raise _fail(
            source,
            "compiler_prefix",
            f"{profile.compiler_prefix!r} holds {unusable!r}, which CMake cannot use in a tool path",
            "move or link the toolchain to a folder without it",
        )
    for key in ("cpu_flags", "libc_flags", "c_flags", "cxx_flags", "link_flags"):
        for flag in getattr(profile, key):
            # One flag per entry: an empty one, or one with a line break or another control
            # character (which ends a build.ninja line), cannot be passed on as one word.
            if not flag or any(ord(c) < 32 or ord(c) == 127 for c in flag):
                raise _fail(source, key, f"{flag!r} is not a single compiler flag")
    for pattern in profile.compiler_search:
        for placeholder in re.findall(r"\{[^}]*\}", pattern):
            if placeholder not in _SEARCH_PLACEHOLDERS:
                raise _fail(
                    source,
                    "compiler_search",
                    f"unknown placeholder {placeholder} (known: {', '.join(_SEARCH_PLACEHOLDERS)})",
                )
    for tag, pattern in profile.elf.attribute_patterns:
        try:
            re.compile(pattern)
        except re.error as exc:
            raise _fail(source, f"elf.attribute_patterns.{tag}", f"not a regular expression: {exc}") from exc
    for size in profile.missing_atomics:
        if size not in ("1", "2", "4", "8", "16"):
            raise _fail(source, "missing_atomics", f"{size!r} is not an operand size (1, 2, 4, 8 or 16)")
    if not re.fullmatch(r"[A-Za-z0-9_]*", profile.micro_ros.xrce_platform):
        raise _fail(
            source,
            "micro_ros.xrce_platform",
            f"{profile.micro_ros.xrce_platform!r} is not a word like 'LwIP'",
        )
    for key in ("ram", "flash"):
        value = getattr(profile.chip, key)
        if value and parse_bytes(value) is None:
            raise _fail(source, f"chip.{key}", f"{value!r} is not a size: {SIZE_HELP}")
    _check_riscv_abi(profile, source)
    if profile.elf.xtensa_abi not in ("", "0", "1"):
        raise _fail(source, "elf.xtensa_abi", f"{profile.elf.xtensa_abi!r} is not 0 (windowed) or 1 (call0)")
    return replace(profile, source=str(source))


def parse_profile(data: Any, source: Path | str) -> TargetProfile:
    try:
        profile: TargetProfile = _build(TargetProfile, str(source), data)
    except ConfigError as exc:
        raise ConfigError(exc.message, exc.hint or _HINT) from None
    return _validate(profile, source)


# Architecture of a standalone --compiler-prefix: (CMAKE_SYSTEM_PROCESSOR, readelf "Machine:").
_PREFIX_ARCH = (
    ("arm", "arm", "ARM"),
    ("riscv", "riscv", "RISC-V"),
    ("xtensa", "xtensa", "Tensilica Xtensa"),
)


def derive_profile(
    base: TargetProfile | None, compiler_prefix: str | None, cflags: tuple[str, ...]
) -> TargetProfile:
    """A profile from the command line: a shipped/own profile with another compiler prefix and
    more flags, or (no base) one made from --compiler-prefix and --cflags alone. Validated like a
    file; the flags stay a list, each one word, all the way to the compiler."""
    source = "command line"
    if base is None:
        if not compiler_prefix:
            raise ConfigError(
                "--cflags without a target", "pass --toolchain NAME or --compiler-prefix PREFIX as well"
            )
        triplet = compiler_prefix.rsplit("/", 1)[-1]
        arch = next((a for a in _PREFIX_ARCH if triplet.startswith(a[0])), None)
        if arch is None:
            raise ConfigError(
                f"--compiler-prefix {compiler_prefix}: cannot tell the architecture from the prefix",
                "derive from a target (--toolchain NAME) or write a profile file (--profile my-board.yaml)",
            )
        # a triplet may hold upper-case letters or '+': the name is an identifier (check_name)
        name = "custom-" + re.sub(r"[^a-z0-9._-]", "-", triplet.rstrip("-").lower())
        profile = TargetProfile(
            name=name,
            description=f"from the command line: {compiler_prefix}gcc {' '.join(cflags)}".rstrip(),
            compiler_prefix=compiler_prefix,
            system_processor=arch[1],
            cpu_flags=cflags,
            elf=ElfFacts(machine=arch[2]),
        )
        return _validate(profile, source)
    profile = replace(
        base,
        name=f"{base.name}-custom",
        description=f"{base.description}, from the command line",
        compiler_prefix=compiler_prefix or base.compiler_prefix,
        c_flags=(*base.c_flags, *cflags),
        cxx_flags=(*base.cxx_flags, *cflags),
    )
    return _validate(profile, source)


def load_profile_file(path: Path) -> TargetProfile:
    return parse_profile(loader.load_yaml(path), path)


def shipped_profiles() -> dict[str, TargetProfile]:
    profiles = {}
    for path in sorted(resources.toolchains_dir().glob("*.yaml")):
        profile = load_profile_file(path)
        if profile.name != path.stem:
            raise _fail(path, "name", f"{profile.name!r} differs from the file name {path.stem!r}")
        profiles[profile.name] = profile
    return profiles


# What else each command accepts in place of a target name, for the hint of a typo.
OR_TOOLCHAIN_FILE = "or pass your own CMake toolchain file (a path ending in .cmake)"
OR_PROFILE_FILE = "or pass your own profile (a path ending in .yaml)"


def find_profile(name: str, flag: str = "--toolchain", alternative: str = OR_TOOLCHAIN_FILE) -> TargetProfile:
    """A shipped profile by name; a typo is an error naming the closest names and what else
    ``flag`` takes (``alternative``; "" for nothing else)."""
    path = resources.toolchains_dir() / f"{name}.yaml"
    if "/" not in name and path.is_file():
        # the one file (a build with nothing to do should not parse all fourteen)
        profile = load_profile_file(path)
        if profile.name != path.stem:
            raise _fail(path, "name", f"{profile.name!r} differs from the file name {path.stem!r}")
        return profile
    profiles = shipped_profiles()
    if name not in profiles:
        raise ConfigError(
            f"{flag}: unknown target {name!r}{did_you_mean(name, profiles)}",
            f"known targets: {', '.join(profiles)}" + (f"; {alternative}" if alternative else ""),
        )
    return profiles[name]
