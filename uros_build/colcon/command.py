"""colcon command lines and build environments (pure functions)."""

from __future__ import annotations

import glob
import os
import re
import shutil
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

# Variables of a sourced ROS 2 (or other colcon) environment that would make the cross build pick
# host packages instead of the workspace's own, plus host compiler flags that CMake would read
# into the cross compiler's flags ($ENV{CFLAGS} in CMakeCInformation.cmake).
SCRUBBED_VARIABLES = (
    "AMENT_PREFIX_PATH",
    "CMAKE_PREFIX_PATH",
    "COLCON_PREFIX_PATH",
    "ROS_DISTRO",
    "ROS_VERSION",
    "ROS_PYTHON_VERSION",
    "ROS_PACKAGE_PATH",
    "CC",
    "CXX",
    "CFLAGS",
    "CXXFLAGS",
    "CPPFLAGS",
    "LDFLAGS",
    # GCC reads these behind the command line (https://gcc.gnu.org/onlinedocs/gcc/Environment-Variables.html):
    # headers, libraries and programs that no flag, toolchain file or fingerprint would show
    "CPATH",
    "C_INCLUDE_PATH",
    "CPLUS_INCLUDE_PATH",
    "OBJC_INCLUDE_PATH",
    "LIBRARY_PATH",
    "GCC_EXEC_PREFIX",
    "COMPILER_PATH",
    "DEPENDENCIES_OUTPUT",
    "SUNPRO_DEPENDENCIES",
    "GCC_COMPARE_DEBUG",
)
# Variables that change what reaches the objects and are left to the user: part of the build's
# fingerprint, so a change rebuilds (ccache's settings, e.g. CCACHE_BASEDIR rewriting __FILE__;
# reproducible-build dates).
FINGERPRINTED_PREFIXES = ("CCACHE_",)
FINGERPRINTED_VARIABLES = ("SOURCE_DATE_EPOCH",)
# ccache's settings that say where entries are kept and how many, never what a compile makes: a
# change must not run colcon again (a CI job or a developer turning a team's remote storage on,
# issue 33 item 6; whose URL may hold a password). https://ccache.dev/manual/4.7.html#_configuration_options
UNFINGERPRINTED_VARIABLES = frozenset(
    {
        "CCACHE_DIR",
        "CCACHE_REMOTE_STORAGE",
        "CCACHE_REMOTE_ONLY",
        "CCACHE_RESHARE",
        "CCACHE_READONLY",
        "CCACHE_MAXSIZE",
        "CCACHE_TEMPDIR",
        "CCACHE_LOGFILE",
    }
)
# colcon writes every installed package's environment scripts once per shell extension it has, and
# colcon-common-extensions brings bash, zsh and PowerShell beside sh and dsv: ~340 more files a
# target (each rendered with empy), which nobody sources in a cross-compiled install tree. sh
# (colcon's command environment on POSIX) and dsv stay, and bat (Windows' command environment; it
# writes nothing elsewhere): 346 fewer files a target, 0-4% less time for a second target in
# four side-by-side A/Bs, the same library (docs/benchmarks.md). Extension names: <entry point group>.<name>
# (https://github.com/colcon/colcon-core/blob/master/colcon_core/extension_point.py).
UNUSED_SHELLS = (
    "colcon_core.shell.bash",
    "colcon_core.shell.zsh",
    "colcon_core.shell.powershell",
)
# colcon loads every installed extension of each group it asks for, importing its module, in
# every run (load_extension_points), and a blocked one is skipped before its import
# (load_extension_point: https://github.com/colcon/colcon-core/blob/master/colcon_core/extension_point.py).
# These serve no `colcon build` that uros starts (dev_ws, the host stage, a target), which take
# ~15 ms of CPU a run (docs/benchmarks.md):
UNUSED_EXTENSIONS = (
    *UNUSED_SHELLS,
    # a group read only to list its variables in --help's epilog, built into the parser of every
    # run: each entry imports its module (get_environment_variables_epilog, colcon_core/command.py)
    "colcon_core.environment_variable",
    # the parser of every verb is built before the one asked runs (create_parser); uros asks for
    # `build` only. A user's colcon defaults for another verb are read only when it runs.
    "colcon_core.verb.test",
    "colcon_core.verb.test-result",
    "colcon_core.verb.graph",
    "colcon_core.verb.info",
    "colcon_core.verb.list",
    "colcon_core.verb.metadata",
    "colcon_core.verb.extension-points",
    "colcon_core.verb.extensions",
    "colcon_core.verb.version-check",
    # shell completion: does nothing unless a shell asks for completions (_ARGCOMPLETE)
    "colcon_core.argument_parser.argcomplete",
)
# colcon's Python package extensions: identification by setup.py (which imports setuptools and
# pkg_resources: ~0.1 s of CPU) and by setup.cfg, and the augmentations that read those files (one
# imports distlib, colcon-ros's of ament_python packages imports setuptools again). A target's
# colcon runs without them when it builds no Python package and no setup.py or setup.cfg lies
# outside the workspace's package.xml folders (packages.python_outside_packages): then each finds
# nothing, since colcon-ros identifies every package.xml folder first (RosPackageIdentification,
# PRIORITY 150: https://github.com/colcon/colcon-ros/blob/master/colcon_ros/package_identification/ros.py),
# and only packages colcon does not build are ament_python (augmentation runs before selection,
# so an ignored or skipped one is augmented too, and needs nothing of it). The build tasks stay:
# a Python package built without its task would be skipped with a warning, not refused.
# Measured: 0.14 s less CPU per colcon run of the fixture (0.45 -> 0.31 s; docs/benchmarks.md).
PYTHON_EXTENSIONS = (
    "colcon_core.package_identification.python",
    "colcon_core.package_identification.python_setup_py",
    "colcon_core.package_augmentation.python",
    "colcon_core.package_augmentation.python_setup_py",
    "colcon_core.package_augmentation.ros_ament_python",
)
_BLOCKLIST = "COLCON_EXTENSION_BLOCKLIST"
_ROS_ROOT = "/opt/ros/"
_PATH_LISTS = ("PATH", "PYTHONPATH", "LD_LIBRARY_PATH")


def host_python() -> str:
    """The interpreter the rosidl generators run with: uros's own, which has empy 3, lark and
    catkin_pkg. Spelled the same however uros was started (`uros`, `python -m uros_build`,
    `python3.11 -m ...`): colcon-cmake reconfigures a package whenever its CMake arguments differ
    from the last run's, and a reconfigure regenerates every interface package's code."""
    stable = Path(sys.prefix) / "bin" / "python3"
    return str(stable) if stable.is_file() else sys.executable


def generator(env: Mapping[str, str]) -> str | None:
    """Ninja where it is installed, unless the user chose a generator through CMake's own
    CMAKE_GENERATOR variable (https://cmake.org/cmake/help/latest/envvar/CMAKE_GENERATOR.html),
    which colcon-cmake and CMake then use; None leaves the choice to them."""
    if env.get("CMAKE_GENERATOR"):
        return None
    return "Ninja" if ninja_program(env) else None


def ninja_program(env: Mapping[str, str]) -> str | None:
    """The ninja the build's environment finds (uros's Python's bin/ comes first on its PATH: pip's
    ninja is there); the one lookup the generator choice, the dependency record and doctor share."""
    return shutil.which("ninja", path=env.get("PATH"))


@dataclass(frozen=True)
class ColconPlan:
    base_paths: tuple[Path, ...]
    build_base: Path
    install_base: Path
    log_base: Path
    metas: tuple[Path, ...]
    toolchain_file: Path | None  # None: a host build (the dev workspace)
    python: str
    generator: str | None = "Ninja"
    verbose: bool = False
    parallel_workers: int | None = None
    packages_up_to: tuple[str, ...] = ()
    ignore_regex: str | None = ".*_cpp"
    # Leaving packages out is done by ignoring them, not by --packages-select/--packages-up-to:
    # colcon's up-to also takes every selected package's *test* dependencies (get_packages' direct
    # categories are all of them), and a selected package's build sources the package.sh of each
    # such dependency, so --packages-select fails on the linters it did not build. An ignored
    # package is gone from colcon's package set: a dependency on it is an external one.
    # https://github.com/colcon/colcon-core/blob/master/colcon_core/verb/build.py (get_packages)
    packages_ignore: tuple[str, ...] = ()
    compiler_launcher: str | None = None  # ccache, in front of every C and C++ compile
    # Built elsewhere (the host stage) and already in the install tree: colcon keeps them in its
    # graph, so their dependents wait for what they depend on, but does not build them.
    packages_skip: tuple[str, ...] = ()
    # micro_ros_setup's firmware CMake arguments (static, no PIC, THIRDPARTY): every build but
    # dev_ws's; the toolchain file is added when there is one (the host stage has none)
    firmware: bool = True


def ccache_env(workspace: Path, stats_log: Path) -> dict[str, str]:
    """ccache's settings for a build of ``workspace``: paths under it are made relative to each
    package's build folder (so another checkout at another path hits the same entries; the
    toolchain's relative -ffile-prefix-map gives those paths the names the absolute ones get, and
    the library keeps its bytes); the working folder left out of the hash (no object holds it);
    this build's hits and misses counted in ``stats_log``; and the depend mode: a miss runs the
    compiler once and takes the headers from its -MD list (CMake asks for one in every compile), not
    the preprocessor first and the compiler after, which cost 35-45% on top of each missed compile
    (measured: 120 compiles of std_msgs, one after another, 7.3-8.0 s without ccache, 10.6-10.8 s
    with, 8.5 s in the depend mode). A compile without -MD falls back to ccache's usual mode.
    The compiler is known by its content: ccache's default check is the driver's size and mtime,
    so a compiler replaced by one of the same size and mtime got the old one's objects back. Its
    hash is kept in ccache's inode cache, keyed by the file's inode, size, mtime and ctime (a
    replacement always changes the ctime): 200 cached compiles cost 0.9 s of CPU with the mtime
    check, 1.2-1.6 s hashing the 1.5 MB driver each time, 0.8 s with the inode cache.
    (https://ccache.dev/manual/4.7.html#config_base_dir, #config_hash_dir, #config_stats_log,
    #_the_depend_mode, #config_compiler_check, #config_inode_cache)."""
    return {
        "CCACHE_BASEDIR": str(workspace),
        "CCACHE_COMPILERCHECK": "content",
        "CCACHE_INODECACHE": "true",
        "CCACHE_DEPEND": "true",
        "CCACHE_NOHASHDIR": "true",
        "CCACHE_STATSLOG": str(stats_log),
    }


def ccache_settings(text: str) -> dict[str, str]:
    """``ccache --show-config``'s lines, ``(source) key = value``, as key -> value."""
    found = {}
    for line in text.splitlines():
        key, equals, value = line.partition(") ")[2].partition(" = ")
        if equals:
            found[key.strip()] = value
    return found


def ccache_trouble(settings: Mapping[str, str]) -> str | None:
    """Why ccache cannot compile with these settings (its cache or temporary folder is a file, or
    one it cannot write in: ccache then fails every compile, "Failed to create directory"), or None.
    A folder not made yet counts as the nearest one that exists, where ccache would make it."""
    read_only = settings.get("read_only", "false") == "true"
    for key in ("temporary_dir",) if read_only else ("cache_dir", "temporary_dir"):
        if not settings.get(key):
            continue
        folder = Path(settings[key])
        there = next((p for p in (folder, *folder.parents) if os.path.lexists(p)), Path("/"))
        if not there.is_dir():
            return f"its {key} {folder}: {there} is not a folder"
        if not os.access(there, os.W_OK | os.X_OK):
            return f"its {key} {folder}: cannot write in {there}"
    return None


def ccache_counts(stats_log: str) -> dict[str, int]:
    """Compiles that hit and missed, from a ccache stats_log ("# <source>" then its counters), and
    ``remote_hits`` where ccache's remote storage (a team's Redis or HTTP store) served some of the
    hits: ccache counts one ``remote_storage_hit`` per compile it took from there (ccache 4.7,
    src/core/Statistic.hpp), a ``remote_storage_read_hit`` per file it read."""
    hits = stats_log.count("\ndirect_cache_hit") + stats_log.count("\npreprocessed_cache_hit")
    counts = {"hits": hits, "misses": stats_log.count("\ncache_miss")}
    remote = stats_log.splitlines().count("remote_storage_hit")
    return {**counts, "remote_hits": remote} if remote else counts


def kept_by_ignores(plan: ColconPlan, names: Iterable[str]) -> set[str]:
    """The ``names`` colcon still builds after the plan's --packages-ignore and
    --packages-ignore-regex (pure). The regex is applied with re.match, a prefix match, so `.*_cpp`
    also leaves out rosidl_typesupport_microxrcedds_cpp_tests.
    https://github.com/colcon/colcon-package-selection/blob/master/colcon_package_selection/package_discovery/ignore.py"""
    ignored = set(plan.packages_ignore)
    pattern = re.compile(plan.ignore_regex) if plan.ignore_regex else None
    return {n for n in names if n not in ignored and not (pattern and pattern.match(n))}


def colcon_path(path: Path) -> str:
    """A folder as colcon's package discovery reads it: a path holding `*` is a glob pattern there
    (expand_dir_wildcards: a workspace at `fw*` also crawled a sibling `fw-other/`), so its glob
    characters are escaped; one without `*` is taken as it is (escaping it would name another path).
    https://github.com/colcon/colcon-core/blob/master/colcon_core/package_discovery/__init__.py"""
    text = str(path)
    return glob.escape(text) if "*" in text else text


def colcon_argv(plan: ColconPlan, colcon: str = "colcon") -> list[str]:
    """micro_ros_setup's generate_lib colcon invocation, made explicit and per target.

    build_firmware.sh (humble, config/generate_lib/generic/build.sh) runs
    colcon build --merge-install --packages-ignore-regex=.*_cpp --metas $META
    --cmake-args -DCMAKE_POSITION_INDEPENDENT_CODE:BOOL=OFF -DTHIRDPARTY=ON -DBUILD_SHARED_LIBS=OFF
    -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release -DCMAKE_TOOLCHAIN_FILE=$TOOLCHAIN
    uros adds separate build/install/log bases per target (so targets never clobber each other and
    a rebuild is incremental), --ignore-user-meta (a ~/.colcon meta must not change a firmware
    library), the Python that has the rosidl generators' modules, and compile_commands.json.
    """
    argv = [colcon, "--log-base", str(plan.log_base), "build"]
    argv += ["--base-paths", *map(colcon_path, plan.base_paths)]
    argv += ["--build-base", str(plan.build_base), "--install-base", str(plan.install_base)]
    argv += ["--merge-install", "--ignore-user-meta"]
    if plan.metas:
        argv += ["--metas", *map(str, plan.metas)]
    if plan.ignore_regex:
        argv.append(f"--packages-ignore-regex={plan.ignore_regex}")
    if plan.packages_ignore:
        argv += ["--packages-ignore", *plan.packages_ignore]
    if plan.packages_skip:
        argv += ["--packages-skip", *plan.packages_skip]
    if plan.packages_up_to:
        argv += ["--packages-up-to", *plan.packages_up_to]
    if plan.parallel_workers:
        argv += ["--parallel-workers", str(plan.parallel_workers)]
    # console_start_end+ explicitly: uros reads its "Starting >>>"/"Finished <<<" lines (the live
    # view, the package set of the build), whatever a user's colcon defaults say.
    argv += [
        "--event-handlers",
        "console_direct+" if plan.verbose else "console_cohesion+",
        "console_start_end+",
    ]
    cmake_args = ["--no-warn-unused-cli", "-DBUILD_TESTING=OFF", "-DCMAKE_BUILD_TYPE=Release"]
    cmake_args.append(f"-DPython3_EXECUTABLE={plan.python}")
    cmake_args.append("-DCMAKE_EXPORT_COMPILE_COMMANDS=ON")
    # Always said, empty for none: a package's CMakeCache.txt keeps the launcher of its last
    # configure, so a build without ccache (--no-ccache, ccache uninstalled or unusable) would
    # still run it, and fail ([code=127]) where it is gone.
    launcher = plan.compiler_launcher or ""
    cmake_args += [f"-DCMAKE_C_COMPILER_LAUNCHER={launcher}", f"-DCMAKE_CXX_COMPILER_LAUNCHER={launcher}"]
    if plan.toolchain_file is not None:
        cmake_args.append(f"-DCMAKE_TOOLCHAIN_FILE={plan.toolchain_file}")
    if plan.firmware:
        cmake_args += [
            "-DCMAKE_POSITION_INDEPENDENT_CODE:BOOL=OFF",
            "-DTHIRDPARTY=ON",
            "-DBUILD_SHARED_LIBS=OFF",
        ]
    if plan.generator:
        cmake_args.append(f"-G{plan.generator}")
    # Last: colcon reads every following word as a CMake argument.
    argv += ["--cmake-args", *cmake_args]
    return argv


# Credentials no build step needs: colcon writes its whole environment into its logs (the team
# cache's token, output/team_cache.TOKEN_VARIABLE, would sit in every package's log).
SECRET_VARIABLES = frozenset({"UROS_CACHE_TOKEN"})


def build_env(
    base: Mapping[str, str],
    *,
    python_bin_dir: str,
    cmake_major: int | None = None,
    git_config: Mapping[str, str] | None = None,
) -> tuple[dict[str, str], list[str]]:
    """The environment for colcon: a sourced ROS 2 removed, uros's Python first on PATH.

    Returns the environment and the names of what was scrubbed (for one notice to the user).
    """
    env = {k: v for k, v in base.items() if k not in SCRUBBED_VARIABLES and k not in SECRET_VARIABLES}
    scrubbed = sorted(k for k in base if k in SCRUBBED_VARIABLES and k not in ("CC", "CXX"))
    # Prefixes of a sourced ROS 2 install or colcon overlay: their bin/, lib/ and site-packages
    # entries go too.
    prefixes = [_ROS_ROOT] + [
        p.rstrip("/") + "/"
        for var in ("AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH")
        for p in base.get(var, "").split(os.pathsep)
        if p
    ]
    for name in _PATH_LISTS:
        if name not in env:
            continue
        parts = env[name].split(os.pathsep)
        kept = [p for p in parts if p and not any((p.rstrip("/") + "/").startswith(m) for m in prefixes)]
        if len(kept) != len([p for p in parts if p]):
            scrubbed.append(f"{name} (ROS entries)")
        env[name] = os.pathsep.join(kept)
    path = env.get("PATH", "")
    env["PATH"] = python_bin_dir + (os.pathsep + path if path else "")
    env = with_blocked(env, UNUSED_EXTENSIONS)
    if cmake_major is not None and cmake_major >= 4:
        # CMake 4 refuses cmake_minimum_required(VERSION < 3.5), as in the vendored libyaml and
        # uncrustify; this is CMake's documented escape hatch.
        env["CMAKE_POLICY_VERSION_MINIMUM"] = "3.5"
    if git_config:
        # git's environment configuration (git >= 2.31) carries url.<mirror>.insteadOf into the
        # clones CMake ExternalProject makes during the build.
        items = sorted(git_config.items())
        env["GIT_CONFIG_COUNT"] = str(len(items))
        for i, (key, value) in enumerate(items):
            env[f"GIT_CONFIG_KEY_{i}"] = key
            env[f"GIT_CONFIG_VALUE_{i}"] = value
    return env, scrubbed


def with_blocked(env: Mapping[str, str], extensions: Iterable[str]) -> dict[str, str]:
    """``env`` with ``extensions`` added to colcon's COLCON_EXTENSION_BLOCKLIST (pure): the user's
    own blocked extensions stay, first; none is named twice."""
    blocked = [b for b in env.get(_BLOCKLIST, "").split(os.pathsep) if b]
    blocked += [e for e in dict.fromkeys(extensions) if e not in blocked]
    return {**env, _BLOCKLIST: os.pathsep.join(blocked)}


# colcon's console_cohesion+/console_direct+ line for a package whose build failed:
# "Failed   <<< fx_dup [0.05s, exited with code 1]" (colcon_core/event_handler/console_start_end.py)
_FAILED = re.compile(r"^Failed\s+<<< (\S+)")


def failed_packages(lines: list[str] | tuple[str, ...]) -> list[str]:
    """The packages colcon reports as failed, in the order it reported them."""
    return [m[1] for m in map(_FAILED.match, lines) if m]


def package_log(log_base: Path, package: str) -> Path:
    """colcon's full log of one package in its latest build (colcon-core's log layout)."""
    return log_base / "latest_build" / package / "stdout_stderr.log"


# ---------------------------------------------------------------------------------------------
# colcon's job events, read from its console_start_end+ lines as they stream


@dataclass(frozen=True)
class JobEvent:
    """One line of colcon's console_start_end event handler
    (colcon_core/event_handler/console_start_end.py): a package started, finished, failed or was
    aborted, with colcon's own measure of its duration."""

    kind: str  # "start", "finish", "fail" or "abort"
    package: str
    seconds: float | None = None


_KINDS = {"Starting": "start", "Finished": "finish", "Failed": "fail", "Aborted": "abort"}
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_EVENT = re.compile(r"^(Starting|Finished|Failed|Aborted)\s+(?:>>>|<<<)\s+(\S+)(?:\s+\[([^\],]*))?")
_DURATION_PART = re.compile(r"([\d.]+)(h|min|s)\b")


def parse_duration(text: str) -> float | None:
    """colcon's format_duration text (``0.05s``, ``1min 2s``, ``1h 0min 3s``) -> seconds."""
    parts = _DURATION_PART.findall(text)
    if not parts:
        return None
    scale = {"h": 3600.0, "min": 60.0, "s": 1.0}
    return sum(float(value) * scale[unit] for value, unit in parts)


def parse_event(line: str) -> JobEvent | None:
    """The event a line of colcon's output reports, or None (an output style may colour it)."""
    match = _EVENT.match(_ANSI.sub("", line).strip())
    if match is None:
        return None
    seconds = parse_duration(match[3]) if match[3] else None
    return JobEvent(_KINDS[match[1]], match[2], seconds)


@dataclass
class BuildProgress:
    """What colcon has done so far in one build, fed line by line (pure: times are given)."""

    total: int  # the packages colcon is expected to build (an estimate: colcon does not say)
    started_at: float
    running: dict[str, float] = field(default_factory=dict)  # package -> when it started
    finished: dict[str, float] = field(default_factory=dict)  # package -> seconds, in finish order
    failed: list[str] = field(default_factory=list)
    aborted: list[str] = field(default_factory=list)

    def feed(self, line: str, now: float) -> JobEvent | None:
        event = parse_event(line)
        if event is None:
            return None
        if event.kind == "start":
            self.running[event.package] = now
            return event
        began = self.running.pop(event.package, now)
        seconds = event.seconds if event.seconds is not None else now - began
        if event.kind == "finish":
            self.finished[event.package] = seconds
        elif event.kind == "fail":
            self.failed.append(event.package)
        else:
            self.aborted.append(event.package)
        return JobEvent(event.kind, event.package, seconds)

    @property
    def done(self) -> int:
        return len(self.finished) + len(self.failed) + len(self.aborted)

    def slowest(self, count: int = 5) -> list[tuple[str, float]]:
        return sorted(self.finished.items(), key=lambda item: (-item[1], item[0]))[:count]
