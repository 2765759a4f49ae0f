"""The ROS 2 environment of a host peer (`uros probe --peer`): a Python venv made once from PyPI's
ros-* wheels (meta/probe/ros2-peer.yaml: the packages and their pinned versions), cached under a
key of those versions, plus the workspace's own interface packages (those in the library that the
wheels lack, e.g. a user's CmdVel.msg) built for the host with plain CMake against the venv, cached
by their content. No ROS install, no colcon, no sourcing: the peer runs with the venv's Python and
the environment :func:`peer_env` gives it.

Two defects of the wheels are mended (docs/probe.md, "A ROS 2 peer"): their dependency lists are
incomplete (the data file names what CMake needs), and their exported CMake targets
(``<pkg>::<pkg>__rosidl_generator_py``) keep the manylinux builder's Python and numpy include
folders (``/opt/python/cp311-cp311/...``), which CMake refuses as "non-existent path" when an
interface package is generated against them: :func:`fix_wheel_cmake` points them at the venv's.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import signal
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import console, loader, resources
from uros_build.colcon.fingerprint import digest, digest_json
from uros_build.errors import ConfigError, StepFailed
from uros_build.files import locked
from uros_build.proc import Runner
from uros_build.run.session import PeerRun
from uros_build.sources.packages import PackageInfo, discover

READY = "uros-ros2-env.json"  # written last: the folder is complete
PARTIAL = "uros-ros2-env.partial"  # written first: the folder is uros's, and unfinished
# the text transform of the wheels' CMake files; a change of it makes new venvs
FIX_VERSION = 1
INTERFACE_GROUP = "rosidl_interface_packages"

VARIABLE = "UROS_ROS2_VENV"  # config/settings.py's ROS2_VENV: where the environments are kept
PIP_HINT = (
    "pip needs PyPI (or a mirror: PIP_INDEX_URL) to make the ROS 2 peer environment once; offline, "
    "point UROS_ROS2_VENV at a folder where `uros probe --peer` (or `uros agent build`) made it before"
)


@dataclass(frozen=True)
class PeerEnvSpec:
    distro: str  # what ROS 2 the wheels are
    packages: tuple[str, ...]  # pip requirements, each NAME==VERSION


_PINNED = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*==[A-Za-z0-9][A-Za-z0-9.+!-]*")


def parse_spec(data: Any, source: str) -> PeerEnvSpec:
    top = loader.mapping(data, source, required=("distro", "packages"))
    distro = loader.string(top, "distro", source)
    if not re.fullmatch(r"[a-z][a-z0-9]*", distro):
        raise ConfigError(f"{source}: distro: {distro!r} is not a ROS 2 distro name")
    packages = loader.string_list(top, "packages", source)
    if not packages:
        raise ConfigError(f"{source}: packages: empty", "name rclpy's wheel at least (ros-rclpy==VERSION)")
    for item in packages:
        if not _PINNED.fullmatch(item):
            raise ConfigError(
                f"{source}: packages: {item!r} is not pinned",
                "write NAME==VERSION: the environment is cached under a key of these versions",
            )
    return PeerEnvSpec(distro, packages)


def load_spec() -> PeerEnvSpec:
    path = resources.meta_dir() / "probe" / "ros2-peer.yaml"
    return parse_spec(loader.load_yaml(path, str(path)), str(path))


def python_version() -> str:
    return f"{sys.version_info.major}.{sys.version_info.minor}"


def venv_key(spec: PeerEnvSpec, python: str) -> str:
    """What makes one venv differ from another: the pinned packages, the Python (the wheels are
    per CPython version) and the CMake mend."""
    return digest_json({"packages": sorted(spec.packages), "python": python, "fix": FIX_VERSION})[:16]


def venv_path(root: Path, spec: PeerEnvSpec, python: str) -> Path:
    return root / f"{spec.distro}-py{python}-{venv_key(spec, python)}"


# The manylinux image's CPython (/opt/python/cp311-cp311) and the numpy inside it
_NUMPY_INCLUDE = re.compile(
    r"/opt/python/cp\d+-cp\d+/lib/python3\.\d+/site-packages/numpy/(?:_?core)/include"
)
_PYTHON_INCLUDE = re.compile(r"/opt/python/cp\d+-cp\d+/include/python3\.\d+")


def fix_wheel_cmake(text: str, python_include: str, numpy_include: str) -> str:
    """A wheel's exported CMake file with the builder's include folders replaced by this venv's
    (pure; numpy's first: its path starts like Python's)."""
    text = _NUMPY_INCLUDE.sub(lambda _m: numpy_include, text)
    return _PYTHON_INCLUDE.sub(lambda _m: python_include, text)


def ensure_venv(runner: Runner, spec: PeerEnvSpec, root: Path) -> Path:
    """The venv of ``spec`` under ``root``: made now (pip, then the CMake mend), or as made before."""
    python = python_version()
    venv = venv_path(root, spec, python)
    if (venv / READY).is_file():
        console.info(f"ROS 2 peer environment: {venv} (made before)")
        return venv
    with locked(root / "locks" / venv.name, "the ROS 2 peer environment", command="uros probe"):
        if (venv / READY).is_file():
            return venv
        _begin(venv)
        console.step(f"making the ROS 2 peer environment ({spec.distro} wheels from PyPI): {venv}")
        runner.run([sys.executable, "-m", "venv", str(venv)], step="make the ROS 2 peer venv")
        try:
            runner.run(
                [str(venv / "bin" / "python3"), "-m", "pip", "install", "--disable-pip-version-check",
                 *spec.packages],
                step="pip install the ROS 2 wheels",
            )  # fmt: skip
        except StepFailed as exc:
            raise StepFailed(
                f"uros probe --peer: pip could not install {spec.packages[0]} and the other ROS 2 wheels "
                f"({exc.cause})",
                PIP_HINT,
                cause=exc.cause,
            ) from None
        patched = mend_exported_cmake(runner, venv)
        runner.log(f"mended the builder's include folders in {len(patched)} exported CMake files")
        _finish(venv, {"distro": spec.distro, "packages": list(spec.packages), "python": python})
    return venv


def _begin(folder: Path) -> None:
    """A cached folder made afresh: what an interrupted run of uros left (its PARTIAL marker says
    so) removed, anything else refused; marked PARTIAL until :func:`_finish`."""
    if folder.exists() and not (folder / PARTIAL).is_file():
        raise ConfigError(
            f"{folder}: exists, and uros did not make it",
            "move it away (uros does not remove what it did not write), "
            "or set UROS_ROS2_VENV to another folder",
        )
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    (folder / PARTIAL).write_text("made by uros probe --peer; unfinished\n", encoding="utf-8")


def _finish(folder: Path, record: Mapping[str, Any]) -> None:
    (folder / READY).write_text(json.dumps(record, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    (folder / PARTIAL).unlink()


def mend_exported_cmake(runner: Runner, venv: Path) -> list[Path]:
    """Apply :func:`fix_wheel_cmake` to the venv's exported CMake files; the files changed."""
    paths = runner.query(
        [str(venv / "bin" / "python3"), "-c",
         "import sysconfig, numpy; print(sysconfig.get_paths()['include']); print(numpy.get_include())"],
        step="ask the peer venv's Python for its include folders",
    ).split("\n")  # fmt: skip
    python_include, numpy_include = paths[0].strip(), paths[1].strip()
    changed = []
    for path in sorted(venv.glob("share/*/cmake/*.cmake")):
        text = path.read_text(encoding="utf-8", errors="surrogateescape")
        fixed = fix_wheel_cmake(text, python_include, numpy_include)
        if fixed != text:
            path.write_text(fixed, encoding="utf-8", errors="surrogateescape")
            changed.append(path)
    return changed


# ---------------------------------------------------------------------------------------------
# the workspace's interface packages, built for the host


def packages_in(venv: Path) -> set[str]:
    """The ROS packages the venv holds (an ament prefix: share/<pkg>/package.xml)."""
    share = venv / "share"
    return {p.name for p in share.iterdir() if (p / "package.xml").is_file()} if share.is_dir() else set()


def interface_packages(
    found: Iterable[PackageInfo], in_library: Iterable[str], have: set[str], own: Iterable[str] | None = None
) -> list[PackageInfo]:
    """The library's interface packages that the venv lacks, each after those of them it depends
    on (pure). ``own`` (the workspace's extra packages) keeps it to those and what they need: the
    upstream ones the wheels lack (example_interfaces, micro_ros_msgs) cost minutes to build and a
    peer rarely imports them; None: every one."""
    library = set(in_library)
    wanted = {
        p.name: p for p in found if INTERFACE_GROUP in p.groups and p.name in library and p.name not in have
    }
    roots = sorted(wanted) if own is None else sorted(set(own) & wanted.keys())
    ordered: list[PackageInfo] = []
    done: set[str] = set()

    def visit(name: str, path: tuple[str, ...]) -> None:
        if name in done or name in path:
            return
        for dep in sorted(wanted[name].build_deps & wanted.keys()):
            visit(dep, (*path, name))
        done.add(name)
        ordered.append(wanted[name])

    for name in roots:
        visit(name, ())
    return ordered


def package_files(path: Path) -> dict[str, bytes]:
    """A package's files by relative path (what its host build depends on)."""
    out = {}
    for file in sorted(path.rglob("*")):
        rel = file.relative_to(path)
        if file.is_file() and not any(part.startswith(".") for part in rel.parts):
            out[rel.as_posix()] = file.read_bytes()
    return out


def interfaces_key(venv_name: str, files: Mapping[str, bytes], deps: Iterable[str] = ()) -> str:
    """One package's host build key: the venv, every file of the package and the keys of the
    interface packages it was built against (pure)."""
    parts: list[str | bytes] = [venv_name, *sorted(deps)]
    for rel in sorted(files):
        parts += [rel, files[rel]]
    return digest(*parts)[:16]


@dataclass(frozen=True)
class HostPrefixes:
    """Where one interface package's host build installs, and what it is built against: the venv
    (an ament prefix) and the prefixes of the interface packages it depends on."""

    prefix: Path
    venv: Path
    deps: tuple[Path, ...] = ()


def cmake_configure_argv(cmake: str, package: Path, build: Path, prefixes: HostPrefixes) -> list[str]:
    """The package's own CMakeLists.txt (ament_cmake + rosidl_generate_interfaces), unchanged,
    installed into its own prefix, against the venv and the prefixes of the interface packages it
    depends on (pure)."""
    prefix, venv = prefixes.prefix, prefixes.venv
    search = ";".join(str(p) for p in (*prefixes.deps, venv))
    return [
        cmake, "-S", str(package), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
        f"-DCMAKE_PREFIX_PATH={search}", f"-DCMAKE_INSTALL_PREFIX={prefix}",
        f"-DPython3_EXECUTABLE={venv / 'bin' / 'python3'}", "-DBUILD_TESTING=OFF",
    ]  # fmt: skip


def build_env(env: Mapping[str, str], venv: Path, deps: Sequence[Path] = ()) -> dict[str, str]:
    """The venv's Python first on PATH (it runs the rosidl generators), and the ament index of
    the venv and of the packages built before (typesupports are found through it) (pure)."""
    out = dict(env)
    out["PATH"] = os.pathsep.join(p for p in (str(venv / "bin"), env.get("PATH", "")) if p)
    out["AMENT_PREFIX_PATH"] = os.pathsep.join(str(p) for p in (*deps, venv))
    out.pop("PYTHONPATH", None)  # uros's own must not reach the generators
    return out


def build_interfaces(
    runner: Runner, venv: Path, packages: list[PackageInfo], root: Path, jobs: int = 2
) -> list[Path]:
    """Build and install each of ``packages`` (in build order) for the host into a prefix of its
    own, cached by its content and its dependencies' (a changed message rebuilds its package and
    those built against it, not the others); the prefixes."""
    prefixes: dict[str, Path] = {}
    keys: dict[str, str] = {}
    for package in packages:
        deps = sorted(package.build_deps & prefixes.keys())
        keys[package.name] = interfaces_key(venv.name, package_files(package.path), (keys[d] for d in deps))
        prefix = root / "interfaces" / f"{package.name}-{venv.name}-{keys[package.name]}"
        _build_interface(runner, package, HostPrefixes(prefix, venv, tuple(prefixes[d] for d in deps)), jobs)
        prefixes[package.name] = prefix
    return list(prefixes.values())


def _build_interface(runner: Runner, package: PackageInfo, prefixes: HostPrefixes, jobs: int) -> None:
    prefix, venv, deps = prefixes.prefix, prefixes.venv, prefixes.deps
    if (prefix / READY).is_file():
        console.info(f"{package.name} for the host: {prefix} (built before)")
        return
    with locked(root_locks(prefix), f"the host build of {package.name}", command="uros probe"):
        if (prefix / READY).is_file():
            return
        _begin(prefix)
        console.step(f"building {package.name} for the host (the peer's Python types)")
        cmake = runner.which("cmake")
        env = build_env(os.environ, venv, deps)
        build = prefix / "build"
        runner.run(cmake_configure_argv(cmake, package.path, build, prefixes), env=env,
                   step=f"configure {package.name} for the host")  # fmt: skip
        runner.run(
            [cmake, "--build", str(build), "-j", str(jobs)],
            env=env,
            step=f"build {package.name} for the host",
        )
        runner.run([cmake, "--install", str(build)], env=env, step=f"install {package.name} for the host")
        shutil.rmtree(build)
        _finish(prefix, {"package": package.name, "venv": venv.name})


def root_locks(prefix: Path) -> Path:
    return prefix.parent.parent / "locks" / prefix.name


# ---------------------------------------------------------------------------------------------
# the peer's process


def peer_argv(venv: Path, script: Path) -> list[str]:
    return [str(venv / "bin" / "python3"), "-u", str(script)]


def peer_env(env: Mapping[str, str], venv: Path, prefixes: Sequence[Path], python: str) -> dict[str, str]:
    """What the peer runs with: the venv's programs, the host-built interface packages' Python
    modules and type-support libraries, Fast DDS as the middleware (pure). The wheels' bootstrapper
    (a .pth the venv's Python runs) adds the venv's own libraries to LD_LIBRARY_PATH itself."""
    out = dict(env)
    out["PATH"] = os.pathsep.join(p for p in (str(venv / "bin"), env.get("PATH", "")) if p)
    out["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
    out["PYTHONUNBUFFERED"] = "1"
    out.pop("PYTHONPATH", None)
    out.pop("VIRTUAL_ENV", None)
    if prefixes:
        out["PYTHONPATH"] = os.pathsep.join(
            str(p / "lib" / f"python{python}" / "site-packages") for p in prefixes
        )
        libs = [
            *(str(p / "lib") for p in prefixes),
            *(p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p),
        ]
        out["LD_LIBRARY_PATH"] = os.pathsep.join(libs)
    out["AMENT_PREFIX_PATH"] = os.pathsep.join([*(str(p) for p in prefixes), str(venv)])
    return out


def cache_root(given: Path) -> Path:
    """The folder the environments are kept in (UROS_ROS2_VENV), absolute: a relative one named
    another folder for the peer than for uros (it gave a peer that never saw a sample); a file there
    is one line, not an internal error."""
    root = Path(os.path.abspath(given.expanduser()))
    if root.exists() and not root.is_dir():
        raise ConfigError(
            f"{VARIABLE} {root}: is not a folder",
            f"set {VARIABLE} to a folder (uros makes it, and the peer's environment in it), or unset it",
        )
    return root


# What the environment's own Python imports before the peer runs (argv: the interface packages):
# rclpy with its C extension (librcl, librmw), the middleware's library, and each package's
# messages with their C type support; what a deleted module or a truncated library breaks.
_CHECK = """
import ctypes, importlib, importlib.util, sys
import rclpy
from rclpy.impl.implementation_singleton import rclpy_implementation
ctypes.CDLL("librmw_fastrtps_cpp.so")
for package in sys.argv[1:]:
    importlib.import_module(package)
    for kind in ("msg", "srv", "action"):
        if importlib.util.find_spec(f"{package}.{kind}") is None:
            continue
        module = importlib.import_module(f"{package}.{kind}")
        types = [t for t in vars(module).values() if hasattr(type(t), "__import_type_support__")]
        if types:
            type(types[0]).__import_type_support__()
print("uros: the ROS 2 environment imports")
"""


def check_env(
    runner: Runner, venv: Path, env: Mapping[str, str], packages: Sequence[str], made: Sequence[Path]
) -> None:
    """The environment works before the peer runs: its Python is there and imports rclpy, the
    middleware and ``packages``' messages. A damaged one (a module deleted, a library cut short, the
    Python gone) is uros's cache, named with its removal, not "the peer failed"."""
    python = venv / "bin" / "python3"
    remove = " ".join(str(p) for p in (venv, *made))
    hint = f"remove it (rm -rf {remove}): the next `uros probe --peer` makes it again"
    if not (python.is_file() and os.access(python, os.X_OK)):
        raise StepFailed(
            f"uros probe --peer: the ROS 2 peer environment {venv} is damaged: no {python}", hint
        )
    try:
        runner.query([str(python), "-c", _CHECK, *packages], env=env, step="check the ROS 2 peer environment")
    except StepFailed as exc:
        code = exc.code or 0
        what = f"importing rclpy, the middleware and {', '.join(packages)}"
        why = (
            f"its Python died of {signal.Signals(-code).name} {what}"
            if code < 0 and -code in signal.valid_signals()
            else f"{what} failed (exit {code}): {exc.cause}"
        )
        raise StepFailed(
            f"uros probe --peer: the ROS 2 peer environment {venv} is damaged: {why}", hint
        ) from None


@dataclass(frozen=True)
class PeerInterfaces:
    """Which interface packages the peer gets built for the host: those of the library (its
    packages) that the wheels lack, from the workspace's sources (None: an output outside a
    workspace, the wheels' packages only); ``own``: the workspace's own packages, else every one."""

    library: tuple[str, ...]
    source_dir: Path | None = None
    own: tuple[str, ...] | None = None


def prepare(runner: Runner, script: Path, root: Path, interfaces: PeerInterfaces, log: Path) -> PeerRun:
    """The peer's run: the venv (made or as before), the interface packages it lacks built for the
    host (``interfaces``), the argv and the environment."""
    source_dir, own, library = interfaces.source_dir, interfaces.own, interfaces.library
    root = cache_root(root)
    wanted: list[PackageInfo] = []
    try:
        venv = ensure_venv(runner, load_spec(), root)
        prefixes: list[Path] = []
        if source_dir is not None:
            wanted = interface_packages(discover(source_dir), library, packages_in(venv), own)
            prefixes = build_interfaces(runner, venv, wanted, root)
        else:
            console.info("the output is not in a workspace: the peer has the wheels' interface packages only")
    except OSError as exc:  # uros's own writes into the cache (a full disk is cli's to say)
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise
        raise ConfigError(
            f"{VARIABLE} {root}: cannot write {exc.filename or root} ({exc.strerror})",
            f"set {VARIABLE} to a folder uros may write (the peer's ROS 2 environment is made there once)",
        ) from None
    env = peer_env(os.environ, venv, prefixes, python_version())
    check_env(runner, venv, env, ["std_msgs", *(p.name for p in wanted)], prefixes)
    return PeerRun(tuple(peer_argv(venv, script)), env, log)
