"""``build-info.json``: what one `uros build` did, as a frozen value written once and read back.

It says what was built, from what, with what: the same inputs give the same bytes (timings live
in the target's timings.json and the run log; a build-info.json written before that may still hold
``package_seconds``, which is read past). The build writes it; ``uros export`` and the output
guard read it back through :func:`read_build_info`, which validates it like any other input, so a
hand-edited or truncated file is a one-line error rather than a KeyError deep in an exporter.
JSON with sorted keys.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from uros_build import loader
from uros_build.defaults import BUILD_INFO
from uros_build.errors import ConfigError

# Written into every output uros creates: how the output guard tells a uros output from a user's
# folder that merely holds a file called build-info.json.
GENERATOR = "uros"


@dataclass(frozen=True)
class Compiler:
    path: str
    version: str


@dataclass(frozen=True)
class Flags:
    cpu: tuple[str, ...] = ()
    c: tuple[str, ...] = ()
    cxx: tuple[str, ...] = ()
    optimization: str | None = None
    micro_ros_only: tuple[str, ...] = ()


@dataclass(frozen=True)
class Library:
    file: str
    bytes: int
    sha256: str
    members: int
    defined_global_symbols: int
    renamed_duplicate_members: int
    inputs: tuple[str, ...]
    size: Mapping[str, int] | None = None  # text/data/bss from <prefix>size, where a profile names it
    # global symbol -> the members that define it, where more than one does (output/symbols.py)
    duplicate_globals: Mapping[str, tuple[str, ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class Include:
    dir: str
    files: int
    bytes: int
    packages: int


@dataclass(frozen=True)
class IdfInfo:
    """The ESP-IDF project micro-ROS was compiled against (`uros build --idf-build`)."""

    version: str  # "5.3.1"
    target: str  # its IDF_TARGET
    sdkconfig_sha256: str  # of its build/config/sdkconfig.h
    components: int
    include_dirs: int
    c_flags: tuple[str, ...] = ()  # its CMAKE_C_FLAGS (response files expanded)
    cxx_flags: tuple[str, ...] = ()


@dataclass(frozen=True)
class RtosInfo:
    """The RTOS micro-ROS was compiled against (`uros build --rtos`; docs/rtos.md)."""

    name: str  # "freertos"
    kernel: str  # the kernel's folder (holds include/FreeRTOS.h)
    port: str  # the port folder(s) under the kernel's portable/ (GCC/ARM_CM7/r0p1), or absolute
    config: str  # the folder holding FreeRTOSConfig.h
    headers_sha256: str  # the kernel's include/*.h, the port's *.h and FreeRTOSConfig.h (target/rtos.py)


@dataclass(frozen=True)
class IpStackInfo:
    """The IP stack the udp transport was compiled against (`uros build --ip-stack`; docs/network.md)."""

    name: str  # "lwip"
    dir: str  # the stack's folder
    config: str  # the folder holding lwipopts.h and arch/cc.h
    platform: str  # the XRCE-DDS client's PLATFORM_NAME (LwIP)
    headers_sha256: str  # the stack's headers, its RTOS port's and the config folder's (target/ipstack.py)


@dataclass(frozen=True)
class BuildInfo:
    generated_by: str
    target: str
    profile: str | None  # the profile file's name; None for the user's own toolchain file
    toolchain_file: str | None
    compiler: Compiler | None
    cmake_version: str
    flags: Flags
    transport: str | None
    packages: tuple[str, ...]
    library: Library
    include: Include
    # abi.verify's summary (expects/result/objects/...): its shape belongs to abi.py
    abi_check: Mapping[str, Any] = field(default_factory=dict)
    skipped_python_packages: tuple[str, ...] = ()
    # of ``packages``, those that compile nothing and were built once for the workspace, for the
    # host, and copied into this target's install tree (the host stage; absent: none)
    host_stage_packages: tuple[str, ...] = ()
    idf_target: str | None = None
    idf: IdfInfo | None = None
    # the RTOS micro-ROS was compiled against; None (written as null): none, bare metal
    rtos: RtosInfo | None = None
    # the IP stack the udp transport was compiled against; None (null): none, or ESP-IDF's own
    ip_stack: IpStackInfo | None = None
    # the CMake options (-D) of each package's cmake-args in the colcon.meta this build used
    cmake_options: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    # package -> {"repository", "commit"}: the clone it was built from and that clone's HEAD then
    sources: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    # the build's inputs by content alone (no paths, times or inodes): equal on every machine that
    # builds the same sources, meta, profile and compiler with the same uros
    build_key: str = ""
    # {"url", "key", "archive_sha256"} when this output was taken from a team cache, not built here
    from_cache: Mapping[str, str] = field(default_factory=dict)
    # {"hits", "misses"}: this build's compiles through ccache (absent: no ccache)
    ccache: Mapping[str, int] = field(default_factory=dict)

    def to_json(self) -> str:
        data = asdict(self)
        for key in ("idf_target", "idf"):
            if data[key] is None:
                del data[key]
        for key in ("from_cache", "ccache", "host_stage_packages"):
            if not data[key]:
                del data[key]
        if data["library"]["size"] is None:
            del data["library"]["size"]
        return json.dumps(_lists(data), indent=2, sort_keys=True) + "\n"


def _lists(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_lists(v) for v in value]
    return value


def _tuple(data: Mapping[str, Any], key: str, source: str) -> tuple[str, ...]:
    return loader.string_list(data, key, source)


def _optional(data: Mapping[str, Any], key: str, source: str) -> str | None:
    value = data.get(key)
    if value is not None and not isinstance(value, str):
        raise ConfigError(f"{source}: {key}: must be a string, got {value!r}")
    return value or None


def _count(data: Mapping[str, Any], key: str, source: str) -> int:
    value = loader.integer(data, key, source, 0)
    if value < 0:
        raise ConfigError(f"{source}: {key}: must be 0 or more, got {value}")
    return value


def parse_build_info(data: Any, source: str) -> BuildInfo:
    """The dataclass from parsed JSON; a ConfigError naming the key on anything malformed."""
    top = loader.mapping(data, source)
    flags = loader.mapping(top.get("flags"), f"{source}: flags")
    lib_where = f"{source}: library"
    lib = loader.mapping(top.get("library"), lib_where, required=("file", "sha256"))
    inc = loader.mapping(top.get("include"), f"{source}: include")
    comp = top.get("compiler")
    compiler = None
    if comp is not None:
        comp = loader.mapping(comp, f"{source}: compiler")
        compiler = Compiler(str(comp.get("path", "")), str(comp.get("version", "")))
    size = None
    if lib.get("size") is not None:
        sizes = loader.mapping(lib["size"], f"{lib_where}: size")
        size = {str(k): _count(sizes, k, f"{lib_where}: size") for k in sizes}
    return BuildInfo(
        generated_by=loader.string(top, "generated_by", source),
        target=loader.string(top, "target", source),
        profile=_optional(top, "profile", source),
        toolchain_file=_optional(top, "toolchain_file", source),
        compiler=compiler,
        cmake_version=str(top.get("cmake_version", "")),
        flags=Flags(
            cpu=_tuple(flags, "cpu", f"{source}: flags"),
            c=_tuple(flags, "c", f"{source}: flags"),
            cxx=_tuple(flags, "cxx", f"{source}: flags"),
            optimization=_optional(flags, "optimization", f"{source}: flags"),
            micro_ros_only=_tuple(flags, "micro_ros_only", f"{source}: flags"),
        ),
        transport=_optional(top, "transport", source),
        packages=_tuple(top, "packages", source),
        library=Library(
            file=loader.string(lib, "file", lib_where),
            bytes=_count(lib, "bytes", lib_where),
            sha256=loader.string(lib, "sha256", lib_where),
            members=_count(lib, "members", lib_where),
            defined_global_symbols=_count(lib, "defined_global_symbols", lib_where),
            renamed_duplicate_members=_count(lib, "renamed_duplicate_members", lib_where),
            inputs=_tuple(lib, "inputs", lib_where),
            size=size,
            duplicate_globals=_string_lists(lib.get("duplicate_globals"), f"{lib_where}: duplicate_globals"),
        ),
        include=Include(
            dir=loader.string(inc, "dir", f"{source}: include", "include"),
            files=_count(inc, "files", f"{source}: include"),
            bytes=_count(inc, "bytes", f"{source}: include"),
            packages=_count(inc, "packages", f"{source}: include"),
        ),
        abi_check=dict(loader.mapping(top.get("abi_check"), f"{source}: abi_check")),
        skipped_python_packages=_tuple(top, "skipped_python_packages", source),
        host_stage_packages=_tuple(top, "host_stage_packages", source),
        idf_target=_optional(top, "idf_target", source),
        idf=_idf(top.get("idf"), f"{source}: idf"),
        rtos=_rtos(top.get("rtos"), f"{source}: rtos"),
        ip_stack=_ip_stack(top.get("ip_stack"), f"{source}: ip_stack"),
        cmake_options=_nested_strings(top.get("cmake_options"), f"{source}: cmake_options"),
        sources=_nested_strings(top.get("sources"), f"{source}: sources"),
        build_key=str(top.get("build_key", "")),
        from_cache=loader.string_map(top, "from_cache", source) if top.get("from_cache") else {},
        ccache=_counts(top.get("ccache"), f"{source}: ccache"),
    )


def _counts(value: Any, where: str) -> dict[str, int]:
    if value is None:
        return {}
    data = loader.mapping(value, where)
    return {str(k): _count(data, k, where) for k in data}


def _string_lists(data: Any, where: str) -> dict[str, tuple[str, ...]]:
    """{name: [string, ...]} (absent: empty, for a build-info written before the key existed)."""
    top = loader.mapping(data, where)
    return {str(k): loader.string_list(top, k, where) for k in top}


def _nested_strings(data: Any, where: str) -> dict[str, dict[str, str]]:
    """{name: {key: string}} (absent: empty, for a build-info written before the key existed)."""
    if data is None:
        return {}
    top = loader.mapping(data, where)
    return {str(k): dict(loader.string_map(top, k, where)) for k in top}


def _idf(data: Any, where: str) -> IdfInfo | None:
    if data is None:
        return None
    idf = loader.mapping(data, where, required=("version", "target", "sdkconfig_sha256"))
    return IdfInfo(
        version=loader.string(idf, "version", where),
        target=loader.string(idf, "target", where),
        sdkconfig_sha256=loader.string(idf, "sdkconfig_sha256", where),
        components=_count(idf, "components", where),
        include_dirs=_count(idf, "include_dirs", where),
        c_flags=_tuple(idf, "c_flags", where),
        cxx_flags=_tuple(idf, "cxx_flags", where),
    )


def _rtos(data: Any, where: str) -> RtosInfo | None:
    if data is None:
        return None
    keys = ("name", "kernel", "port", "config", "headers_sha256")
    rtos = loader.mapping(data, where, required=keys)
    return RtosInfo(*(loader.string(rtos, key, where) for key in keys))


def _ip_stack(data: Any, where: str) -> IpStackInfo | None:
    if data is None:
        return None
    keys = ("name", "dir", "config", "platform", "headers_sha256")
    stack = loader.mapping(data, where, required=keys)
    return IpStackInfo(*(loader.string(stack, key, where) for key in keys))


def read_build_info(out: Path, flag: str = "--from") -> BuildInfo:
    path = out / BUILD_INFO
    hint = "point at the output folder of `uros build` (default <workspace>/build/<target>)"
    if not path.is_file():
        raise ConfigError(f"{flag} {out}: no {BUILD_INFO} there, so it is not a uros build output", hint)
    info = parse_build_info(loader.load_json(path, flag, hint), f"{flag} {path}")
    if not info.generated_by.startswith(GENERATOR):
        raise ConfigError(f"{flag} {path}: not written by uros", hint)
    return info
