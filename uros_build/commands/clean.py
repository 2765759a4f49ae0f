"""`uros clean`: remove uros's own per-target trees and outputs from a workspace, and say how much
that freed. Only what uros wrote goes: .uros/targets/<key> (colcon's build/install/log, the
rendered toolchain and meta), with --all the host stages (.uros/shared), and, of build/<key>, the
entries its `.uros-output` marker names (the folder itself only when nothing else is left in it);
the sources, uros.yaml, colcon.meta, dev_ws, a file the user put into an output and any folder of
the user's stay."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from uros_build import console
from uros_build.config.resolver import resolve_workspace
from uros_build.config.targets import folder_key, named_keys
from uros_build.errors import ConfigError, did_you_mean
from uros_build.files import locked, remove_tree
from uros_build.output import folders as outputs
from uros_build.sources.workspace import Workspace, tree_bytes


def human(n: int) -> str:
    """Bytes as people read them (1024-based units, one decimal)."""
    size = float(n)
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if size < 1024 or unit == "GiB":
            return f"{n:,} bytes" if unit == "bytes" else f"{size:.1f} {unit}"
        size /= 1024
    raise AssertionError("unreachable")


def _chosen(ws: Workspace, toolchain: str | None, everything: bool, profile: Path | None = None) -> list[str]:
    """The folder keys to clean: every one with --all, else the target named (--toolchain, --profile),
    else those `uros build` builds here by default (uros.yaml's); the name → key rule is the plan's."""
    present = outputs.target_keys(ws)
    if (toolchain is not None or profile is not None) and everything:
        raise ConfigError(f"{'--toolchain' if toolchain else '--profile'} and --all: pass one of them")
    if toolchain is not None and profile is not None:
        raise ConfigError("--toolchain and --profile name a target twice", "pass only one of them")
    if everything:
        return present
    if profile is not None:
        if not profile.is_file():
            raise ConfigError(f"--profile {profile}: no such file", "pass the profile file you built with")
        toolchain, key = str(profile), folder_key(str(profile), "--profile", profile=True)
    elif toolchain is None:
        keys = [key for _name, key in named_keys(ws, None)]
        if not keys:
            built = ", ".join(present) or "none"
            raise ConfigError(
                "uros clean: which target?", f"pass --toolchain NAME or --all (built here: {built})"
            )
        return keys
    else:
        key = folder_key(toolchain)
    if key not in present:
        flag = "--toolchain" if profile is None else "--profile"
        raise ConfigError(
            f"{flag} {toolchain}: nothing of it in {ws.root}{did_you_mean(key, present)}",
            f"built here: {', '.join(present) or 'none'}",
        )
    return [key]


_STAGE_NAME = re.compile(r"[0-9a-f]{16}")


def _clean_host_stages(ws: Workspace) -> int:
    """The host stages (.uros/shared/<key>: the packages that compile nothing, built once for every
    target), each under its lock; returns the bytes freed."""
    shared = ws.stages_dir
    freed = 0
    for stage in sorted(shared.iterdir()) if shared.is_dir() else ():
        # only the folders uros names (hoststage.plan_stage: 16 hex digits of their key)
        if not stage.is_dir() or stage.is_symlink() or not _STAGE_NAME.fullmatch(stage.name):
            continue
        size = tree_bytes(stage)
        with locked(stage, "the host stage"):  # never under a build that is taking from it
            why = remove_tree(stage)
        shutil.rmtree(stage, ignore_errors=True)  # the lock file locked() leaves
        if why is not None:
            console.warn(f"could not remove all of {stage}: {why}")
            continue
        freed += size
        console.info(f"removed {stage} ({human(size)})")
    return freed


def clean(
    workspace: Path | None, toolchain: str | None, everything: bool, profile: Path | None = None
) -> int:
    """Remove the chosen targets' trees and outputs; returns the bytes freed."""
    root = resolve_workspace(workspace)
    if not root.is_dir():
        raise ConfigError(f"--workspace {root}: no such folder", "pass the workspace to clean with -w DIR")
    ws = Workspace(root.resolve())
    freed = 0
    for key in _chosen(ws, toolchain, everything, profile):
        tree, output = ws.target_dir(key), ws.default_output(key)
        owned = outputs.owned_entries(output) if outputs.is_uros_output(output) else None
        if output.exists() and owned is None:
            console.warn(f"kept {output}: no uros marker in it, so not a uros output")
        # the marker last: an interrupted clean leaves an output uros still recognises
        names = sorted(set(owned or ()) - {outputs.MARKER}) + ([outputs.MARKER] if owned is not None else [])
        paths = [tree] + [output / name for name in names if (output / name).exists()]
        # measured before the lock, whose owner file (the pid of this process) is uros's own bookkeeping
        sizes = [tree_bytes(path) if path.exists() else 0 for path in paths]
        with locked(tree, key):  # never under a running build of the same target
            for path, size in zip(paths, sizes, strict=True):
                why = remove_tree(path)
                if why is not None:
                    console.warn(f"could not remove all of {path}: {why}")
                    continue
                freed += size
                if path != tree or size:
                    console.info(f"removed {path} ({human(size)})")
        # locked() made the tree's folder to hold its lock file when there was none
        shutil.rmtree(tree, ignore_errors=True)
        if owned is not None:
            kept = sorted(p.name for p in output.iterdir())
            if kept:
                console.warn(f"kept {output}: it holds files uros did not write ({', '.join(kept)})")
            else:
                output.rmdir()
    if everything:
        freed += _clean_host_stages(ws)
        # the interface code cache older uros kept in the workspace (now the user's, like ccache's:
        # ~/.cache/uros/gen, not the workspace's to drop)
        gen = ws.state_dir / "gen-cache"
        size = tree_bytes(gen) if gen.exists() else 0
        if size and remove_tree(gen) is None:
            freed += size
            console.info(f"removed {gen} ({human(size)})")
    console.step(f"freed {human(freed)} ({freed:,} bytes) in {ws.root}")
    return freed
