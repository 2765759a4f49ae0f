"""`uros agent build`: the Micro XRCE-DDS Agent built from pinned sources (a distro's
``meta/distros/<distro>/agent.repos``, cloned through the workspace's mirror rules) against the ROS 2
environment the peer uses (run/peerenv.py: a venv of PyPI's kilted ros-* wheels, Fast DDS 3.2.2 and
Fast CDR 2.3.3), with plain CMake: no ROS install, no colcon, no apt Fast DDS.

Three pieces, built in order into one prefix: eProsima's agent (a library, and its ``MicroXRCEAgent``
program), micro_ros_msgs for the host, and micro-ROS-Agent's ``micro_ros_agent`` (the agent plus the
graph manager that puts the board's nodes into the ROS graph). When micro_ros_agent does not build,
the agent is ``MicroXRCEAgent`` and the record says why.

Cached like the peer's environment: the prefix's folder is named by a key of the sources' commits,
the venv (the wheels' versions and the Python) and the build's options; a second build of the same
key does nothing. It is built beside the agent in use, and ``current.json`` names the new one only
once it is complete: a failed build leaves the previous agent in place (run/builtagent.py: the record
and the agent in use, as the commands that run it read them).

Two defects of the wheels are worked around (docs/probe.md, "The agent"): Fast DDS's exported CMake
links ``/usr/lib64/libtinyxml2.so`` (the wheel builder's path; the wheel carries its own
``libtinyxml2-<hash>.so``), and the wheels' libraries look for their vendored libraries with an RPATH
that points outside the venv (``$ORIGIN/../../../ros_*.libs``): the link gets ``-rpath-link`` to
those folders and the programs a DT_RPATH naming them (it reaches the libraries' own dependencies,
where a DT_RUNPATH would not). micro-ROS-Agent's CMakeLists asks for three packages the wheels lack
and its build does not use (``fastrtps_cmake_module``, and the test-only ``ament_lint_auto`` and
``ament_cmake_gtest``): uros points each at an empty package of its own; GCC 12 needs ``<iterator>``,
which its main.cpp does not include: ``-include iterator``. The sources are built as cloned.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, loader, resources
from uros_build.colcon.fingerprint import digest_json
from uros_build.errors import ConfigError, StepFailed
from uros_build.files import locked, remove_tree, write_atomic, write_if_changed
from uros_build.proc import Runner
from uros_build.run import peerenv
from uros_build.run.builtagent import (
    AGENT_DIR,
    CURRENT,
    GRAPH,
    MSGS,
    PROGRAMS,
    RECORD,
    WRAPPER,
    XRCE,
    BuiltAgent,
    parse_record,
    program_path,
)
from uros_build.sources import clones, distros
from uros_build.sources.distros import Mirror, Repo
from uros_build.sources.packages import discover

PIN_FILE = "agent.repos"  # in meta/distros/<distro>/
PARTIAL = "uros-agent.partial"  # written first: the folder is uros's, and unfinished
# the build recipe below: a change of it makes new agents
BUILD_VERSION = 1

ROLES = (XRCE, GRAPH, MSGS)

# eProsima's agent against the wheels' Fast DDS and Fast CDR: no superbuild (it would clone and
# build its own), no spdlog (the wheels have none: the agent logs nothing, and prints no
# "running..." line), no P2P profile (it needs the client library)
XRCE_OPTIONS = (
    "-DCMAKE_BUILD_TYPE=Release",
    "-DUAGENT_SUPERBUILD=OFF",
    "-DUAGENT_USE_SYSTEM_FASTCDR=ON",
    "-DUAGENT_USE_SYSTEM_FASTDDS=ON",
    "-DUAGENT_USE_SYSTEM_LOGGER=OFF",
    "-DUAGENT_LOGGER_PROFILE=OFF",
    "-DUAGENT_P2P_PROFILE=OFF",
    "-DUAGENT_BUILD_EXECUTABLE=ON",
)
GRAPH_OPTIONS = (
    "-DCMAKE_BUILD_TYPE=Release",
    "-DMICROROSAGENT_SUPERBUILD=OFF",
    "-DBUILD_TESTING=OFF",
    "-DCMAKE_CXX_FLAGS=-include iterator",
)
# packages micro-ROS-Agent's CMakeLists finds but its build does not use; the wheels lack them
UNUSED_PACKAGES = ("fastrtps_cmake_module", "ament_lint_auto", "ament_cmake_gtest")

BUILD_HINT = "the full output is in the run log; the previous agent (if any) stays in use"


@dataclass(frozen=True)
class AgentPin:
    """What `uros agent build` builds for a distro: eProsima's agent, and micro-ROS-Agent with its
    messages (both or neither)."""

    distro: str
    xrce: Repo
    graph: Repo | None
    msgs: Repo | None
    source: str  # the file, for messages

    @property
    def repos(self) -> tuple[Repo, ...]:
        return tuple(r for r in (self.xrce, self.graph, self.msgs) if r is not None)


def parse_pin(repos: Sequence[Repo], source: str, distro: str) -> AgentPin:
    """A distro's agent.repos (already parsed by distros.parse_repos) → AgentPin (pure)."""
    by_path = {r.path: r for r in repos}
    for path in sorted(by_path):
        if path not in ROLES:
            raise ConfigError(
                f"{source}: repositories.{path}: not one of the agent's repositories",
                f"name them {', '.join(ROLES)}",
            )
    if XRCE not in by_path:
        raise ConfigError(
            f"{source}: repositories.{XRCE}: is required but missing",
            "name eProsima's Micro-XRCE-DDS-Agent and its version (v3.0.1 builds against the wheels)",
        )
    if (GRAPH in by_path) != (MSGS in by_path):
        given, other = (GRAPH, MSGS) if GRAPH in by_path else (MSGS, GRAPH)
        raise ConfigError(
            f"{source}: repositories.{given}: given without {other}",
            "micro_ros_agent needs micro_ros_msgs (its graph messages): name both, or neither",
        )
    return AgentPin(distro, by_path[XRCE], by_path.get(GRAPH), by_path.get(MSGS), source)


def load_pin(distro: str) -> AgentPin:
    """The agent pinned for ``distro`` (meta/distros/<distro>/agent.repos)."""
    distros.load_distro(distro)  # an unknown distro: the usual error, with the known ones
    path = resources.meta_dir() / "distros" / distro / PIN_FILE
    if not path.is_file():
        pinned = sorted(d for d in distros.known_distros() if (path.parent.parent / d / PIN_FILE).is_file())
        raise ConfigError(
            f"--distro {distro}: no agent is pinned for it (no meta/distros/{distro}/{PIN_FILE})",
            f"build the agent of {' or '.join(pinned) or 'another distro'} (--distro): the XRCE-DDS "
            "protocol is the same, or add the file",
        )
    return parse_pin(distros.parse_repos(loader.load_yaml(path), str(path)), str(path), distro)


# ---------------------------------------------------------------------------------------------
# pure: keys, argv, texts


def agent_key(commits: Mapping[str, str], venv_name: str) -> str:
    """What makes one agent differ from another (pure): the commit of each source, the ROS 2
    environment (its folder's name is a key of the wheels' versions and the Python), the build's
    options and this module's recipe."""
    return digest_json(
        {
            "commits": dict(sorted(commits.items())),
            "venv": venv_name,
            "options": [*XRCE_OPTIONS, *GRAPH_OPTIONS],
            "recipe": BUILD_VERSION,
        }
    )[:16]


def wheel_lib_dirs(venv: Path, python: str) -> list[Path]:
    """The folders of the wheels' vendored libraries (``site-packages/ros_*.libs``), sorted."""
    site = venv / "lib" / f"python{python}" / "site-packages"
    return sorted(p for p in site.glob("ros_*.libs") if p.is_dir()) if site.is_dir() else []


def library_path(prefix: Path, venv: Path, libs: Sequence[Path]) -> list[str]:
    """Where the agent's libraries are: its own prefix, the venv's lib, the wheels' vendored ones."""
    return [str(prefix / "lib"), str(venv / "lib"), *(str(p) for p in libs)]


def link_options(prefix: Path, venv: Path, libs: Sequence[Path]) -> list[str]:
    """The linker and install options every piece is configured with (pure): ``-rpath-link`` to the
    wheels' vendored libraries (their own RPATH misses them), and a DT_RPATH (``--disable-new-dtags``:
    it is searched for the libraries' dependencies too) naming every folder."""
    flags = " ".join([*(f"-Wl,-rpath-link,{p}" for p in libs), "-Wl,--disable-new-dtags"])
    return [
        f"-DCMAKE_EXE_LINKER_FLAGS={flags}",
        f"-DCMAKE_SHARED_LINKER_FLAGS={flags}",
        f"-DCMAKE_INSTALL_RPATH={';'.join(library_path(prefix, venv, libs))}",
    ]


@dataclass(frozen=True)
class Build:
    """What every piece is configured with: CMake, the prefix it installs into, the venv it builds
    against, the wheels' vendored library folders, the generator (``-G Ninja``, or CMake's default)."""

    cmake: str
    prefix: Path
    venv: Path
    libs: tuple[Path, ...]
    generator: tuple[str, ...] = ()

    def configure(self, src: Path, tree: Path) -> list[str]:
        """cmake's first arguments for ``src`` in ``tree``, installing into the prefix (pure)."""
        return [
            self.cmake,
            "-S",
            str(src),
            "-B",
            str(tree),
            *self.generator,
            f"-DCMAKE_INSTALL_PREFIX={self.prefix}",
        ]


def xrce_configure_argv(b: Build, src: Path, tree: Path) -> list[str]:
    """eProsima's agent, configured against the venv (pure)."""
    return [
        *b.configure(src, tree),
        *XRCE_OPTIONS,
        f"-DCMAKE_PREFIX_PATH={b.venv}",
        *link_options(b.prefix, b.venv, b.libs),
    ]


def graph_configure_argv(b: Build, src: Path, tree: Path, unused: Path) -> list[str]:
    """micro-ROS-Agent's micro_ros_agent package (``src``: its folder in the clone), against the
    agent and micro_ros_msgs in the prefix and the venv; each unused package from ``unused`` (pure)."""
    return [
        *b.configure(src, tree), *GRAPH_OPTIONS, f"-DCMAKE_PREFIX_PATH={b.prefix};{b.venv}",
        f"-DPython3_EXECUTABLE={b.venv / 'bin' / 'python3'}",
        *(f"-D{name}_DIR={unused / name}" for name in UNUSED_PACKAGES),
        *link_options(b.prefix, b.venv, b.libs),
    ]  # fmt: skip


def unused_package_config(name: str) -> str:
    """The config file of an empty package standing in for ``name`` (pure)."""
    return (
        f"# Written by uros agent build: {name} is found by micro-ROS-Agent's CMakeLists but not used\n"
        "# to build micro_ros_agent, and PyPI's ROS 2 wheels lack it; this empty package stands in.\n"
        f"set({name}_FOUND TRUE)\n"
    )


_TINYXML_BUILDER = "/usr/lib64/libtinyxml2.so"


def fix_fastdds_tinyxml(text: str, tinyxml: str) -> str:
    """Fast DDS's exported targets with the wheel builder's tinyxml2 replaced by the wheel's own
    (pure)."""
    return text.replace(_TINYXML_BUILDER, tinyxml)


def wrapper_script(program: Path, libraries: Sequence[str], ament: Sequence[str], what: str) -> str:
    """The shell script that runs ``program`` with its libraries found (pure): the loader's path and
    the ament index (the graph manager's type supports are looked up through both), then exec, so the
    agent is the process that signals reach. Every path shell-quoted."""
    libs = shlex.quote(os.pathsep.join(libraries))
    index = shlex.quote(os.pathsep.join(ament))
    return (
        "#!/bin/sh\n"
        f"# Written by uros agent build: {what}.\n"
        "# It runs the agent with the libraries of PyPI's ROS 2 wheels it was built against.\n"
        f"LD_LIBRARY_PATH={libs}${{LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}}\n"
        f"AMENT_PREFIX_PATH={index}${{AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}}\n"
        "# Fast DDS over UDP only, unless told otherwise: its shared-memory transport across a network\n"
        "# namespace left the agent's participant undiscovered by a host peer in most short runs\n"
        "FASTDDS_BUILTIN_TRANSPORTS=${FASTDDS_BUILTIN_TRANSPORTS:-UDPv4}\n"
        "export LD_LIBRARY_PATH AMENT_PREFIX_PATH FASTDDS_BUILTIN_TRANSPORTS\n"
        f'exec {shlex.quote(str(program))} "$@"\n'
    )


# ---------------------------------------------------------------------------------------------
# the build


def build_agent(
    runner: Runner, pin: AgentPin, mirror: Mirror, root: Path, jobs: int
) -> tuple[BuiltAgent, bool]:
    """Build ``pin`` under ``root`` (or find it built); make it the current agent. (the agent, True
    when it was built now). A failed build keeps its trees (``build-<key>``): the next one with the
    same key picks up where it stopped."""
    try:
        venv = peerenv.ensure_venv(runner, peerenv.load_spec(), root)
    except StepFailed as exc:
        raise StepFailed(
            f"uros agent build: the ROS 2 environment could not be made ({exc.cause})", exc.hint
        ) from None
    agents = root / AGENT_DIR
    with locked(root / "locks" / AGENT_DIR, "the agent build", command="uros agent build"):
        fresh = agents / "src-new"
        remove_tree(fresh)
        commits = _clone(runner, pin, mirror, fresh)
        key = agent_key(commits, venv.name)
        folder = agents / f"{pin.distro}-{key}"
        work = agents / f"build-{key}"
        if (folder / RECORD).is_file() and (folder / WRAPPER).is_file():
            built = parse_record(loader.load_json(folder / RECORD), str(folder / RECORD), folder)
            _write_wrapper(built, venv, key)  # derived from the record: an older uros's is renewed
            _make_current(agents, folder)
            remove_tree(fresh)
            return built, False
        if (work / "src").is_dir():  # the same commits, from a build that failed: its trees go on
            remove_tree(fresh)
        else:
            work.mkdir(parents=True, exist_ok=True)
            fresh.rename(work / "src")
        built = _build(runner, pin, work, folder, venv, jobs, key, commits)
        _make_current(agents, folder)
        remove_tree(work)
        return built, True


def _build(
    runner: Runner,
    pin: AgentPin,
    work: Path,
    folder: Path,
    venv: Path,
    jobs: int,
    key: str,
    commits: Mapping[str, str],
) -> BuiltAgent:
    libs = wheel_lib_dirs(venv, peerenv.python_version())
    _mend_fastdds(venv, libs)
    _begin(folder)
    started = time.monotonic()
    generator = ("-G", "Ninja") if shutil.which("ninja") else ()
    b = Build(runner.which("cmake"), folder, venv, tuple(libs), generator)
    src, trees = work / "src", work / "build"
    console.step(f"building eProsima's agent ({pin.xrce.version}) against the wheels' Fast DDS")
    _cmake(
        runner, b, xrce_configure_argv(b, src / XRCE, trees / XRCE), trees / XRCE, jobs, "eProsima's agent"
    )
    program, why = PROGRAMS[XRCE], f"{pin.source} names no micro_ros_agent"
    if pin.graph is not None:
        try:
            _build_graph(runner, b, work, jobs)
            program = PROGRAMS[GRAPH]
            why = "micro_ros_agent built against the wheels (with the graph manager)"
        except StepFailed as exc:
            why = f"micro_ros_agent did not build against the wheels: {exc.message}"
            console.warn(f"{why}; the agent is MicroXRCEAgent (no graph manager)")
    record = {
        "program": program,
        "why": why,
        "distro": pin.distro,
        "commits": dict(commits),
        "venv": venv.name,
        "seconds": round(time.monotonic() - started, 1),
        "generated_by": "uros agent build",
    }
    built = parse_record(record, str(folder / RECORD), folder)
    _write_wrapper(built, venv, key)
    write_atomic(folder / RECORD, json.dumps(record, indent=2, sort_keys=True) + "\n")
    (folder / PARTIAL).unlink()
    return built


def _write_wrapper(built: BuiltAgent, venv: Path, key: str) -> None:
    folder = built.folder
    executable = program_path(folder, built.program)
    libs = wheel_lib_dirs(venv, peerenv.python_version())
    what = f"{built.program} ({built.distro}), key {key}"
    text = wrapper_script(executable, library_path(folder, venv, libs), [str(folder), str(venv)], what)
    if write_if_changed(folder / WRAPPER, text):
        (folder / WRAPPER).chmod(0o755)


def _clone(runner: Runner, pin: AgentPin, mirror: Mirror, dest: Path) -> dict[str, str]:
    """Each repository of the pin cloned through the mirror rules; role -> the commit it is at."""
    git = runner.which("git")
    commits = {}
    for repo in pin.repos:
        source = distros.resolve(repo, mirror)
        if distros.is_local(source.url) and not distros.local_path(source.url).exists():
            raise ConfigError(
                f"--mirror: {source.url} (for {repo.path}, upstream {repo.url}) does not exist",
                f"fix the mirror rule, or point this repository elsewhere: --mirror-override {repo.path}=URL",
            )
        console.info(distros.describe_stand_in(repo.path, source))
        try:
            for argv in clones.clone_argv(git, source, dest / repo.path):
                runner.run(argv, step=f"clone {repo.path}", quiet=True)
        except StepFailed as exc:
            raise clones.source_failed(
                "cloning", repo.path, source, exc, f"--mirror-override {repo.path}=URL[@VERSION]"
            ) from None
        commits[repo.path] = runner.query(
            [git, "-C", str(dest / repo.path), "rev-parse", "HEAD"], step=f"read {repo.path}'s commit"
        ).strip()
    return commits


def _mend_fastdds(venv: Path, libs: Sequence[Path]) -> None:
    """Fast DDS's exported targets link the wheel's own tinyxml2 (idempotent: a text transform)."""
    tinyxml = sorted(p for d in libs for p in d.glob("libtinyxml2-*.so*"))
    targets = venv / "share" / "fastdds" / "cmake" / "fastdds-shared-targets.cmake"
    if not tinyxml or not targets.is_file():
        return
    text = targets.read_text(encoding="utf-8", errors="surrogateescape")
    fixed = fix_fastdds_tinyxml(text, str(tinyxml[0]))
    if fixed != text:
        write_atomic(targets, fixed.encode("utf-8", "surrogateescape"))


def _build_graph(runner: Runner, b: Build, work: Path, jobs: int) -> None:
    """micro_ros_msgs for the host, then micro_ros_agent, into the prefix."""
    src, trees = work / "src", work / "build"
    console.step("building micro_ros_msgs for the host, then micro_ros_agent (the graph manager)")
    env = peerenv.build_env(os.environ, b.venv)
    msgs = discover(src / MSGS)
    if len(msgs) != 1:
        raise StepFailed(f"{src / MSGS}: expected one package (micro_ros_msgs), found {len(msgs)}")
    prefixes = peerenv.HostPrefixes(b.prefix, b.venv)
    configure = peerenv.cmake_configure_argv(b.cmake, msgs[0].path, trees / MSGS, prefixes)
    _cmake(runner, b, [*configure, *b.generator], trees / MSGS, jobs, "micro_ros_msgs", env)
    unused = work / "unused-packages"
    for name in UNUSED_PACKAGES:
        write_atomic(unused / name / f"{name}Config.cmake", unused_package_config(name))
    graph_env = peerenv.build_env(os.environ, b.venv, [b.prefix])
    argv = graph_configure_argv(b, src / GRAPH / GRAPH, trees / GRAPH, unused)
    _cmake(runner, b, argv, trees / GRAPH, jobs, "micro_ros_agent", graph_env)


def _cmake(
    runner: Runner,
    b: Build,
    configure: list[str],
    tree: Path,
    jobs: int,
    what: str,
    env: Mapping[str, str] | None = None,
) -> None:
    runner.run(configure, env=env, step=f"configure {what}", hint=BUILD_HINT)
    runner.run(
        [b.cmake, "--build", str(tree), "-j", str(jobs)], env=env, step=f"build {what}", hint=BUILD_HINT
    )
    runner.run(
        [b.cmake, "--install", str(tree)], env=env, step=f"install {what}", hint=BUILD_HINT, quiet=True
    )


def _begin(folder: Path) -> None:
    """An agent's folder made afresh: what an unfinished build left (its PARTIAL marker) removed,
    anything else refused; marked PARTIAL until the record is written."""
    if folder.exists() and not (folder / PARTIAL).is_file():
        raise ConfigError(
            f"{folder}: exists, and uros did not make it (or it lacks {WRAPPER})",
            "move it away (uros does not remove what it did not write), or set UROS_ROS2_VENV elsewhere",
        )
    remove_tree(folder)
    folder.mkdir(parents=True)
    (folder / PARTIAL).write_text("made by uros agent build; unfinished\n", encoding="utf-8")


def _make_current(agents: Path, folder: Path) -> None:
    """The swap: ``current.json`` names ``folder``, written whole or not at all."""
    write_atomic(agents / CURRENT, json.dumps({"folder": folder.name}, sort_keys=True) + "\n")
