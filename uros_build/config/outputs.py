"""Where the read commands (info, size, probe, export) find an output: the workspace's default
folder for a target, or the folder given; a swap a killed build left half-way is finished or undone
first. Nothing here starts a process."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from uros_build import console
from uros_build.config.resolver import resolve_workspace
from uros_build.config.targets import named_keys
from uros_build.errors import ConfigError, did_you_mean
from uros_build.output import swap
from uros_build.output.folders import is_uros_output, target_keys
from uros_build.sources.workspace import Workspace

# ---------------------------------------------------------------------------------------------
# the workspace: one default for every command


def finish_killed_swaps(output: Path | None, workspace: Path | None) -> None:
    """Before an output is read (`uros info`, `uros size`, `uros probe`): a swap into it that a
    killed build left half-way is finished or undone as the next build would (swap.finish_swaps),
    so the reader sees a whole output, the previous or the new. ``output``: the folder (or its
    libmicroros.a) named, else every target's output in the workspace."""
    if output is not None:
        folders = [output.parent if output.suffix == ".a" else output]
    else:
        try:
            ws = Workspace(resolve_workspace(workspace).resolve())
            folders = [ws.default_output(key) for key in target_keys(ws)]
        except (ConfigError, OSError):
            return  # no workspace: resolve_output says so
    for folder in folders:
        for line in swap.finish_swaps(folder.absolute(), tidy=False):
            console.info(line)


def resolve_output(
    output: Path | None, workspace: Path | None, toolchain: str | None, env: Mapping[str, str] | None = None
) -> Path:
    """The build output a command reads (uros info, uros size, uros probe): OUTPUT as given, else
    in the workspace: the target the settings name (--toolchain, else uros.yaml's one target),
    else the only one built."""
    if output is not None:
        return output
    root = resolve_workspace(workspace)
    ws = Workspace(root.resolve())
    built = [k for k in target_keys(ws) if is_uros_output(ws.default_output(k))]
    keys = named_keys(ws, toolchain, env)
    if len(keys) != 1:
        if len(built) != 1:
            raise ConfigError(
                f"which output? {len(built)} built in {ws.root}: {', '.join(built) or 'none'}",
                "pass the output folder (e.g. firmware/build/cortex-m7), or --toolchain NAME",
            )
        keys = [(built[0], built[0])]
    ((name, key),) = keys
    if key not in built:
        raise ConfigError(
            f"--toolchain {name}: no output of it in {ws.root}{did_you_mean(key, built)}",
            f"build it first: uros build --toolchain {name}"
            + (f" (built: {', '.join(built)})" if built else ""),
        )
    return ws.default_output(key)
