"""The commands that print or render without building: `uros targets`, `uros distros`,
`uros toolchain render`, `uros meta write`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from uros_build import console, defaults, loader
from uros_build.config.colconmeta import meta_for
from uros_build.config.resolver import resolve_workspace
from uros_build.config.targets import resolve_target
from uros_build.errors import ConfigError
from uros_build.files import write_if_changed
from uros_build.output import contents
from uros_build.sources import distros as distros_mod
from uros_build.sources import meta as meta_mod
from uros_build.sources import options as options_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.workspace import Workspace, check_file_target
from uros_build.target.profiles import OR_PROFILE_FILE, find_profile, load_profile_file, shipped_profiles
from uros_build.target.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    render_toolchain,
)


def targets_table() -> list[dict[str, Any]]:
    return [
        {
            "name": p.name,
            "description": p.description,
            "compiler": p.tool("gcc"),
            "cpu_flags": list(p.cpu_flags),
            "transport": p.transport,
            "file": Path(p.source).name,
        }
        for p in shipped_profiles().values()
    ]


def target_profile_text(name: str) -> str:
    """`uros targets show`: a shipped profile's file as it is, comments and all (to copy and edit)."""
    profile = find_profile(name, "NAME", "")
    return loader.read_text(Path(profile.source))


def distros_table() -> list[dict[str, Any]]:
    rows = []
    for name in distros_mod.known_distros():
        d = distros_mod.load_distro(name)
        rows.append(
            {
                "name": d.name,
                "status": d.status,
                "dev_repositories": len(d.dev),
                "mcu_repositories": len(d.mcu),
                "stand_in_count": len(d.stand_ins),
                "stand_ins": [{"repository": o.key, "use": o.use, "why": o.reason} for o in d.stand_ins],
            }
        )
    return rows


def distro_repositories(name: str) -> list[dict[str, Any]]:
    """`uros distros show NAME`: each repository (dev_ws/..., mcu_ws/...), the manifest's version,
    and the declared stand-in for it (what `create-firmware --stand-ins` clones instead, and why)."""
    d = distros_mod.load_distro(name, "NAME")
    rows = []
    for ws, repos in (("dev_ws", d.dev), ("mcu_ws", d.mcu)):
        for repo in repos:
            o = next((s for s in d.stand_ins if s.matches(repo)), None)
            rows.append(
                {
                    "path": f"{ws}/{repo.path}",
                    "url": repo.url,
                    "version": repo.version,
                    "stand_in": o.use if o else "-",
                    "why": o.reason if o else "",
                }
            )
    return rows


def options_table() -> list[dict[str, Any]]:
    """`uros meta options`: the known options, their upstream default and the value uros's
    default preset (the default distro's generate_lib meta) builds with."""
    preset = contents.cmake_options(meta_mod.load_preset(defaults.PRESET))
    return [
        {
            "package": o.package,
            "option": o.name,
            "default": o.default,
            "preset": preset.get(o.package, {}).get(o.name, ""),
            "type": o.type,
            "choices": list(o.choices),
            "cost": o.cost,
            # the static pools it sizes: `uros size` reads their bytes from a library (nm)
            "pools": list(o.pools),
        }
        for o in options_mod.known_options()
    ]


def write_output_file(path: Path | None, text: str, flag: str = "--output") -> None:
    if path is None:
        sys.stdout.write(text)
        return
    check_file_target(path, flag)
    try:
        write_if_changed(path, text)
    except OSError as exc:
        raise ConfigError(f"{flag} {path}: cannot write: {exc.strerror}") from None
    console.info(f"wrote {path}")


def render_toolchain_file(target: str, output: Path | None, micro_ros: bool, gcc_major: int | None) -> None:
    """`uros toolchain render`: a target name or a profile .yaml -> toolchain text.

    For micro-ROS, the clock_gettime declaration header the profile may need is written beside
    the output file (to standard output: into the current folder) and referenced by absolute path,
    so the toolchain file works on its own; uros says where it wrote it.
    """
    if target.endswith((".yaml", ".yml")):
        profile = load_profile_file(Path(target))
    else:
        profile = find_profile(target, "TARGET", OR_PROFILE_FILE)
    header: Path | None = None
    if output is not None:
        check_file_target(output, "--output")  # before the header is written beside it
    if micro_ros and profile.micro_ros.declare_clock_gettime:
        header = output.resolve().with_name(CLOCK_HEADER_NAME) if output else Path.cwd() / CLOCK_HEADER_NAME
        try:
            write_if_changed(header, CLOCK_HEADER_TEXT)
        except OSError as exc:
            raise ConfigError(
                f"cannot write {header} (the toolchain file's -include names it): {exc.strerror}",
                "run in a folder you can write to, or pass -o FILE",
            ) from None
        console.info(f"wrote {header} (the toolchain file force-includes it: keep it beside the file)")
    command = f"uros toolchain render {target}" + (" --for micro-ros" if micro_ros else "")
    req = ToolchainRequest(
        profile,
        micro_ros=micro_ros,
        gcc_major=gcc_major,
        clock_header=str(header) if header else None,
        command=command,
    )
    write_output_file(output, render_toolchain(req))


def write_meta(
    preset: str,
    target: str | None,
    transport: str | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    output: Path | None,
) -> None:
    """`uros meta write`: the colcon.meta `uros build` would use (JSON, sorted keys)."""
    resolved = resolve_target(target, None) if target else None
    for warning in options_mod.check_sets(sets, options_mod.by_package(options_mod.known_options())):
        console.warn(warning)
    merged = meta_for(preset, resolved, transport, list(metas), list(sets))
    text = meta_mod.dump_meta(merged, f"uros meta write --preset {preset or defaults.PRESET}")
    write_output_file(output, text)


# -- names for shell completion (never raise: a completion must not print a traceback) ----------


def target_names() -> list[str]:
    try:
        return list(shipped_profiles())
    except Exception:
        return []


def distro_names() -> list[str]:
    try:
        return distros_mod.known_distros()
    except Exception:
        return []


def package_names(workspace: Path | None) -> list[str]:
    """The packages of the workspace (-w, else the default one), for --packages-up-to and --set."""
    try:
        root = resolve_workspace(workspace)
        return [p.name for p in packages_mod.discover(Workspace(root).source_dir)] if root.is_dir() else []
    except Exception:
        return []


def set_candidates(workspace: Path | None) -> list[str]:
    """PKG.OPTION= for the known options, and PKG. for the workspace's packages."""
    try:
        known = [f"{o.package}.{o.name}=" for o in options_mod.known_options()]
    except Exception:
        known = []
    return known + [f"{name}." for name in package_names(workspace)]
