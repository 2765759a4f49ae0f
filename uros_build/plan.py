"""Raw command-line arguments → frozen, validated plans (pypa/cibuildwheel's options.py idea).

Every input is read and checked here, before any process starts: the target, the profile, the
metas, the workspace's uros.yaml and distro, the output folder. What comes out is a frozen value
that the commands execute; the mapping itself is unit-tested without running anything.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from uros_build import cache as cache_mod
from uros_build import defaults, espidf, firmware_scan, loader
from uros_build import distros as distros_mod
from uros_build import meta as meta_mod
from uros_build import options as options_mod
from uros_build import packages as packages_mod
from uros_build.cache import CacheSettings
from uros_build.distros import Distro, Mirror, Source
from uros_build.errors import ConfigError, did_you_mean
from uros_build.espidf import IdfProject
from uros_build.outputs import check_output_dir, check_output_owner, is_uros_output, target_keys
from uros_build.packages import PackageInfo
from uros_build.profiles import (
    TargetProfile,
    derive_profile,
    find_profile,
    load_profile_file,
    shipped_profiles,
)
from uros_build.workspace import (
    CONFIG,
    LOCK,
    PENDING,
    Lock,
    Workspace,
    WorkspaceConfig,
    check_build_folder,
    check_extra_package,
    check_folder_target,
    find_workspace,
    load_config,
    parse_config,
    read_lock,
    target_key,
)

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


def resolve_output(output: Path | None, workspace: Path | None, toolchain: str | None) -> Path:
    """The build output a command reads (uros info, uros size): OUTPUT as given, else in the
    workspace: --toolchain's output, else uros.yaml's target's, else the only one built."""
    if output is not None:
        return output
    root = resolve_workspace(workspace)
    ws = Workspace(root.resolve())
    built = [k for k in target_keys(ws) if is_uros_output(ws.default_output(k))]
    if toolchain is None:
        cfg = load_config(ws.root) if ws.root.is_dir() else None
        named: tuple[str, ...] = ()
        if cfg is not None:
            named = cfg.targets or ((cfg.target,) if cfg.target else ())
        if len(named) == 1:
            toolchain = named[0]
        elif len(built) == 1:
            toolchain = built[0]
        else:
            raise ConfigError(
                f"which output? {len(built)} built in {ws.root}: {', '.join(built) or 'none'}",
                "pass the output folder (e.g. firmware/build/cortex-m7), or --toolchain NAME",
            )
    key = target_key(Path(toolchain).stem if toolchain.endswith(".cmake") else toolchain)
    if key not in built:
        raise ConfigError(
            f"--toolchain {toolchain}: no output of it in {ws.root}{did_you_mean(key, built)}",
            f"build it first: uros build --toolchain {toolchain}"
            + (f" (built: {', '.join(built)})" if built else ""),
        )
    return ws.default_output(key)


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
    if toolchain.endswith(".cmake") or "/" in toolchain:
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
        return ToolchainFileTarget(target_key(path.stem, f"{flag} {toolchain}"), path)
    profile = find_profile(toolchain, flag)
    if derive:
        profile = derive_profile(profile, compiler_prefix, cflags)
        return ProfileTarget(target_key(profile.name), profile)
    return ProfileTarget(target_key(profile.name), profile)


def target_profile(target: Target | None) -> TargetProfile | None:
    return target.profile if isinstance(target, ProfileTarget) else None


# ---------------------------------------------------------------------------------------------
# colcon.meta


def meta_for(
    preset: str,
    target: Target | None,
    transport: str | None,
    user_metas: list[Path],
    sets: list[str],
    distro_preset: str | None = None,
) -> meta_mod.Meta:
    return meta_mod.build_meta(
        meta_mod.load_preset(preset, distro_preset),
        meta_mod.target_fragments(target_profile(target), transport),
        [meta_mod.load_meta_file(p) for p in user_metas],
        sets,
    )


def meta_transport(meta: meta_mod.Meta) -> str | None:
    """The XRCE-DDS transport the merged meta selects (recorded in build-info.json)."""
    args = meta.names.get("rmw_microxrcedds", {}).get("cmake-args", ())
    for arg in args if isinstance(args, tuple) else ():
        if arg.startswith("-DRMW_UXRCE_TRANSPORT="):
            return arg.split("=", 1)[1]
    return None


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
class Selection:
    """The packages `uros build` asks colcon for (--packages-up-to), and why each."""

    wanted: tuple[str, ...]  # --packages / uros.yaml packages:
    firmware: firmware_scan.FirmwareUse | None  # --for-firmware's findings
    core: tuple[str, ...]  # the core packages the workspace has
    extra: tuple[str, ...]  # the workspace's extra packages

    @property
    def request(self) -> tuple[str, ...]:
        found = tuple(self.firmware.packages) if self.firmware else ()
        return tuple(sorted({*self.wanted, *found, *self.core, *self.extra}))


@dataclass(frozen=True)
class BuildPlan:
    workspace: Workspace
    config: WorkspaceConfig | None  # None: a plain colcon workspace, not made by create-firmware
    distro: Distro | None
    target: Target
    meta: meta_mod.Meta
    output: Path
    target_dir: Path  # .uros/targets/<key>
    packages_up_to: tuple[str, ...]  # colcon's --packages-up-to as the user gave it (and only that)
    jobs: int | None
    verbose: bool
    packages: tuple[PackageInfo, ...] = ()  # every package colcon will find in the workspace
    warnings: tuple[str, ...] = ()  # inputs that are valid but likely not what the user meant
    idf: IdfProject | None = None  # the ESP-IDF project micro-ROS is compiled against
    rebuild: bool = False
    selection: Selection | None = None  # --packages/--for-firmware/uros.yaml packages: (None: all)
    force: bool = False  # --force: the output may be another target's, or hold the user's files
    output_flag: str = "--output"  # how messages name the output ("the output folder" by default)
    cache: CacheSettings | None = None  # the team cache of outputs (None: none)
    ccache: bool | None = None  # True: ccache required; None: when installed; False: never

    @property
    def profile(self) -> TargetProfile | None:
        return target_profile(self.target)

    @property
    def requested(self) -> tuple[str, ...]:
        """The packages whose closure the build is for: the selection's (--packages, --for-firmware,
        uros.yaml's packages:), else --packages-up-to's; () for every package."""
        return self.selection.request if self.selection else self.packages_up_to


def _closest(name: str, names: set[str]) -> str:
    near = packages_mod.closest(name, names)
    return f" (closest: {', '.join(near)})" if near else ""


def unknown_packages(metas: list[meta_mod.Meta], sets: tuple[str, ...], names: set[str]) -> list[str]:
    """Warnings for --meta and --set entries that name no package of the workspace: colcon
    ignores them without a word, so a typo would silently build with the default (pure)."""
    out = []
    for meta in metas:
        for pkg in meta.names:
            if pkg not in names:
                near = _closest(pkg, names)
                out.append(f"--meta {meta.source}: names.{pkg}: no package {pkg} in the workspace{near}")
    for item in sets:
        pkg = meta_mod.split_set(item).package
        if pkg not in names:
            out.append(f"--set {item}: no package {pkg} in the workspace{_closest(pkg, names)}")
    return out


def idf_project(
    args: BuildArgs, ws: Workspace, cfg: WorkspaceConfig | None, target: Target
) -> IdfProject | None:
    """The ESP-IDF build folder of --idf-build, else uros.yaml's idf_build for an ESP-IDF target
    (a workspace may name several targets; the IDF project is for its ESP-IDF one), read and
    checked against the target."""
    profile = target_profile(target)
    folder, flag = args.idf_build, "--idf-build"
    if folder is None and cfg is not None and cfg.idf_build and profile is not None and profile.idf_target:
        folder, flag = ws.root / cfg.idf_build, f"{ws.root / CONFIG}: idf_build"
    if folder is None:
        return None
    if profile is None:
        raise ConfigError(
            f"--idf-build with your own toolchain file {target.key}: uros knows no ESP-IDF target for it",
            "build for a target (uros build --toolchain esp32s3 --idf-build DIR) or a profile (--profile)",
        )
    return espidf.read_idf_build(folder, profile.idf_target, profile.name, flag)


# ESP-IDF's newlib defines the 64-bit __atomic_*_8 routines from 5.3 on (components/newlib/stdatomic.c:
# ATOMIC_FUNCTIONS(8, ...)); 5.2 and earlier define none, so rcutils must bring its own there.
IDF_DEFINES_ATOMICS_8 = (5, 3)


def idf_platform(target: Target, idf: IdfProject | None) -> Target:
    """The target as the IDF project's version makes it: C17 from ESP-IDF 5 on, C11 before; and
    before 5.3 the platform does not define __atomic_*_8, so rcutils' own are built (and allowed by
    the ABI check)."""
    if idf is None or not isinstance(target, ProfileTarget):
        return target
    profile = replace(target.profile, c_standard=idf.c_standard)
    if idf.version < IDF_DEFINES_ATOMICS_8:
        profile = replace(profile, native_64bit_atomics=False)
    return ProfileTarget(target.key, profile)


def _select(
    args: BuildArgs, cfg: WorkspaceConfig | None, ws: Workspace, packages: list[PackageInfo], names: set[str]
) -> Selection | None:
    """What --packages, --for-firmware or uros.yaml's packages: ask for, plus the core and the
    extra packages; None when none of them is given (every package is built)."""
    wanted = args.packages or (cfg.packages if cfg and args.for_firmware is None else ())
    use = None
    if args.for_firmware is not None:
        folder = args.for_firmware
        if not folder.is_dir():
            raise ConfigError(
                f"--for-firmware {folder}: no such folder", "pass your firmware's source folder"
            )
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
    flag = "--packages" if args.packages else f"{ws.root / CONFIG}: packages"
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


def plan_build(args: BuildArgs) -> BuildPlan:
    """Validate every input of `uros build` (reads files, starts nothing)."""
    ws = open_workspace(args.workspace)
    cfg = load_config(ws.root)
    toolchain = args.toolchain
    if (
        toolchain
        and args.toolchain_from != "--toolchain"
        and (toolchain.endswith(".cmake") or "/" in toolchain)
    ):
        toolchain = str(ws.root / toolchain)  # a toolchain file named in uros.yaml: from the workspace
    target = resolve_target(toolchain, args.profile, args.compiler_prefix, args.cflags, args.toolchain_from)
    distro = distros_mod.load_distro(cfg.distro, f"{ws.root / CONFIG}: distro") if cfg else None
    user_metas = list(args.metas)
    if cfg is not None and ws.user_meta.is_file():
        user_metas.insert(0, ws.user_meta)
    # uros.yaml's transport and set, under the command line's (a later --set of an option wins)
    transport = args.transport or (cfg.transport if cfg else None)
    sets = (*(cfg.set if cfg else ()), *args.sets)
    idf = idf_project(args, ws, cfg, target)
    target = idf_platform(target, idf)
    meta = meta_for(args.preset, target, transport, user_metas, list(sets), distro.preset if distro else None)
    if args.jobs is not None and args.jobs < 1:
        raise ConfigError(f"-j/--jobs {args.jobs}: must be 1 or more", "omit it to let colcon choose")
    packages = packages_mod.discover(ws.source_dir)
    names = {p.name for p in packages}
    named = {*args.packages_up_to, *(meta_mod.split_set(s).package for s in sets)}
    given_metas = [meta_mod.load_meta_file(p) for p in args.metas]
    named |= {pkg for m in given_metas for pkg in m.names}
    if named - names:  # colcon also builds CMake packages that have no package.xml
        names |= packages_mod.plain_cmake_packages(ws.source_dir)
    for pkg in args.packages_up_to:
        if pkg not in names:
            raise ConfigError(
                f"--packages-up-to {pkg}: no package {pkg} in {ws.source_dir}{_closest(pkg, names)}",
                "name a package of the workspace (a folder with a package.xml or a CMakeLists.txt)",
            )
    warnings = unknown_packages(given_metas, sets, names)
    warnings += options_mod.check_sets(sets, options_mod.by_package(options_mod.known_options()))
    selection = _select(args, cfg, ws, packages, names)
    out = (args.output or ws.default_output(target.key)).resolve()
    flag = "--output" if args.output else "the output folder"
    check_folder_target(out, flag)
    check_output_dir(out, args.force, flag, ws.root)
    check_output_owner(out, target.key, args.force, flag)
    return BuildPlan(
        workspace=ws,
        config=cfg,
        distro=distro,
        target=target,
        meta=meta,
        output=out,
        target_dir=ws.target_dir(target.key),
        packages_up_to=args.packages_up_to,
        jobs=args.jobs,
        verbose=args.verbose,
        packages=tuple(packages),
        warnings=tuple(warnings),
        idf=idf,
        rebuild=args.rebuild,
        selection=selection,
        force=args.force,
        output_flag=flag,
        cache=_cache_settings(args, cfg, ws.root / CONFIG),
        ccache=args.ccache,
    )


def _cache_settings(args: BuildArgs, cfg: WorkspaceConfig | None, config_path: Path) -> CacheSettings | None:
    """--cache, else uros.yaml's cache: (the command line wins); --cache-upload needs one of them."""
    if args.cache is not None:
        text, where = args.cache, "--cache"
    elif cfg is not None and cfg.cache is not None:
        text, where = cfg.cache, f"{config_path}: cache"
    elif args.cache_upload:
        raise ConfigError(
            "--cache-upload without a cache", f"add --cache URL or a cache: line to {config_path}"
        )
    else:
        return None
    if text in ("", "none"):  # --cache none: this build without the workspace's cache
        if args.cache_upload:
            raise ConfigError("--cache-upload with --cache none", "give the cache's URL to upload to")
        return None
    return CacheSettings(cache_mod.parse_url(text, where), upload=args.cache_upload)


# ---------------------------------------------------------------------------------------------
# uros create-firmware


@dataclass(frozen=True)
class CreateArgs:
    directory: Path | None = None  # None: resolve_workspace's default
    distro: str = defaults.DISTRO
    platform: str = defaults.PLATFORM
    mirrors: tuple[str, ...] = ()
    overrides: tuple[str, ...] = ()
    config: Path | None = None
    locked: bool = False
    lock_file: Path | None = None
    extra_packages: tuple[Path, ...] = ()
    force: bool = False
    keep_partial: bool = False
    build_dev: bool = True
    toolchain: str | None = None  # a target whose prerequisites are checked first
    jobs: int = defaults.CLONE_JOBS
    verbose: bool = False


@dataclass(frozen=True)
class CreatePlan:
    root: Path
    existed: bool  # the folder was there (empty, or a workspace re-created with --force)
    existing: WorkspaceConfig | None
    previous: Lock | None  # the lock of the workspace re-created with --force: what uros cloned
    distro: Distro
    mirror: Mirror
    sources: Mapping[str, Source]  # workspace path (dev_ws/..., mcu_ws/...) -> what to clone
    extra_packages: tuple[tuple[Path, str], ...]  # (folder, package name)
    probe: TargetProfile | None  # check this target's compiler and C library before cloning
    args: CreateArgs


def plan_sources(distro: Distro, mirror: Mirror, locked: Mapping[str, str] | None) -> dict[str, Source]:
    """Workspace path (dev_ws/..., mcu_ws/...) -> what to clone (pure)."""
    sources = {}
    for ws, repos in (("dev_ws", distro.dev), ("mcu_ws", distro.mcu)):
        for repo in repos:
            sources[f"{ws}/{repo.path}"] = distros_mod.resolve(repo, mirror, locked, prefix=f"{ws}/")
    return sources


def _mirror_from(args: CreateArgs, existing: WorkspaceConfig | None) -> Mirror:
    parts: list[Mirror] = []
    if existing is not None:
        parts.append(existing.mirror)
    if args.config is not None:
        given = parse_config(
            loader.load_yaml(args.config, "--config"), f"--config {args.config}", partial=True
        )
        parts.append(given.mirror)
    parts.append(
        Mirror(
            tuple(distros_mod.parse_rule(s) for s in args.mirrors),
            tuple(distros_mod.parse_override(s) for s in args.overrides),
        )
    )
    return distros_mod.combine(*parts)


def _check_sources(sources: Mapping[str, Source], where: str = "--mirror") -> None:
    for path, source in sources.items():
        if distros_mod.is_local(source.url) and not distros_mod.local_path(source.url).exists():
            raise ConfigError(
                f"{where}: {source.url} (for {path}, upstream {source.repo.url}) does not exist",
                "fix the mirror rule, or point this repository elsewhere: "
                + (
                    f"--mirror-override {source.repo.path}=URL"
                    if where == "--mirror"
                    else f"an override '{source.repo.path}=URL' in that file's mirror: section"
                ),
            )


def _existing(root: Path, force: bool) -> tuple[bool, WorkspaceConfig | None, Lock | None]:
    """(existed, its config, its lock). An existing, non-empty folder needs --force, and --force
    needs a workspace uros made: only what its uros.lock lists is ever replaced."""
    if not root.exists():
        return False, None, None
    if not root.is_dir():
        raise ConfigError(f"--workspace {root}: is a file", "pass a new or empty folder")
    if not any(p.name != ".uros" for p in root.iterdir()) and not (root / PENDING).is_file():
        return True, None, None  # empty, or only uros's own .uros/ (logs of a run that cloned nothing)
    if not force and (root / PENDING).is_file() and not (root / CONFIG).is_file():
        raise ConfigError(
            f"--workspace {root}: a create-firmware that was stopped before it finished left this folder",
            "pass --force to finish it (only the clones it was making are made again)",
        )
    if not force:
        raise ConfigError(
            f"--workspace {root}: already exists",
            "use another --workspace, or pass --force to re-clone the repositories its uros.lock "
            "lists (everything else is kept: colcon.meta, uros.yaml, your packages)",
        )
    cfg = load_config(root)
    lock = read_lock(root / LOCK, "--workspace") if (root / LOCK).is_file() else None
    if cfg is None and lock is None and (root / PENDING).is_file():
        # a create-firmware killed before it wrote uros.yaml and uros.lock: the record it wrote
        # first names the clones it was making, all of them uros's
        pending = read_lock(root / PENDING, "--workspace")
        return True, None, pending
    if cfg is None and lock is None:
        raise ConfigError(
            f"--workspace {root}: not a workspace made by uros create-firmware (no {CONFIG}, no {LOCK})",
            "--force re-creates only uros's own clones: use a new or empty folder",
        )
    return True, cfg, lock


def _check_destinations(root: Path, sources: Mapping[str, Source], previous: Lock | None) -> None:
    """Every folder about to be cloned into is free, or a clone the previous lock lists."""
    ours = set(previous.repositories) if previous else set()
    for path in sorted(sources):
        if (root / path).exists() and path not in ours:
            raise ConfigError(
                f"--workspace {root}: {path} exists and is not in {LOCK}, so uros did not clone it",
                "move it away (uros never replaces what it did not write), or use a new folder",
            )


# ---------------------------------------------------------------------------------------------
# uros update


@dataclass(frozen=True)
class UpdateArgs:
    directory: Path | None = None
    distro: str | None = None  # None: the workspace's own (uros.yaml)
    before: str | None = None  # YYYY-MM-DD: the newest commits before this day, not the newest
    dry_run: bool = False
    jobs: int = defaults.CLONE_JOBS
    verbose: bool = False


@dataclass(frozen=True)
class UpdatePlan:
    root: Path
    config: WorkspaceConfig
    lock: Lock  # what the workspace holds now
    distro: Distro  # the distro to move to (the workspace's own, or --distro)
    sources: Mapping[str, Source]  # workspace path -> the branch to move to (uros.yaml's mirror rules)
    kept: tuple[str, ...]  # clones in the lock and in the distro: fetched and moved
    added: tuple[str, ...]  # in the distro, not in the lock: cloned
    removed: tuple[str, ...]  # in the lock, not in the distro: removed (uros cloned them)
    args: UpdateArgs


def check_day(text: str, flag: str) -> str:
    """A calendar day as YYYY-MM-DD (git reads many date forms; uros takes one, so a lock says
    plainly what it was moved to)."""
    try:
        if len(text) != 10:
            raise ValueError(text)
        day = datetime.date.fromisoformat(text)
    except ValueError:
        raise ConfigError(f"{flag} {text!r}: not a day", "write it as YYYY-MM-DD, e.g. 2024-06-30") from None
    # git's date parser silently matches nothing from 2100 on (`git rev-list --before=2100-01-01`)
    if not 1970 <= day.year <= 2099:
        raise ConfigError(f"{flag} {text}: outside the years git reads (1970-2099)", "pick a day in them")
    return text


def plan_update(args: UpdateArgs) -> UpdatePlan:
    """Every input of `uros update` checked before git runs: a firmware workspace with its lock, a
    known distro, mirrors that exist, and new clones' folders free."""
    if args.jobs < 1:
        raise ConfigError(f"--git-jobs {args.jobs}: must be 1 or more")
    if args.before is not None:
        check_day(args.before, "--before")
    ws, cfg = Workspace.open_firmware(resolve_workspace(args.directory))
    if not ws.lock_path.is_file():
        raise ConfigError(
            f"--workspace {ws.root}: no {LOCK}, so uros does not know which clones it made",
            "re-create the workspace with `uros create-firmware --force`",
        )
    lock = read_lock(ws.lock_path, "--workspace")
    distro = distros_mod.load_distro(args.distro if args.distro is not None else cfg.distro)
    sources = plan_sources(distro, cfg.mirror, None)
    _check_sources(sources, f"{ws.root / CONFIG}: mirror")
    kept = tuple(sorted(set(sources) & set(lock.repositories)))
    added = tuple(sorted(set(sources) - set(lock.repositories)))
    removed = tuple(sorted(set(lock.repositories) - set(sources)))
    for path in added:
        if (ws.root / path).exists():
            raise ConfigError(
                f"--workspace {ws.root}: {path} exists and is not in {LOCK}, so uros did not clone it",
                "move it away (uros never replaces what it did not write), then run `uros update` again",
            )
    return UpdatePlan(ws.root, cfg, lock, distro, sources, kept, added, removed, args)


def _check_lock_covers(lock: Lock, distro: Distro, where: str) -> None:
    """A lock pins every repository of this distro, or it would be silently ignored for the ones
    it lacks (they would be cloned at their branches' newest commits, from the network)."""
    if lock.distro and lock.distro != distro.name:
        raise ConfigError(
            f"{where}: locks micro-ROS {lock.distro}, not {distro.name}",
            f"pass --distro {lock.distro}, or a lock written for {distro.name}",
        )
    wanted = {
        f"{ws}/{r.path}" for ws, repos in (("dev_ws", distro.dev), ("mcu_ws", distro.mcu)) for r in repos
    }
    missing = sorted(wanted - set(lock.repositories))
    if missing:
        raise ConfigError(
            f"{where}: has no commit for {len(missing)} of the {len(wanted)} repositories of {distro.name} "
            f"({', '.join(missing[:3])}{', ...' if len(missing) > 3 else ''})",
            "pass the uros.lock that `uros create-firmware` wrote for this distro",
        )


def plan_create(args: CreateArgs) -> CreatePlan:
    if args.platform != defaults.PLATFORM:
        raise ConfigError(
            f"create-firmware: unknown platform {args.platform!r}", "uros supports `generate_lib` (any MCU)"
        )
    if args.jobs < 1:
        raise ConfigError(f"--git-jobs {args.jobs}: must be 1 or more")
    distro = distros_mod.load_distro(args.distro)
    root = resolve_workspace(args.directory).resolve()
    check_build_folder(root, "--workspace")
    extras = tuple((p, check_extra_package(p, "--extra-package")) for p in args.extra_packages)
    locked: dict[str, str] | None = None
    if args.locked or args.lock_file:
        lock_path = args.lock_file or root / "uros.lock"
        lock_flag = "--lock-file" if args.lock_file else "--locked"
        lock = read_lock(lock_path, lock_flag)
        _check_lock_covers(lock, distro, f"{lock_flag} {lock_path}")
        locked = lock.commits()
    existed, existing, previous = _existing(root, args.force)
    mirror = _mirror_from(args, existing)
    sources = plan_sources(distro, mirror, locked)
    _check_sources(sources)
    _check_destinations(root, sources, previous)
    probe = find_profile(args.toolchain, alternative="") if args.toolchain is not None else None
    return CreatePlan(root, existed, existing, previous, distro, mirror, sources, extras, probe, args)
