"""`uros build`'s command line as one record (:class:`BuildArgs`, one field a row of the settings
table, by its name), the targets a build expands to, and every row for one target's build through
the resolver. Nothing here starts a process."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, ClassVar

from uros_build import defaults
from uros_build.config.resolver import Chosen, Resolved, resolve, resolve_one, resolve_workspace
from uros_build.config.settings import PRESET, SETTINGS, TARGETS, Setting
from uros_build.errors import ConfigError
from uros_build.sources.wsfiles import CONFIG, WorkspaceConfig, load_config

# ---------------------------------------------------------------------------------------------
# uros build


@dataclass(frozen=True)
class BuildArgs:
    """What the command line said, unvalidated: one field a row of the table with an ``option``
    (cli/build.py passes click's values as they are, ``BuildArgs(**values)``), by its name, and the
    fields a build sets itself (``DERIVED``). A field without a row, or a row without a field, is an
    error when this module is imported (:func:`unmatched`)."""

    DERIVED: ClassVar[tuple[str, ...]] = ("toolchain", "toolchain_from")  # not from the command line

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
    rtos: str | None = None  # --rtos freertos: the RTOS micro-ROS is compiled against
    rtos_dir: Path | None = None  # its kernel's folder
    rtos_config: Path | None = None  # the folder of FreeRTOSConfig.h
    rtos_port: str | None = None  # the port folder, when not the core's
    ip_stack: str | None = None  # --ip-stack lwip: the IP stack the udp transport is compiled against
    ip_stack_dir: Path | None = None  # its folder
    ip_stack_config: Path | None = None  # the folder of lwipopts.h and arch/cc.h
    cache: str | None = None  # --cache URL: a team cache of outputs (default: uros.yaml's cache:)
    cache_upload: bool = False  # --cache-upload: write this build's output to the cache
    ccache: bool | None = None  # --ccache/--no-ccache (None: ccache when it is installed)

    def names_a_target(self) -> bool:
        return bool(self.toolchain or self.toolchains or self.profile or self.compiler_prefix or self.cflags)

    def flags(self) -> dict[str, object]:
        """The command line's values by row name (a flag left out: None, False or ())."""
        given: dict[str, object] = {f.name: getattr(self, f.name) for f in fields(self)}
        given["toolchains"] = self.toolchains or ((self.toolchain,) if self.toolchain else ())
        for name in _FLAGS:  # on/off flags: off is "not given"
            given[name] = True if given[name] else None
        # click fills in --preset's default: that value is the default's, whoever typed it
        given["preset"] = None if self.preset == PRESET.default else self.preset
        return given


def unmatched(names: tuple[str, ...], rows: tuple[Setting[Any], ...]) -> list[str]:
    """What keeps a record's fields (``names``) and the rows with an option apart: a field no row
    names, a row no field takes (as cibuildwheel refuses an option its table does not list). Pure."""
    options = [s.name for s in rows if s.option is not None]
    return [
        f"BuildArgs.{n} has no row with an option in config/settings.py" for n in names if n not in options
    ] + [f"setting {n} has an option but no BuildArgs field" for n in options if n not in names]


_PROBLEMS = unmatched(tuple(f.name for f in fields(BuildArgs) if f.name not in BuildArgs.DERIVED), SETTINGS)
if _PROBLEMS:
    raise TypeError("; ".join(_PROBLEMS))
_FLAGS = tuple(s.name for s in SETTINGS if s.option is not None and s.option.kind == "flag")


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
    chosen = resolve_one(TARGETS, args.flags(), cfg, root, {})  # no variable names a target
    names = chosen.value
    if not names:
        return (args,)
    if len(names) > 1 and args.output is not None:
        raise ConfigError(
            f"--output with {len(names)} targets ({', '.join(names)} from {root / CONFIG})",
            "pass --toolchain NAME to build one of them into --output, or leave --output out",
        )
    return tuple(replace(args, toolchain=n, toolchain_from=chosen.source) for n in names)


def build_settings(
    args: BuildArgs, cfg: WorkspaceConfig | None, root: Path, env: Mapping[str, str] | None = None
) -> Resolved:
    """Every row for `uros build`: ``args`` over the environment over ``cfg`` (the uros.yaml of
    the workspace at ``root``; None: there is none) over the defaults."""
    resolved = resolve(args.flags(), cfg, root, env if env is not None else {}, _BUILD_ROWS)
    if args.toolchain is None:
        return resolved
    # one target of the run (expand_targets): the one this build is for, and who named it
    return Resolved({**resolved.chosen, TARGETS.name: Chosen((args.toolchain,), args.toolchain_from)})


_BUILD_ROWS = tuple(s for s in SETTINGS if "build" in s.commands)
