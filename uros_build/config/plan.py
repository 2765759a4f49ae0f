"""Settings → frozen, validated plans (pypa/cibuildwheel's options.py idea).

settings.py decides who wins (command line, environment, uros.yaml, defaults); here every setting is checked
without starting a process: the target, the profile, the metas, the distro, the packages asked for,
the output folder. What comes out is a frozen value the commands execute; the mapping is
unit-tested without running anything. Checked later, because a process must run first: the extra
packages' clones (`uros build` syncs them before its lock), the host tools, the compilers.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from uros_build import defaults
from uros_build.config import settings as rows
from uros_build.config.buildargs import BuildArgs, build_settings
from uros_build.config.buildplan import BuildPlan, Selection
from uros_build.config.colconmeta import meta_for, meta_transport, only_the_preset
from uros_build.config.platform import (
    Platform,
    check_multithread,
    check_udp_profile,
    idf_platform,
    idf_project,
    ip_stack_headers,
    rtos_headers,
    udp_without_stack,
)
from uros_build.config.resolver import Chosen, Resolved, open_workspace
from uros_build.config.targets import names_a_file, resolve_target
from uros_build.errors import ConfigError
from uros_build.output import team_cache as cache_mod
from uros_build.output.exports import refuse_package_folder
from uros_build.output.folders import check_output_dir, check_output_owner
from uros_build.output.team_cache import CacheSettings
from uros_build.sources import distros as distros_mod
from uros_build.sources import meta as meta_mod
from uros_build.sources import options as options_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.packages import PackageInfo
from uros_build.sources.workspace import Workspace, check_folder_target
from uros_build.sources.wsfiles import CONFIG, WorkspaceConfig, load_config

# ---------------------------------------------------------------------------------------------
# uros build


def _closest(name: str, names: set[str]) -> str:
    near = packages_mod.closest(name, names)
    return f" (closest: {', '.join(near)})" if near else ""


def unknown_packages(
    metas: list[meta_mod.Meta],
    sets: tuple[str, ...],
    names: set[str],
    origins: Mapping[str, str] | None = None,
) -> list[str]:
    """Warnings for --meta and --set entries that name no package of the workspace: colcon
    ignores them without a word, so a typo would silently build with the default (pure).
    ``origins``: a set entry -> where it was given, when not --set (uros.yaml's set:)."""
    out = []
    for meta in metas:
        for pkg in meta.names:
            if pkg not in names:
                near = _closest(pkg, names)
                out.append(f"--meta {meta.source}: names.{pkg}: no package {pkg} in the workspace{near}")
    for item in sets:
        where = (origins or {}).get(item, "--set")
        pkg = meta_mod.split_set(item, where).package
        if pkg not in names:
            out.append(f"{where} {item}: no package {pkg} in the workspace{_closest(pkg, names)}")
    return out


def set_origins(cfg: WorkspaceConfig | None, root: Path, given: tuple[str, ...]) -> dict[str, str]:
    """The set: entries of uros.yaml that the command line does not repeat -> ``uros.yaml: set:``,
    so that a message about one names the file it is in, not a --set the user never typed."""
    return {s: f"{root / CONFIG}: set:" for s in (cfg.set if cfg else ()) if s not in given}


def _select(
    args: BuildArgs,
    chosen: Chosen[tuple[str, ...]],
    ws: Workspace,
    packages: list[PackageInfo],
    names: set[str],
) -> Selection | None:
    """What --packages, --for-firmware or uros.yaml's packages: ask for, plus the core and the
    extra packages; None when none of them is given (every package is built)."""
    wanted = chosen.value
    use = None
    if args.for_firmware is not None:
        folder = args.for_firmware
        if not folder.is_dir():
            raise ConfigError(
                f"--for-firmware {folder}: no such folder", "pass your firmware's source folder"
            )
        from uros_build.sources import firmware_scan  # --for-firmware only (start-up cost)

        use = firmware_scan.scan_folder(folder.resolve())
        if not use.packages:
            raise ConfigError(
                f"--for-firmware {folder}: no interface type found in {use.scanned} C/C++ files",
                "it looks for #include <pkg/msg/...>, <pkg/srv/...>, <pkg/action/...> and "
                "ROSIDL_GET_MSG_TYPE_SUPPORT(pkg, msg, Type); or name them: --packages PKG",
            )
    if not wanted and use is None:
        return None
    if args.packages_up_to:
        raise ConfigError(
            "--packages-up-to and --packages/--for-firmware/uros.yaml packages: both choose the packages",
            "use one: --packages adds the core and the extra packages, "
            "--packages-up-to takes exactly what it names",
        )
    flag = chosen.source
    for pkg in wanted:
        if pkg not in names:
            raise ConfigError(
                f"{flag} {pkg}: no package {pkg} in {ws.source_dir}{_closest(pkg, names)}",
                "name a package of the workspace (a folder with a package.xml)",
            )
    for pkg in sorted(use.packages if use else ()):
        if pkg not in names:
            files = ", ".join((use.files[pkg] if use else ())[:3])
            raise ConfigError(
                f"--for-firmware {args.for_firmware}: the firmware uses {pkg} ({files}), "
                f"which is not in the workspace{_closest(pkg, names)}",
                "add the package to the workspace: uros add-package PATH",
            )
    core = tuple(p for p in defaults.CORE_PACKAGES if p in names)
    extra_dir = ws.extra_dir
    extra = tuple(p.name for p in packages if p.path.is_relative_to(extra_dir))
    return Selection(tuple(wanted), use, core, extra)


def plan_build(args: BuildArgs, env: Mapping[str, str] | None = None) -> BuildPlan:
    """Validate every input of `uros build` (reads files, starts nothing); ``env``: the
    environment its settings are read from (None: this process's)."""
    ws = open_workspace(args.workspace)
    cfg = load_config(ws.root)
    if cfg is not None:
        ws.check_extra_sources(cfg)
    toolchain = args.toolchain
    if toolchain and args.toolchain_from != "--toolchain" and names_a_file(toolchain):
        toolchain = str(ws.root / toolchain)  # a file named in uros.yaml: from the workspace
    target = resolve_target(toolchain, args.profile, args.compiler_prefix, args.cflags, args.toolchain_from)
    settings = build_settings(args, cfg, ws.root, os.environ if env is None else env)
    get = settings.value  # every setting below as the precedence chose it (settings.py)
    # a distro only chooses the meta preset here: a uros.yaml without one builds with uros's own
    name = settings[rows.DISTRO]
    distro = distros_mod.load_distro(name.value, name.source) if name.value else None
    metas: tuple[Path, ...] = get(rows.METAS)
    user_metas = list(metas)
    distro_preset = distro.preset if distro else None
    if cfg is not None and ws.user_meta.is_file() and not only_the_preset(ws.user_meta, distro_preset):
        user_metas.insert(0, ws.user_meta)
    transport, sets = get(rows.TRANSPORT), get(rows.SETS)
    jobs, up_to = get(rows.JOBS), get(rows.PACKAGES_UP_TO)
    idf = idf_project(settings[rows.IDF_BUILD], target)
    target = idf_platform(target, idf)
    rtos = rtos_headers(settings, target, idf)
    meta = meta_for(get(rows.PRESET), target, transport, user_metas, list(sets), distro_preset)
    check_multithread(meta, target, idf, rtos)
    ip_stack = ip_stack_headers(settings, target, idf, rtos, meta_transport(meta))
    check_udp_profile(meta, ip_stack)
    if jobs is not None and jobs < 1:
        raise ConfigError(f"-j/--jobs {jobs}: must be 1 or more", "omit it to let colcon choose")
    packages = packages_mod.discover(ws.source_dir)
    names = {p.name for p in packages}
    named = {*up_to, *(meta_mod.split_set(s).package for s in sets)}
    given_metas = [meta_mod.load_meta_file(p) for p in metas]
    named |= {pkg for m in given_metas for pkg in m.names}
    if named - names:  # colcon also builds CMake packages that have no package.xml
        names |= packages_mod.plain_cmake_packages(ws.source_dir)
    for pkg in up_to:
        if pkg not in names:
            raise ConfigError(
                f"--packages-up-to {pkg}: no package {pkg} in {ws.source_dir}{_closest(pkg, names)}",
                "name a package of the workspace (a folder with a package.xml or a CMakeLists.txt)",
            )
    origins = set_origins(cfg, ws.root, args.sets)
    warnings = unknown_packages(given_metas, sets, names, origins)
    warnings += udp_without_stack(target, idf, ip_stack, meta_transport(meta))
    warnings += options_mod.check_sets(sets, options_mod.by_package(options_mod.known_options()), origins)
    selection = _select(args, settings[rows.PACKAGES], ws, packages, names)
    given_output, force = get(rows.OUTPUT), get(rows.FORCE)
    out = (given_output or ws.default_output(target.key)).resolve()
    flag = "--output" if given_output else "the output folder"
    check_folder_target(out, flag)
    # the output is a CMake package (microrosConfig.cmake, toolchain.cmake): as `uros export cmake`
    refuse_package_folder("cmake", out, flag, "build into a folder without it (--output DIR)")
    check_output_dir(out, force, flag, ws.root)
    check_output_owner(out, target.key, force, flag)
    return BuildPlan(
        workspace=ws,
        config=cfg,
        distro=distro,
        target=target,
        meta=meta,
        output=out,
        target_dir=ws.target_dir(target.key),
        packages_up_to=up_to,
        jobs=jobs,
        verbose=get(rows.VERBOSE),
        workspace_packages=tuple(packages),
        warnings=tuple(warnings),
        platform=Platform(idf, rtos, ip_stack),
        rebuild=get(rows.REBUILD),
        selection=selection,
        force=force,
        output_flag=flag,
        cache=_cache_settings(
            settings[rows.CACHE], get(rows.CACHE_UPLOAD), ws.root / CONFIG, get(rows.CACHE_TIMEOUT)
        ),
        ccache=get(rows.CCACHE),
        settings=Resolved({**settings.chosen, rows.OUTPUT.name: Chosen(out, settings[rows.OUTPUT].source)}),
        host_stage=get(rows.HOST_STAGE),
        compiler_seed=get(rows.COMPILER_SEED),
        gen_cache=get(rows.GEN_CACHE),
        gen_cache_dir=get(rows.GEN_CACHE_DIR),
    )


def _cache_settings(
    chosen: Chosen[str | None], upload: bool, config_path: Path, timeout: float = cache_mod.TIMEOUT_SECONDS
) -> CacheSettings | None:
    """The team cache the settings name (settings.py); --cache-upload needs one."""
    text, where = chosen.value, chosen.source
    if text is None:
        if upload:
            raise ConfigError(
                "--cache-upload without a cache", f"add --cache URL or a cache: line to {config_path}"
            )
        return None
    if text in ("", "none"):  # --cache none: this build without the workspace's cache
        if upload:
            raise ConfigError("--cache-upload with --cache none", "give the cache's URL to upload to")
        return None
    return CacheSettings(cache_mod.parse_url(text, where), upload=upload, timeout=timeout)
