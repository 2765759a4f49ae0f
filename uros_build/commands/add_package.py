"""`uros add-package`: one more package in a firmware workspace's mcu_ws/extra_packages."""

from __future__ import annotations

import shutil
from pathlib import Path

from uros_build import console
from uros_build.config.resolver import resolve_workspace
from uros_build.errors import ConfigError, StepFailed
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.sources import packages as packages_mod
from uros_build.sources.workspace import Workspace, check_extra_package, sync_tree
from uros_build.sources.wsfiles import CONFIG, with_extra_package


def _is_url(source: str) -> bool:
    return "://" in source or source.startswith("git@")


def add_package(source: str, workspace: Path | None, version: str | None, verbose: bool) -> Path:
    ws, cfg = Workspace.open_firmware(resolve_workspace(workspace))
    if _is_url(source):
        return _clone_package(ws, source, version, verbose)
    path = Path(source).resolve()
    name = check_extra_package(path, "add-package")
    dest = ws.extra_dir / name
    if str(path) in cfg.extra_packages:
        sync_tree(path, dest)
        console.step(f"{name} is already in {CONFIG} ({path}): synced into {dest}")
        return dest
    _refuse_duplicates(ws, {name}, f"add-package {path}")
    config = ws.root / CONFIG
    # a line edit: uros.yaml is the user's file, with the user's comments
    edited = with_extra_package(config.read_text(encoding="utf-8"), str(path), str(config))
    sync_tree(path, dest)
    write_if_changed(config, edited)
    console.step(f"added {name}: {path} is synced into {dest} at every `uros build`")
    return dest


def _refuse_duplicates(ws: Workspace, names: set[str], what: str, skip: Path | None = None) -> None:
    """A package name is one package in a colcon workspace: a second folder of that name breaks the
    build ('Duplicate package names not supported'), so it is refused before anything is written."""
    for pkg in packages_mod.discover(ws.source_dir):
        if pkg.name in names and (skip is None or not pkg.path.resolve().is_relative_to(skip)):
            raise ConfigError(
                f"{what}: the workspace already has a package named {pkg.name} ({pkg.path})",
                "remove that one first (for an extra package: its line in uros.yaml and its copy), "
                "or give this package another name in its package.xml",
            )


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
    found = packages_mod.discover(dest)
    if not found:
        shutil.rmtree(dest)
        raise ConfigError(
            f"add-package {source}: the repository holds no package.xml", "pass a ROS 2 package"
        )
    try:
        _refuse_duplicates(ws, {p.name for p in found}, f"add-package {source}", skip=dest.resolve())
    except ConfigError:
        shutil.rmtree(dest)  # uros cloned it just now
        raise
    console.step(f"cloned {source} into {dest}")
    return dest
