"""Who decides what a build does: the one declared precedence of issue 18 (model: pypa/cibuildwheel's
options.py). For every setting the command line wins over the workspace's uros.yaml, which wins over
uros's defaults; the few settings that add up instead of replacing say so.

| setting | command line | uros.yaml | default |
|---|---|---|---|
| workspace | `-w/--workspace` | the nearest folder upward with a uros.yaml | `./firmware` |
| target(s) | `--toolchain` (repeatable), `--profile`, `--compiler-prefix` | `targets:` | an error |
| transport | `--transport` | `transport:` | the preset's |
| colcon.meta options | `--set` (applied after) | `set:` (applied first) | the preset, then the distro's |
| meta files | `--meta` (applied after) | the workspace's `colcon.meta` (first) | none |
| packages | `--packages`, `--for-firmware` | `packages:` (unless `--for-firmware`) | every package |
| ESP-IDF build folder | `--idf-build` | `idf_build:` (for an ESP-IDF target) | none |
| team cache | `--cache URL`, `--cache none` | `cache:` | none |
| ccache | `--ccache`/`--no-ccache` | (none) | when installed |

Each resolved value carries where it came from (:class:`Chosen`), so that an error names the flag
or the uros.yaml line the user has to change. Nothing here starts a process; plan.py validates the
values (profiles, metas, packages, the output folder).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Generic, TypeVar

from uros_build import defaults
from uros_build.errors import ConfigError
from uros_build.sources.workspace import Workspace
from uros_build.sources.wsfiles import CONFIG, WorkspaceConfig, find_workspace, load_config

T = TypeVar("T")

# ---------------------------------------------------------------------------------------------
# the workspace: one default for every command


def resolve_workspace(given: Path | None, cwd: Path | None = None) -> Path:
    """-w/--workspace as given, else the nearest folder upward with a uros.yaml, else ./firmware."""
    if given is not None:
        return given
    here = cwd if cwd is not None else Path.cwd()
    found = find_workspace(here)
    return found if found is not None else here / defaults.FIRMWARE_DIR


def open_workspace(given: Path | None, cwd: Path | None = None) -> Workspace:
    """The workspace a build runs in. Without -w, a folder that is no uros workspace is refused
    before anything is written: run in the wrong folder, a build would crawl every project below
    it for packages and leave .uros/ and build/ behind."""
    path = resolve_workspace(given, cwd)
    if given is None and not path.exists():
        here = cwd if cwd is not None else Path.cwd()
        raise ConfigError(
            f"no uros workspace here: no {CONFIG} in {here} or above it, and no ./{defaults.FIRMWARE_DIR}",
            "cd into a firmware workspace, create one with `uros create-firmware generate_lib` "
            "(makes ./firmware), or pass -w DIR (a colcon workspace with packages works too)",
        )
    return Workspace.open(path)


# ---------------------------------------------------------------------------------------------
# uros build


@dataclass(frozen=True)
class BuildArgs:
    """What the command line said, unvalidated."""

    workspace: Path | None = None  # None: resolve_workspace's default
    toolchain: str | None = None
    toolchains: tuple[str, ...] = ()  # --toolchain given several times: one build each
    profile: Path | None = None
    metas: tuple[Path, ...] = ()
    sets: tuple[str, ...] = ()
    preset: str = defaults.PRESET
    transport: str | None = None
    output: Path | None = None
    verbose: bool = False
    force: bool = False
    packages_up_to: tuple[str, ...] = ()
    jobs: int | None = None
    compiler_prefix: str | None = None
    cflags: tuple[str, ...] = ()
    rebuild: bool = False  # run every step even when no input changed
    packages: tuple[str, ...] = ()  # --packages: what the firmware wants (the core is added)
    for_firmware: Path | None = None  # --for-firmware: read what it wants from its sources
    toolchain_from: str = "--toolchain"  # where toolchain came from (uros.yaml's target), for messages
    idf_build: Path | None = None  # an ESP-IDF project's build folder to compile micro-ROS against
    cache: str | None = None  # --cache URL: a team cache of outputs (default: uros.yaml's cache:)
    cache_upload: bool = False  # --cache-upload: write this build's output to the cache
    ccache: bool | None = None  # --ccache/--no-ccache (None: ccache when it is installed)

    def names_a_target(self) -> bool:
        return bool(self.toolchain or self.toolchains or self.profile or self.compiler_prefix or self.cflags)


def expand_targets(args: BuildArgs) -> tuple[BuildArgs, ...]:
    """One BuildArgs per target to build: the command line's, else the workspace uros.yaml's
    target or targets (the command line wins), else the command line's as it is (and plan_build
    says that no target was given)."""
    names = tuple(dict.fromkeys(args.toolchains))
    if len(names) > 1:
        if args.output is not None:
            raise ConfigError(
                f"--output with {len(names)} targets ({', '.join(names)})",
                "each target has its own output (<workspace>/build/<target>): leave --output out",
            )
        if args.profile is not None:
            raise ConfigError(
                f"--profile with {len(names)} --toolchain targets", "give --toolchain or --profile, once"
            )
        return tuple(replace(args, toolchain=n, toolchains=(n,)) for n in names)
    if names:
        args = replace(args, toolchain=names[0])
    if args.names_a_target():
        return (args,)
    root = resolve_workspace(args.workspace)
    cfg = load_config(root) if root.is_dir() else None
    if cfg is None:
        return (args,)
    names = cfg.targets or ((cfg.target,) if cfg.target else ())
    if len(names) > 1 and args.output is not None:
        raise ConfigError(
            f"--output with {len(names)} targets ({', '.join(names)} from {root / CONFIG})",
            "pass --toolchain NAME to build one of them into --output, or leave --output out",
        )
    key = "targets" if cfg.targets else "target"
    where = f"{root / CONFIG}: {key}"
    expanded = tuple(replace(args, workspace=root, toolchain=n, toolchain_from=where) for n in names)
    return expanded or (args,)


@dataclass(frozen=True)
class Chosen(Generic[T]):
    """A setting's value and who chose it: a flag, a uros.yaml line (``/ws/uros.yaml: transport``)
    or ``default``."""

    value: T
    source: str


def pick(given: T | None, flag: str, configured: T | None, config_line: str, default: T) -> Chosen[T]:
    """The command line's value, else uros.yaml's, else the default (None: not given)."""
    if given is not None:
        return Chosen(given, flag)
    if configured is not None:
        return Chosen(configured, config_line)
    return Chosen(default, "default")


@dataclass(frozen=True)
class BuildSettings:
    """The settings of one build after the precedence above (before plan.py checks them)."""

    transport: Chosen[str | None]
    sets: tuple[str, ...]  # uros.yaml's set:, then --set (a later --set of an option wins)
    packages: Chosen[tuple[str, ...]]  # () : every package (or --for-firmware's alone)
    cache: Chosen[str | None]  # a URL, "none", or None
    idf_build: Chosen[Path | None]  # uros.yaml's is relative to the workspace


def build_settings(args: BuildArgs, cfg: WorkspaceConfig | None, root: Path) -> BuildSettings:
    """``args`` over ``cfg`` (the uros.yaml of the workspace at ``root``; None: there is none)."""
    line = f"{root / CONFIG}:"
    # --for-firmware reads what the firmware wants: uros.yaml's packages: list does not add to it
    packages = (cfg.packages if cfg is not None and args.for_firmware is None else ()) or None
    transport = cfg.transport if cfg else None
    idf_build = root / cfg.idf_build if cfg is not None and cfg.idf_build else None
    return BuildSettings(
        transport=pick(args.transport, "--transport", transport, f"{line} transport", None),
        sets=(*(cfg.set if cfg else ()), *args.sets),
        packages=pick(args.packages or None, "--packages", packages, f"{line} packages", ()),
        cache=pick(args.cache, "--cache", cfg.cache if cfg else None, f"{line} cache", None),
        idf_build=pick(args.idf_build, "--idf-build", idf_build, f"{line} idf_build", None),
    )
