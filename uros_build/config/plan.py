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
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from uros_build import console, defaults
from uros_build.config import settings as rows
from uros_build.config.settings import (
    BuildArgs,
    Chosen,
    Resolved,
    build_settings,
    open_workspace,
    resolve_one,
    resolve_workspace,
)
from uros_build.errors import ConfigError, did_you_mean
from uros_build.output import swap
from uros_build.output import team_cache as cache_mod
from uros_build.output.exports import refuse_package_folder
from uros_build.output.folders import check_output_dir, check_output_owner, is_uros_output, target_keys
from uros_build.output.team_cache import CacheSettings
from uros_build.sources import distros as distros_mod
from uros_build.sources import firmware_scan
from uros_build.sources import meta as meta_mod
from uros_build.sources import options as options_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.distros import Distro
from uros_build.sources.packages import PackageInfo
from uros_build.sources.workspace import Workspace, check_folder_target, target_key
from uros_build.sources.wsfiles import CONFIG, WorkspaceConfig, load_config
from uros_build.target import espidf
from uros_build.target.espidf import IdfProject
from uros_build.target.ipstack import IpStackHeaders, read_ip_stack
from uros_build.target.profiles import (
    TargetProfile,
    derive_profile,
    find_profile,
    load_profile_file,
    shipped_profiles,
)
from uros_build.target.rtos import RtosHeaders, read_freertos

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


def only_the_preset(path: Path, distro_preset: str | None) -> bool:
    """The workspace's colcon.meta is the distro's preset as create-firmware wrote it, unedited.
    It then adds nothing over that preset, and merged over another one (`--preset tiny`) it put
    the distro's values back (RMW_UXRCE_MAX_HISTORY=4 over tiny's 1): such a file is left out,
    an edited one is the user's and is merged over any preset."""
    preset = meta_mod.load_preset(defaults.PRESET, distro_preset)
    return meta_mod.load_meta_file(path).names == preset.names


def meta_option(meta: meta_mod.Meta, package: str, option: str) -> str | None:
    """The value the merged meta gives ``package``'s CMake option ``option`` (-D), or None."""
    args = meta.names.get(package, {}).get("cmake-args", ())
    found = None
    for arg in args if isinstance(args, tuple) else ():
        name, sep, value = arg.removeprefix("-D").partition("=")
        if arg.startswith("-D") and sep and name.partition(":")[0] == option:
            found = value  # the last one wins, as on CMake's command line
    return found


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
    workspace_packages: tuple[PackageInfo, ...] = ()  # every package colcon will find in the workspace
    warnings: tuple[str, ...] = ()  # inputs that are valid but likely not what the user meant
    idf: IdfProject | None = None  # the ESP-IDF project micro-ROS is compiled against
    rtos: RtosHeaders | None = None  # the RTOS micro-ROS is compiled against (--rtos)
    ip_stack: IpStackHeaders | None = None  # the IP stack the udp transport is compiled against
    rebuild: bool = False
    selection: Selection | None = None  # --packages/--for-firmware/uros.yaml packages: (None: all)
    force: bool = False  # --force: the output may be another target's, or hold the user's files
    output_flag: str = "--output"  # how messages name the output ("the output folder" by default)
    cache: CacheSettings | None = None  # the team cache of outputs (None: none)
    ccache: bool | None = None  # True: ccache required; None: when installed; False: never
    # every setting with who chose it (settings.py), printed by `uros build -v`
    settings: Resolved = field(default_factory=lambda: Resolved({}))
    # the environment's switches (settings.py: UROS_HOST_STAGE, UROS_COMPILER_SEED, UROS_GEN_CACHE,
    # UROS_GEN_CACHE_DIR), read once here: the steps read the plan, not the environment
    host_stage: bool = True  # the packages that compile nothing built once for the host
    compiler_seed: bool = True  # CMake's compiler facts found once per target
    gen_cache: bool = True  # generator runs and configure calls through the user's cache
    gen_cache_dir: Path = Path("~/.cache/uros/gen")  # that cache's folder

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


def idf_project(chosen: Chosen[Path | None], target: Target) -> IdfProject | None:
    """The ESP-IDF build folder settings.py chose (--idf-build, else uros.yaml's idf_build, which
    applies to an ESP-IDF target only: a workspace may name several targets), read and checked
    against the target."""
    profile = target_profile(target)
    folder, flag = chosen.value, chosen.source
    if folder is None or (flag != "--idf-build" and (profile is None or not profile.idf_target)):
        return None
    if profile is None:
        raise ConfigError(
            f"--idf-build with your own toolchain file {target.key}: uros knows no ESP-IDF target for it",
            "build for a target (uros build --toolchain esp32s3 --idf-build DIR) or a profile (--profile)",
        )
    return espidf.read_idf_build(folder, profile.idf_target, profile.name, flag)


def _named(
    settings: Resolved, main: rows.Setting[Any], folders: tuple[rows.Setting[Any], ...], example: str
) -> dict[str, str]:
    """How the user gave ``main`` (--rtos, --ip-stack) and its folder settings (setting name -> a
    flag or a uros.yaml key, for the one-line errors); a folder flag without ``main`` is refused,
    and a uros.yaml folder key without ``main``'s key too: either was ignored without a word (a
    kernel's folder built bare metal)."""
    if settings[main].value is None:
        for row in folders:
            source = settings.chosen[row.name].source
            if source == row.flag:
                raise ConfigError(
                    f"{row.flag} without {main.flag}",
                    f"add {main.flag} {example} (or {main.key}: {example} in {CONFIG})",
                )
            if source != rows.DEFAULT:
                raise ConfigError(
                    f"{source} without {main.key}: (the build would ignore it)",
                    f"add `{main.key}: {example}` to {CONFIG} (or pass {main.flag} {example}), "
                    f"or remove {row.key}:",
                )
    return {row.name: settings.chosen[row.name].source for row in (main, *folders)}


def rtos_headers(settings: Resolved, target: Target, idf: IdfProject | None) -> RtosHeaders | None:
    """The RTOS settings.py chose (--rtos, --rtos-dir, --rtos-config, --rtos-port, else uros.yaml's
    rtos keys), read and checked against the target's core (target/rtos.py)."""
    rtos = settings[rows.RTOS]
    where = _named(settings, rows.RTOS, (rows.RTOS_DIR, rows.RTOS_CONFIG, rows.RTOS_PORT), "freertos")
    if rtos.value is None:
        return None
    profile = target_profile(target)
    if profile is None:
        raise ConfigError(
            f"{rtos.source} {rtos.value} with your own toolchain file {target.key}: uros adds no flags to it",
            "build for a target (uros build --toolchain cortex-m7 --rtos freertos ...) or a profile "
            "(--profile), or put the RTOS's include folders in your toolchain file",
        )
    if idf is not None:
        raise ConfigError(
            f"{rtos.source} {rtos.value} with --idf-build: an ESP-IDF project brings its own FreeRTOS",
            "leave --rtos out: --idf-build already compiles micro-ROS against ESP-IDF's FreeRTOS headers",
        )
    return read_freertos(
        settings.value(rows.RTOS_DIR),
        settings.value(rows.RTOS_CONFIG),
        settings.value(rows.RTOS_PORT),
        profile,
        where,
    )


def ip_stack_headers(
    settings: Resolved,
    target: Target,
    idf: IdfProject | None,
    rtos: RtosHeaders | None,
    transport: str | None,
) -> IpStackHeaders | None:
    """The IP stack settings.py chose (--ip-stack, --ip-stack-dir, --ip-stack-config, else uros.yaml's
    ip_stack keys), read and checked against the transport and the RTOS (target/ipstack.py)."""
    stack = settings[rows.IP_STACK]
    where = _named(settings, rows.IP_STACK, (rows.IP_STACK_DIR, rows.IP_STACK_CONFIG), "lwip")
    if stack.value is None:
        return None
    if target_profile(target) is None:
        raise ConfigError(
            f"{stack.source} {stack.value} with your own toolchain file {target.key}: "
            "uros adds no flags to it",
            "build for a target (uros build --toolchain cortex-m7 --ip-stack lwip ...) or a profile "
            "(--profile), or put the stack's include folders and PLATFORM_NAME in your toolchain file",
        )
    if idf is not None:
        raise ConfigError(
            f"{stack.source} {stack.value} with --idf-build: an ESP-IDF project brings its own lwIP",
            "leave --ip-stack out: --idf-build already compiles the udp transport against ESP-IDF's lwIP",
        )
    return read_ip_stack(
        stack.value,
        settings.value(rows.IP_STACK_DIR),
        settings.value(rows.IP_STACK_CONFIG),
        rtos,
        transport,
        target.key,
        where,
    )


def check_udp_profile(meta: meta_mod.Meta, stack: IpStackHeaders | None) -> None:
    """--ip-stack with the client's UDP profile off: the transport the stack carries would not be
    compiled (rmw_microxrcedds' udp transport then has no uxr_init_udp_transport): said before
    anything runs."""
    value = meta_option(meta, "microxrcedds_client", "UCLIENT_PROFILE_UDP")
    if stack is None or value is None or value.upper() in _CMAKE_TRUE:
        return
    raise ConfigError(
        f"microxrcedds_client.UCLIENT_PROFILE_UDP={value} with --ip-stack {stack.name}: "
        "the XRCE-DDS client would compile no UDP transport for the stack to carry",
        "leave the option out (transport udp turns it on), or build without --ip-stack",
    )


def udp_without_stack(
    target: Target, idf: IdfProject | None, stack: IpStackHeaders | None, transport: str | None
) -> list[str]:
    """A warning for the udp transport on a profile's target that has no socket platform (no
    --ip-stack, no ESP-IDF, no xrce_platform in the profile): the client's udp_transport.h then
    has no platform ("field 'platform' has incomplete type")."""
    profile = target_profile(target)
    if transport != "udp" or stack is not None or idf is not None or profile is None:
        return []
    if profile.micro_ros.xrce_platform:
        return []
    return [
        f"transport udp on {target.key} without an IP stack: the XRCE-DDS client has no socket code "
        "for it; add --rtos freertos ... --ip-stack lwip --ip-stack-dir DIR --ip-stack-config DIR "
        "(docs/network.md)"
    ]


_CMAKE_TRUE = ("ON", "TRUE", "1", "YES", "Y")


def check_multithread(
    meta: meta_mod.Meta, target: Target, idf: IdfProject | None, rtos: RtosHeaders | None
) -> None:
    """UCLIENT_PROFILE_MULTITHREAD on a profile's bare-metal target: the XRCE-DDS client's
    multithread.c stops with `#error XRCE multithreading not supported for this platform` deep in
    the build (it knows FreeRTOS, Zephyr and POSIX mutexes only): said before anything runs."""
    value = meta_option(meta, "microxrcedds_client", "UCLIENT_PROFILE_MULTITHREAD")
    if value is None or value.upper() not in _CMAKE_TRUE:
        return
    if rtos is None and idf is None and isinstance(target, ProfileTarget):
        raise ConfigError(
            f"microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD={value} on {target.key} without an RTOS: "
            "the client's mutexes are an RTOS's",
            "add --rtos freertos --rtos-dir KERNEL --rtos-config DIR (docs/rtos.md), or leave the option out",
        )


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
        idf=idf,
        rtos=rtos,
        ip_stack=ip_stack,
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
