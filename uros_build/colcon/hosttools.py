"""What the host and the target's tools are: compiler location and version, C library and C++
headers, CMake's version, the colcon program, the archiver CMake chose, and the environment colcon
runs in. Probes run tools through the runner and return frozen facts. Two things here act
rather than look, because a probe needs them first: the host tools workspace (dev_ws) is built
when it is missing or out of date (build_dev_workspace), and CMake's compiler facts are found by
configuring a tiny project (cmake_compiler_facts).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from uros_build import console
from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint, relocate
from uros_build.errors import DiskFull, MissingToolError, StepFailed, UrosError
from uros_build.files import write_atomic
from uros_build.proc import Runner
from uros_build.sources import distros as distros_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.distros import Distro
from uros_build.sources.packages import PackageInfo
from uros_build.sources.workspace import Workspace, dev_env
from uros_build.sources.wsfiles import WorkspaceConfig
from uros_build.target import abi, toolsearch
from uros_build.target.profiles import TargetProfile
from uros_build.target.toolchain import tool_paths
from uros_build.target.toolsearch import BinTools


@dataclass(frozen=True)
class HostFacts:
    cmake: str
    cmake_version: str
    colcon: str
    gcc: str = ""  # the target's C compiler, absolute ("" for the user's own toolchain file)
    gcc_version: str = ""
    tool_dir: str | None = None  # where the target's tools are when not on PATH (ESP-IDF install)

    @property
    def gcc_major(self) -> int | None:
        return major(self.gcc_version)


@dataclass
class ProbeCache:
    """Answers of probes that start a process (``cmake --version``, ``gcc -dumpversion``, the C
    library and C++ header checks), kept in a file and keyed by the identity of the programs
    they ran (path, size, mtime, inode: :func:`fingerprint.stat_key`), so that a build with
    nothing to do starts no process to find out. ``path`` None: no cache."""

    path: Path | None = None
    _data: dict[str, str] = field(default_factory=dict)
    _loaded: bool = False

    def get(self, key: str, compute: Callable[[], str]) -> str:
        if self.path is None:
            return compute()
        if not self._loaded:
            self._loaded = True
            try:
                loaded = json.loads(self.path.read_text(encoding="utf-8"))
                self._data = {str(k): str(v) for k, v in loaded.items()} if isinstance(loaded, dict) else {}
            except (OSError, ValueError):
                self._data = {}
        if key not in self._data:
            self._data[key] = compute()
            write_atomic(self.path, json.dumps(self._data, indent=1, sort_keys=True) + "\n")
        return self._data[key]


def first_version(text: str) -> str:
    """The first word that looks like a version (``cmake version 3.25.1`` -> ``3.25.1``)."""
    lines = text.splitlines()
    for line in lines:
        for word in line.split():
            if word[:1].isdigit() and "." in word:
                return word
    return lines[0].strip() if lines else ""


def major(version: str) -> int | None:
    head = version.split(".", 1)[0]
    return int(head) if head.isdigit() else None


def colcon_program() -> str:
    """colcon beside uros's own Python (a venv's bin/), else whatever is on PATH."""
    beside = Path(colcon.host_python()).parent / "colcon"
    return str(beside) if beside.is_file() else "colcon"


def cmake_version(runner: Runner, cache: ProbeCache | None = None) -> tuple[str, str]:
    cmake = runner.which("cmake")
    key = f"cmake --version {fingerprint.stat_key(Path(cmake))}"
    return cmake, (cache or ProbeCache()).get(
        key, lambda: first_version(runner.query([cmake, "--version"], step="cmake --version"))
    )


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


def probe_host(
    runner: Runner,
    profile: TargetProfile | None,
    scratch: Path,
    check_libraries: bool,
    cache: ProbeCache | None = None,
) -> HostFacts:
    """Every tool a build needs, found before anything is built; what needs a process to find
    out is answered from ``cache`` while the programs are the same files."""
    cache = cache or ProbeCache()
    cmake, version = cmake_version(runner, cache)
    colcon_prog = runner.which(colcon_program())
    if profile is None:
        return HostFacts(cmake, version, colcon_prog)
    tools, tool_dir = probe_target_tools(runner, profile)
    # the ABI check reads the library with the host's readelf after the build: found now, a
    # missing one costs seconds rather than the whole build
    runner.which(abi.READELF, abi.READELF_HINT)
    gcc_id = fingerprint.stat_key(Path(tools["gcc"]))
    gcc_version = cache.get(
        f"gcc -dumpversion {gcc_id}",
        lambda: runner.query([tools["gcc"], "-dumpversion"], step="gcc -dumpversion").strip(),
    )
    if check_libraries:
        flags = " ".join([*profile.cpu_flags, *profile.libc_flags])
        key = f"prerequisites {gcc_id} {fingerprint.stat_key(Path(tools['g++']))} {flags}"

        def check() -> str:
            check_target_prerequisites(runner, profile, tools, scratch)
            return "ok"  # a failed check raises: only a passed one is remembered

        cache.get(key, check)
    return HostFacts(cmake, version, colcon_prog, tools["gcc"], gcc_version, tool_dir)


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


def colcon_env(
    ws: Workspace,
    cfg: WorkspaceConfig | None,
    distro: Distro | None,
    cmake_version: str,
    with_dev: bool = True,
) -> tuple[dict[str, str], list[str]]:
    """The environment colcon runs in: sourced ROS 2 scrubbed, uros's Python first, and for a
    firmware workspace its dev_ws (as if sourced) and git redirects for the build-time clones of
    its ``distro`` (the plan's, loaded once)."""
    git_config = None
    if cfg is not None and distro is not None:
        git_config = distros_mod.insteadof(distro.build_time_clones, cfg.mirror)
    env, scrubbed = colcon.build_env(
        os.environ,
        python_bin_dir=str(Path(colcon.host_python()).parent),
        cmake_major=major(cmake_version),
        git_config=git_config,
    )
    if cfg is not None and with_dev:
        env = dev_env(env, ws.dev_install)
    return env, scrubbed


DEV_PACKAGES = ".uros-dev-packages.json"  # in dev_ws/install: what the dev build built, of what


def dev_record(ws: Workspace) -> tuple[frozenset[str], frozenset[str]] | None:
    """(built, available): the dev_ws packages the last dev build built and those dev_ws had
    then; None for a dev_ws built whole (before uros built only the closure)."""
    try:
        data = json.loads((ws.dev_install / DEV_PACKAGES).read_text(encoding="utf-8"))
        return frozenset(data["built"]), frozenset(data["available"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def dev_needs_building(ws: Workspace, mcu: Sequence[PackageInfo]) -> bool:
    """dev_ws was never built, or the MCU packages now need a dev_ws package it did not build
    (a new extra package that finds another ament_cmake extension). Reads no package.xml."""
    if not ws.dev_built():
        return True
    record = dev_record(ws)
    if record is None:
        return False
    built, available = record
    wanted = {d for p in mcu for d in p.build_deps} & available
    return not wanted <= built


def build_dev_workspace(
    ws: Workspace,
    cfg: WorkspaceConfig,
    distro: Distro | None,  # None: a uros.yaml without one (no build-time clones to redirect)
    runner: Runner,
    verbose: bool,
    jobs: int | None = None,
) -> None:
    """Build the part of dev_ws (ament and friends) the MCU packages need, for the host; every
    target reuses it. micro_ros_setup builds all of it, uncrustify and a dozen linters included,
    which a BUILD_TESTING=OFF cross build never calls."""
    dev = packages_mod.discover(ws.dev_dir)
    needed = packages_mod.tool_closure(packages_mod.discover(ws.source_dir), dev)
    console.step(
        f"building the host tools workspace (dev_ws): {len(needed)} of its {len(dev)} packages, "
        "those the MCU packages need"
    )
    if needed:
        relocate.reconfigure_moved(ws.dev_dir / "build", "dev_ws")
        _cmake, version = cmake_version(runner)
        env, _ = colcon_env(ws, cfg, distro, version, with_dev=False)
        plan = colcon.ColconPlan(
            base_paths=(ws.dev_dir,),
            build_base=ws.dev_dir / "build",
            install_base=ws.dev_install,
            log_base=ws.dev_dir / "log",
            metas=(),
            toolchain_file=None,
            firmware=False,
            python=colcon.host_python(),
            generator=colcon.generator(env),
            verbose=verbose,
            parallel_workers=jobs,
            ignore_regex=None,
            packages_ignore=tuple(sorted({p.name for p in dev} - needed)),
        )
        runner.run(
            colcon.colcon_argv(plan, runner.which(colcon_program())),
            step="colcon build (dev_ws)",
            cwd=ws.dev_dir,
            env=env,
        )
    ws.dev_install.mkdir(parents=True, exist_ok=True)
    record = {"built": sorted(needed), "available": sorted(p.name for p in dev)}
    (ws.dev_install / DEV_PACKAGES).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    ws.mark_dev_built()


# ---------------------------------------------------------------------------------------------
# CMake's compiler facts, found once per target (issue 19, item 1)

SEED_LANGUAGES = ("C", "CXX")


@dataclass(frozen=True)
class CompilerFacts:
    """What CMake found about a target's compilers in one tiny project."""

    languages: Mapping[str, str]  # language -> the text of CMakeFiles/<version>/CMake<LANG>Compiler.cmake
    executable_format: str  # CMAKE_EXECUTABLE_FORMAT, which identification caches ("" when it did not)
    archive_plugin: str = ""  # GCC's LTO plugin, for GNU ar (:func:`archive_plugin`); "": none


# The probe project also asks the C compiler where its LTO plugin is and the archiver what it is
# (for :func:`archive_plugin`); CMake writes both answers to this file.
_PROBE_ARCHIVER = "uros-archiver.txt"
_PROBE_PROJECT = """cmake_minimum_required(VERSION 3.12)
project(uros_compiler_facts C CXX)
execute_process(COMMAND "${CMAKE_C_COMPILER}" -print-file-name=liblto_plugin.so
  OUTPUT_VARIABLE plugin ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
execute_process(COMMAND "${CMAKE_AR}" --version OUTPUT_VARIABLE ar_version ERROR_QUIET)
file(WRITE "${CMAKE_BINARY_DIR}/"""
_PROBE_PROJECT += _PROBE_ARCHIVER + '" "${plugin}\\n${ar_version}")\n'

_PLAIN_PATH = re.compile(r"/[A-Za-z0-9_./+-]+")


def archive_plugin(probe: str) -> str:
    """The LTO plugin to name to the archiver, from the probe's answers (the C compiler's
    ``-print-file-name=liblto_plugin.so``, then ``ar --version``): GCC's plugin when the archiver
    is GNU ar and the compiler gave an absolute path of plain characters (it goes into a command
    line unquoted); "" otherwise (the archive rules stay CMake's own).

    Why: GNU ar, indexing an archive, loads every plugin in the bfd-plugins folder unless one is
    named; where LLVM's linker tools are installed that is LLVMgold, which loads libLLVM (measured
    here: ranlib 33-39 ms an archive, 7 ms with GCC's plugin named; a micro-ROS target makes 110).
    https://sourceware.org/binutils/docs/binutils/ar-cmdline.html (--plugin)"""
    plugin, _, version = probe.partition("\n")
    plugin = plugin.strip()
    first = version.strip().splitlines()[0] if version.strip() else ""
    if not first.startswith("GNU ar ") or not _PLAIN_PATH.fullmatch(plugin):
        return ""
    return plugin


def cmake_compiler_facts(
    runner: Runner,
    cmake: str,
    toolchain_file: Path,
    scratch: Path,
    generator: str | None,
    env: Mapping[str, str],
) -> CompilerFacts | None:
    """What CMake finds out about the target's compilers (identification, ABI, implicit folders,
    compile features: its ``CMakeFiles/<version>/CMake<LANG>Compiler.cmake``), from one tiny
    project configured with the toolchain file; None (the build then goes without) when CMake
    could not make them, for instance a target without a C++ compiler."""
    shutil.rmtree(scratch, ignore_errors=True)
    source = scratch / "src"
    source.mkdir(parents=True)
    (source / "CMakeLists.txt").write_text(_PROBE_PROJECT, encoding="utf-8")
    argv = [cmake, "-S", str(source), "-B", str(scratch / "build")]
    argv.append(f"-DCMAKE_TOOLCHAIN_FILE={toolchain_file}")
    if generator:
        argv.append(f"-G{generator}")
    try:
        runner.query(argv, step="find the target compilers' facts (once per target)", env=env)
    except UrosError:
        return None
    found = {}
    for lang in SEED_LANGUAGES:
        files = sorted((scratch / "build" / "CMakeFiles").glob(f"*/CMake{lang}Compiler.cmake"))
        if len(files) != 1:
            return None
        found[lang] = files[0].read_text(encoding="utf-8")
    try:
        cache = (scratch / "build" / "CMakeCache.txt").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    fmt = re.search(r"^CMAKE_EXECUTABLE_FORMAT:INTERNAL=(.*)$", cache, re.MULTILINE)
    try:
        plugin = archive_plugin((scratch / "build" / _PROBE_ARCHIVER).read_text(encoding="utf-8"))
    except OSError:
        plugin = ""
    if plugin and not Path(plugin).is_file():
        plugin = ""
    shutil.rmtree(scratch, ignore_errors=True)
    return CompilerFacts(found, fmt[1] if fmt else "", plugin)


def ccache_unusable(runner: Runner, ccache: str, env: Mapping[str, str]) -> str | None:
    """Why this ccache cannot compile here (a cache or temporary folder that is a file or that it
    cannot write in; a ccache that cannot say its settings: a broken ccache.conf), or None. ccache
    then fails every compile: the build compiles without it instead (a cache is never why a build
    fails), and `uros doctor` says so."""
    try:
        shown = runner.query([ccache, "--show-config"], step="ccache --show-config", env=env)
    except (StepFailed, DiskFull) as exc:
        return exc.message
    return colcon.ccache_trouble(colcon.ccache_settings(shown))
