"""What the host is: CMake's version, the colcon program, the probe cache that answers a build
with nothing to do without starting a process, ccache's health, and the host facts a build starts
from (the target's compiler and its version found through target/compilers.py)."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint
from uros_build.errors import DiskFull, StepFailed
from uros_build.files import write_atomic
from uros_build.proc import Runner
from uros_build.target import abi
from uros_build.target.compilers import check_target_prerequisites, probe_target_tools
from uros_build.target.profiles import TargetProfile


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
