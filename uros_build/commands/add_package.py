"""`uros add-package`: one more package in a firmware workspace's mcu_ws/extra_packages."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError, StepFailed
from uros_build.plan import resolve_workspace
from uros_build.proc import Runner
from uros_build.workspace import Workspace, check_extra_package, save_config, sync_tree


def _is_url(source: str) -> bool:
    return "://" in source or source.startswith("git@")


def add_package(source: str, workspace: Path | None, version: str | None, verbose: bool) -> Path:
    ws, cfg = Workspace.open_firmware(resolve_workspace(workspace))
    if _is_url(source):
        return _clone_package(ws, source, version, verbose)
    path = Path(source).resolve()
    name = check_extra_package(path, "add-package")
    entries = list(cfg.extra_packages)
    if str(path) not in entries:
        entries.append(str(path))
    save_config(ws.root, replace(cfg, extra_packages=tuple(entries)))
    dest = ws.extra_dir / name
    sync_tree(path, dest)
    console.step(f"added {name}: {path} is synced into {dest} at every `uros build`")
    return dest


def _clone_package(ws: Workspace, source: str, version: str | None, verbose: bool) -> Path:
    name = source.rstrip("/").rsplit("/", 1)[-1].removesuffix(".git")
    dest = ws.extra_dir / name
    if dest.exists():
        raise ConfigError(f"add-package: {dest} already exists", "remove it first to clone it again")
    runner = Runner(ws.new_log("add-package"), verbose=verbose)
    argv = [runner.which("git"), "clone", "--quiet", *(["--branch", version] if version else []), source]
    try:
        runner.run([*argv, str(dest)], step=f"clone {source}")
    except StepFailed:
        shutil.rmtree(dest, ignore_errors=True)
        raise
    if not list(dest.rglob("package.xml")):
        shutil.rmtree(dest)
        raise ConfigError(
            f"add-package {source}: the repository holds no package.xml", "pass a ROS 2 package"
        )
    console.step(f"cloned {source} into {dest}")
    return dest
