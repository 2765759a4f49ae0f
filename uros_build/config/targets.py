"""The target a command names: a profile uros renders a toolchain file from, or the user's own
toolchain file (the sum type ``Target``), and the one name -> folder-key rule (:func:`folder_key`)
that build, clean, info, size and probe share. Nothing here starts a process."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.config import settings as rows
from uros_build.config.resolver import resolve_one
from uros_build.errors import ConfigError
from uros_build.sources.workspace import Workspace, target_key
from uros_build.sources.wsfiles import CONFIG, load_config
from uros_build.target.profiles import (
    TargetProfile,
    derive_profile,
    find_profile,
    load_profile_file,
    shipped_profiles,
)


def named_keys(
    ws: Workspace, toolchain: str | None, env: Mapping[str, str] | None = None
) -> list[tuple[str, str]]:
    """The targets the settings name (--toolchain, else uros.yaml's target or targets), each as
    (its name, its folder key): what `uros build` builds here by default, and so what clean, info,
    size and probe look for."""
    cfg = load_config(ws.root) if toolchain is None and ws.root.is_dir() else None
    flags = {rows.TARGETS.name: (toolchain,) if toolchain else ()}
    chosen = resolve_one(rows.TARGETS, flags, cfg, ws.root, env if env is not None else os.environ)
    base = ws.root if chosen.source != rows.TARGETS.flag else None  # uros.yaml's: from the workspace
    return [(name, folder_key(name, chosen.source, base)) for name in chosen.value]


PROFILE_SUFFIXES = (".yaml", ".yml")  # a target named by such a file is a profile, as --profile's


def names_a_file(name: str) -> bool:
    """A target named by its file (a profile or a CMake toolchain file), not by a shipped target's
    name."""
    return name.endswith((".cmake", *PROFILE_SUFFIXES)) or "/" in name


def folder_key(name: str, where: str = "--toolchain", base: Path | None = None, profile: bool = False) -> str:
    """The one name → folder-key rule (.uros/targets/<key>, build/<key>) for a target as the
    command line or uros.yaml names it (``where``; ``base``: the folder a relative path is from,
    None: the current one): a shipped target's name as it is; a profile file's ``name:`` (a
    .yaml name, or ``profile``: --profile's file); a toolchain file's stem, made folder-safe.
    :func:`resolve_target` gives every target the key this gives its name."""
    if profile or name.endswith(PROFILE_SUFFIXES):
        path = base / name if base is not None else Path(name)
        if path.is_file():
            return target_key(load_profile_file(path).name, f"{where} {name}")
        return target_key(Path(name).stem, f"{where} {name}")  # gone: the name it most likely had
    if names_a_file(name):
        return target_key(Path(name).stem, f"{where} {name}")
    return target_key(name, where)


# ---------------------------------------------------------------------------------------------
# the target: a profile uros renders a toolchain file from, or the user's own toolchain file


@dataclass(frozen=True)
class ProfileTarget:
    key: str  # folder-safe name: .uros/targets/<key>, build/<key>
    profile: TargetProfile


@dataclass(frozen=True)
class ToolchainFileTarget:
    key: str
    toolchain_file: Path  # used unchanged; uros knows no ELF facts to check against


Target = ProfileTarget | ToolchainFileTarget


def resolve_target(
    toolchain: str | None,
    profile_path: Path | None,
    compiler_prefix: str | None = None,
    cflags: tuple[str, ...] = (),
    flag: str = "--toolchain",
) -> Target:
    """``flag``: where ``toolchain`` came from, for messages (``--toolchain``, or uros.yaml's target)."""
    derive = compiler_prefix is not None or bool(cflags)
    if profile_path is not None:
        if toolchain is not None:
            raise ConfigError("--toolchain and --profile name a target twice", "pass only one of them")
        profile = load_profile_file(profile_path)
        if derive:
            profile = derive_profile(profile, compiler_prefix, cflags)
        return ProfileTarget(target_key(profile.name), profile)
    if toolchain is None:
        if derive:
            profile = derive_profile(None, compiler_prefix, cflags)
            return ProfileTarget(target_key(profile.name), profile)
        raise ConfigError(
            "no target given",
            f"pass --toolchain with one of: {', '.join(shipped_profiles())}, "
            f"or name it in the workspace's {CONFIG} (target: NAME)",
        )
    if toolchain.endswith(PROFILE_SUFFIXES):
        # a profile file (uros.yaml's target: boards/my_board.yaml), as --profile takes: never a
        # CMake toolchain file, which CMake would fail to parse (issue 34, item 3)
        if not Path(toolchain).is_file():
            raise ConfigError(
                f"{flag} {toolchain}: no such profile file",
                "pass a target name, a profile (.yaml) or a CMake toolchain file (.cmake) that exists",
            )
        return resolve_target(None, Path(toolchain), compiler_prefix, cflags, flag)
    if names_a_file(toolchain):
        if derive:
            raise ConfigError(
                f"--compiler-prefix/--cflags cannot change your own toolchain file {toolchain}",
                "edit the file, or derive from a target name or a profile (--profile my-board.yaml)",
            )
        path = Path(toolchain).resolve()
        if not path.is_file():
            raise ConfigError(
                f"{flag} {toolchain}: no such file", "pass a target name or an existing .cmake file"
            )
        return ToolchainFileTarget(folder_key(toolchain, flag), path)
    profile = find_profile(toolchain, flag)
    if derive:
        profile = derive_profile(profile, compiler_prefix, cflags)
        return ProfileTarget(target_key(profile.name), profile)
    return ProfileTarget(target_key(profile.name), profile)


def target_profile(target: Target | None) -> TargetProfile | None:
    return target.profile if isinstance(target, ProfileTarget) else None
