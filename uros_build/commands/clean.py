"""`uros clean`: remove uros's own per-target trees and outputs from a workspace, and say how much
that freed. Only what uros wrote goes: .uros/targets/<key> (colcon's build/install/log, the
rendered toolchain and meta) and build/<key> when its build-info.json says uros wrote it; the
sources, uros.yaml, colcon.meta, dev_ws and any folder of the user's stay."""

from __future__ import annotations

import shutil
from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError, did_you_mean
from uros_build.plan import BuildArgs, expand_targets, resolve_workspace
from uros_build.workspace import Workspace, is_uros_output, locked, target_key, tree_bytes


def human(n: int) -> str:
    """Bytes as people read them (1024-based units, one decimal)."""
    size = float(n)
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if size < 1024 or unit == "GiB":
            return f"{n:,} bytes" if unit == "bytes" else f"{size:.1f} {unit}"
        size /= 1024
    raise AssertionError("unreachable")


def _chosen(ws: Workspace, toolchain: str | None, everything: bool) -> list[str]:
    present = ws.target_keys()
    if toolchain is not None and everything:
        raise ConfigError("--toolchain and --all: pass one of them")
    if everything:
        return present
    if toolchain is None:
        # the target(s) `uros build` would build here by default
        names = [str(a.toolchain) for a in expand_targets(BuildArgs(workspace=ws.root)) if a.toolchain]
        if not names:
            built = ", ".join(present) or "none"
            raise ConfigError(
                "uros clean: which target?", f"pass --toolchain NAME or --all (built here: {built})"
            )
        return [target_key(Path(n).stem if n.endswith(".cmake") else n) for n in names]
    key = target_key(toolchain)
    if key not in present:
        raise ConfigError(
            f"--toolchain {toolchain}: nothing of it in {ws.root}{did_you_mean(key, present)}",
            f"built here: {', '.join(present) or 'none'}",
        )
    return [key]


def clean(workspace: Path | None, toolchain: str | None, everything: bool) -> int:
    """Remove the chosen targets' trees and outputs; returns the bytes freed."""
    root = resolve_workspace(workspace)
    if not root.is_dir():
        raise ConfigError(f"--workspace {root}: no such folder", "pass the workspace to clean with -w DIR")
    ws = Workspace(root.resolve())
    freed = 0
    for key in _chosen(ws, toolchain, everything):
        tree, output = ws.target_dir(key), ws.default_output(key)
        ours = [p for p in (tree, output) if p.exists() and (p == tree or is_uros_output(p))]
        if output.exists() and output not in ours:
            console.warn(f"kept {output}: no build-info.json written by uros in it, so not a uros output")
        with locked(tree):  # never under a running build of the same target
            for path in ours:
                size = tree_bytes(path)
                shutil.rmtree(path)
                freed += size
                console.info(f"removed {path} ({human(size)})")
            # locked() made the tree's folder to hold its lock file when there was none
            shutil.rmtree(tree, ignore_errors=True)
    console.step(f"freed {human(freed)} ({freed:,} bytes) in {ws.root}")
    return freed
