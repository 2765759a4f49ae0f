"""The target's tools: where its compiler is (PATH, or a profile's search folders such as ESP-IDF's
install), whether it has a C library and C++ headers for the profile's flags, the archiver CMake
chose for a user's own toolchain file, and an archive's sizes. Probes run tools through the runner."""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path

from uros_build import console
from uros_build.errors import MissingToolError, StepFailed
from uros_build.proc import Runner
from uros_build.target import toolsearch
from uros_build.target.profiles import TargetProfile
from uros_build.target.toolchain import tool_paths
from uros_build.target.toolsearch import BinTools


def locate_compiler(runner: Runner, profile: TargetProfile) -> str | None:
    """None when <prefix>gcc is on PATH, else the profile's compiler_search folder holding it."""
    gcc = profile.tool("gcc")
    try:
        runner.which(gcc, profile.install_hint or None)
        return None
    except MissingToolError:
        if not profile.compiler_search:
            raise
    found = toolsearch.search_compiler(profile, os.environ, Path.home())
    if found is None:
        places = toolsearch.searched_places(profile, os.environ, Path.home())
        raise MissingToolError(
            f"'{gcc}' was found neither on PATH nor in {' or '.join(places)}", profile.install_hint or None
        )
    console.info(f"using {found / gcc} (not on PATH)")
    return str(found)


def find_libc(runner: Runner, profile: TargetProfile, tools: Mapping[str, str]) -> str | None:
    """The target's libc.a as its compiler finds it with the profile's flags, or None."""
    flags = [tools["gcc"], *profile.cpu_flags, *profile.libc_flags]
    libc = runner.query([*flags, "-print-file-name=libc.a"], step="find libc").strip()
    # GCC prints the bare name back when it finds no such file
    if libc and Path(libc).is_absolute():
        return libc
    # picolibc's specs add its library folder to the link only (-L...%M), where -print-file-name
    # does not look (measured: riscv64-unknown-elf-gcc --specs=picolibc.specs prints "libc.a")
    specs = next((f.removeprefix("--specs=") for f in profile.libc_flags if f.startswith("--specs=")), None)
    if specs is None:
        return None
    if not Path(specs).is_absolute():
        specs = runner.query(
            [tools["gcc"], f"-print-file-name={specs}"], step="find the C library's specs"
        ).strip()
    multi = runner.query([*flags, "-print-multi-directory"], step="find libc").strip()
    try:
        text = Path(specs).read_text(encoding="utf-8")
    except OSError:
        return None
    for folder in specs_library_dirs(text, multi):
        if (Path(folder) / "libc.a").is_file():
            return str(Path(folder) / "libc.a")
    return None


def specs_library_dirs(specs: str, multi: str) -> list[str]:
    """The default -L folders a GCC specs file's link rule names, %M as the multilib folder
    ("-L%{-picolibc-prefix=*:...; :/usr/lib/picolibc/riscv64-unknown-elf/lib/%M}")."""
    return [found.replace("%M", multi) for found in re.findall(r":(/[^\s;{}:]+)\}", specs)]


def has_cxx_headers(runner: Runner, profile: TargetProfile, tools: Mapping[str, str], scratch: Path) -> bool:
    """Whether the target's g++ compiles ``#include <cstdint>`` with the profile's flags."""
    probe = scratch / "uros_cxx_probe.cpp"
    probe.parent.mkdir(parents=True, exist_ok=True)
    probe.write_text("#include <cstdint>\nstd::uint8_t uros_probe;\n", encoding="utf-8")
    try:
        runner.query(
            [tools["g++"], *profile.cpu_flags, *profile.libc_flags, "-fsyntax-only", str(probe)],
            step="find C++ headers",
        )
    except StepFailed:
        return False
    return True


def check_target_prerequisites(
    runner: Runner, profile: TargetProfile, tools: Mapping[str, str], scratch: Path
) -> None:
    """Real micro-ROS needs the target's C library and C++ headers (humble's rosidl_typesupport_c
    has .cpp sources): say which package is missing before a long build fails on it."""
    hint = profile.install_hint or None
    if find_libc(runner, profile, tools) is None:
        raise MissingToolError(f"{profile.tool('gcc')} has no C library (libc.a) for {profile.name}", hint)
    if not profile.micro_ros.cxx_wrapper_headers and not has_cxx_headers(runner, profile, tools, scratch):
        message = f"{profile.tool('g++')} has no C++ standard headers for {profile.name}"
        raise MissingToolError(message, hint)


def probe_target_tools(runner: Runner, profile: TargetProfile) -> tuple[dict[str, str], str | None]:
    """The target's tools, each checked to exist (exit 3 naming the package otherwise)."""
    tool_dir = locate_compiler(runner, profile)
    tools = tool_paths(profile, tool_dir)
    for tool in ("gcc", "g++", "ar", "ranlib", "nm", "size"):
        tools[tool] = runner.which(tools[tool], profile.install_hint or None)
    return tools, tool_dir


def bintools_from_build(build_base: Path) -> BinTools | None:
    """The archiver CMake recorded for a user's toolchain file (CMakeCache.txt of any package)."""
    for cache in sorted(build_base.glob("*/CMakeCache.txt")):
        values: dict[str, str] = {}
        for line in cache.read_text(encoding="utf-8", errors="replace").splitlines():
            for key in ("CMAKE_AR", "CMAKE_RANLIB", "CMAKE_NM"):
                if line.startswith(f"{key}:"):
                    values[key] = line.split("=", 1)[1]
        if values.get("CMAKE_AR") and values.get("CMAKE_NM"):
            return BinTools(
                ar=values["CMAKE_AR"], ranlib=values.get("CMAKE_RANLIB") or "ranlib", nm=values["CMAKE_NM"]
            )
    return None


def size_totals(runner: Runner, size_tool: str, library: Path) -> dict[str, int]:
    """text/data/bss of a whole archive (``size -t``'s TOTALS line)."""
    text = runner.query([size_tool, "-t", str(library)], step="measure libmicroros.a")
    for line in reversed(text.splitlines()):
        parts = line.split()
        if "(TOTALS)" in line and len(parts) >= 3 and all(p.isdigit() for p in parts[:3]):
            return {"text": int(parts[0]), "data": int(parts[1]), "bss": int(parts[2])}
    return {}
