"""The ordered steps of each uros command. Builders are pure; the runner is the only process user."""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uros_build import __version__, abi, console, export, firmware, includes, toolsearch
from uros_build import colcon as colcon_mod
from uros_build import distros as distros_mod
from uros_build import meta as meta_mod
from uros_build import packages as packages_mod
from uros_build.archive import BinTools, merge_archives
from uros_build.errors import ConfigError, MissingToolError, StepFailed, UrosError
from uros_build.proc import Runner
from uros_build.profiles import (
    TargetProfile,
    derive_profile,
    find_profile,
    load_profile_file,
    shipped_profiles,
)
from uros_build.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    microros_flags,
    render_toolchain,
    tool_paths,
)
from uros_build.workspace import Workspace, locked, target_key, write_if_changed


@dataclass(frozen=True)
class Target:
    key: str
    profile: TargetProfile | None  # None: the user's own toolchain file, used unchanged
    toolchain_file: Path | None = None


def resolve_target(
    toolchain: str | None,
    profile_path: Path | None,
    compiler_prefix: str | None = None,
    cflags: tuple[str, ...] = (),
) -> Target:
    derive = compiler_prefix is not None or bool(cflags)
    if profile_path is not None:
        if toolchain is not None:
            raise ConfigError("--toolchain and --profile name a target twice", "pass only one of them")
        profile = load_profile_file(profile_path)
        if derive:
            profile = derive_profile(profile, compiler_prefix, cflags)
        return Target(target_key(profile.name), profile)
    if toolchain is None:
        if derive:
            profile = derive_profile(None, compiler_prefix, cflags)
            return Target(target_key(profile.name), profile)
        raise ConfigError("no target given", f"pass --toolchain with one of: {', '.join(shipped_profiles())}")
    if toolchain.endswith(".cmake") or "/" in toolchain:
        if derive:
            raise ConfigError(
                f"--compiler-prefix/--cflags cannot change your own toolchain file {toolchain}",
                "edit the file, or derive from a target name or a profile (--profile my-board.yaml)",
            )
        path = Path(toolchain).resolve()
        if not path.is_file():
            raise ConfigError(
                f"--toolchain {toolchain}: no such file", "pass a target name or an existing .cmake file"
            )
        return Target(target_key(path.stem), None, path)
    profile = find_profile(toolchain)
    if derive:
        profile = derive_profile(profile, compiler_prefix, cflags)
        return Target(target_key(profile.name), profile)
    return Target(profile.name, profile)


# ---------------------------------------------------------------------------------------------
# colcon.meta for a target


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
        meta_mod.target_fragments(target.profile if target else None, transport),
        [meta_mod.load_meta_file(p) for p in user_metas],
        sets,
    )


# ---------------------------------------------------------------------------------------------
# uros build


@dataclass(frozen=True)
class BuildOptions:
    workspace: Path
    toolchain: str | None
    profile: Path | None = None
    metas: tuple[Path, ...] = ()
    sets: tuple[str, ...] = ()
    preset: str = "default"
    transport: str | None = None
    output: Path | None = None
    verbose: bool = False
    force: bool = False
    packages_up_to: tuple[str, ...] = ()
    jobs: int | None = None
    compiler_prefix: str | None = None
    cflags: tuple[str, ...] = ()


@dataclass
class _Facts:
    gcc: str = ""
    gcc_version: str = ""
    tool_dir: str | None = None  # where the target's tools are when not on PATH (ESP-IDF install)
    cmake_version: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


def _first_version(lines: list[str]) -> str:
    for line in lines:
        for word in line.split():
            if word[:1].isdigit() and "." in word:
                return word
    return lines[0].strip() if lines else ""


def _major(version: str) -> int | None:
    head = version.split(".", 1)[0]
    return int(head) if head.isdigit() else None


def _colcon_program() -> str:
    beside = Path(colcon_mod.host_python()).parent / "colcon"
    return str(beside) if beside.is_file() else "colcon"


def check_output_dir(out: Path, force: bool) -> None:
    if out.exists() and any(out.iterdir()) and not (out / export.BUILD_INFO).is_file() and not force:
        raise ConfigError(
            f"--output {out}: the folder exists and is not a uros build output",
            "choose a new or empty folder, or pass --force to replace its contents",
        )


def _swap_into_place(staging: Path, out: Path) -> None:
    """Replace ``out`` by ``staging`` with renames only, so ``out`` is never half-written."""
    out.parent.mkdir(parents=True, exist_ok=True)
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    if out.exists():
        out.rename(old)
    staging.rename(out)
    if old.exists():
        shutil.rmtree(old)


def _size_totals(runner: Runner, size_tool: str, library: Path) -> dict[str, int]:
    lines = runner.run([size_tool, "-t", str(library)], step="measure libmicroros.a", quiet=True)
    for line in reversed(lines):
        parts = line.split()
        if "(TOTALS)" in line and len(parts) >= 3 and all(p.isdigit() for p in parts[:3]):
            return {"text": int(parts[0]), "data": int(parts[1]), "bss": int(parts[2])}
    return {}


def _built_packages(install: Path) -> list[str]:
    # colcon records every package it installed into a merged prefix here.
    marker = install / "share" / "colcon-core" / "packages"
    return sorted(p.name for p in marker.iterdir()) if marker.is_dir() else []


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _host_env(
    root: Path, cfg: firmware.FirmwareConfig | None, cmake_version: str, with_dev: bool = True
) -> tuple[dict[str, str], list[str]]:
    """The environment colcon runs in: sourced ROS 2 scrubbed, uros's Python first, and for a
    firmware workspace its dev_ws (as if sourced) and git redirects for build-time clones."""
    git_config = None
    if cfg is not None:
        distro = distros_mod.load_distro(cfg.distro)
        git_config = distros_mod.insteadof(distro.build_time_clones, cfg.mirror)
    env, scrubbed = colcon_mod.build_env(
        os.environ,
        python_bin_dir=str(Path(colcon_mod.host_python()).parent),
        cmake_major=_major(cmake_version),
        git_config=git_config,
    )
    if cfg is not None and with_dev:
        env = firmware.dev_env(env, firmware.dev_install(root))
    return env, scrubbed


def build_dev_workspace(root: Path, runner: Runner, verbose: bool, jobs: int | None = None) -> None:
    """Build dev_ws (ament and friends) for the host, once; every target reuses it."""
    cfg = firmware.load_config(root)
    if cfg is None:
        raise ConfigError(f"{root}: no {firmware.CONFIG}", "create the workspace with `uros create-firmware`")
    cmake = runner.which("cmake")
    cmake_version = _first_version(runner.run([cmake, "--version"], step="cmake --version", quiet=True))
    env, _ = _host_env(root, cfg, cmake_version, with_dev=False)
    console.step("building the host tools workspace (dev_ws)")
    plan = firmware.dev_build_plan(root, verbose, jobs)
    runner.run(
        colcon_mod.colcon_argv(plan, runner.which(_colcon_program())),
        step="colcon build (dev_ws)",
        cwd=root / "dev_ws",
        env=env,
    )
    (firmware.dev_install(root) / firmware.DEV_MARKER).write_text(
        (root / firmware.LOCK).read_text(encoding="utf-8") if (root / firmware.LOCK).is_file() else "",
        "utf-8",
    )


def create_firmware(opts: firmware.CreateOptions) -> Path:
    precheck = None
    if opts.toolchain is not None:
        profile = find_profile(opts.toolchain)

        def precheck(runner: Runner) -> None:
            tools = tool_paths(profile, locate_compiler(runner, profile))
            for tool in ("gcc", "g++", "ar"):
                runner.which(tools[tool], profile.install_hint or None)
            _check_target_prerequisites(runner, profile, tools, opts.directory.resolve() / ".uros" / "probe")

    return firmware.create_firmware(
        opts, lambda root, runner, verbose: build_dev_workspace(root, runner, verbose), precheck
    )


def _check_target_prerequisites(
    runner: Runner, profile: TargetProfile, tools: dict[str, str], tdir: Path
) -> None:
    """Real micro-ROS needs the target's C library and C++ headers (humble's rosidl_typesupport_c
    has .cpp sources): say which package is missing before a long build fails on it."""
    hint = profile.install_hint or None
    libc = runner.run(
        [tools["gcc"], *profile.cpu_flags, *profile.libc_flags, "-print-file-name=libc.a"],
        step="find libc",
        quiet=True,
    )
    if not libc or not Path(libc[-1].strip()).is_absolute():
        raise MissingToolError(f"{profile.tool('gcc')} has no C library (libc.a) for {profile.name}", hint)
    probe = tdir / "uros_cxx_probe.cpp"
    probe.parent.mkdir(parents=True, exist_ok=True)
    probe.write_text("#include <cstdint>\nstd::uint8_t uros_probe;\n", encoding="utf-8")
    try:
        runner.run(
            [tools["g++"], *profile.cpu_flags, *profile.libc_flags, "-fsyntax-only", str(probe)],
            step="find C++ headers",
            quiet=True,
        )
    except StepFailed:
        message = f"{profile.tool('g++')} has no C++ standard headers for {profile.name}"
        raise MissingToolError(message, hint) from None


def build(opts: BuildOptions) -> Path:
    ws = Workspace.open(opts.workspace)
    target = resolve_target(opts.toolchain, opts.profile, opts.compiler_prefix, opts.cflags)
    cfg = firmware.load_config(ws.root)
    distro_preset = distros_mod.load_distro(cfg.distro).preset if cfg else None
    user_metas = list(opts.metas)
    if cfg is not None and (ws.root / firmware.USER_META).is_file():
        user_metas.insert(0, ws.root / firmware.USER_META)
    # Validate every input before anything runs.
    meta = meta_for(opts.preset, target, opts.transport, user_metas, list(opts.sets), distro_preset)
    out = (opts.output or ws.default_output(target.key)).resolve()
    check_output_dir(out, opts.force)
    ws.mark_ignored()
    runner = Runner(ws.new_log("build", target.key), verbose=opts.verbose)
    console.step(f"uros build: target {target.key}, workspace {ws.root}")
    console.info(f"log: {runner.log_path}")

    facts = _Facts()
    cmake = runner.which("cmake")
    facts.cmake_version = _first_version(runner.run([cmake, "--version"], step="cmake --version", quiet=True))
    colcon_prog = runner.which(_colcon_program())
    profile = target.profile
    tdir = ws.target_dir(target.key)
    if profile is not None:
        facts.tool_dir = locate_compiler(runner, profile)
        tools = tool_paths(profile, facts.tool_dir)
        facts.gcc = runner.which(tools["gcc"], profile.install_hint or None)
        for tool in ("g++", "ar", "ranlib", "nm", "size"):
            runner.which(tools[tool], profile.install_hint or None)
        version = runner.run([facts.gcc, "-dumpversion"], step="gcc -dumpversion", quiet=True)
        facts.gcc_version = version[0].strip()
        if cfg is not None:
            _check_target_prerequisites(runner, profile, tools, tdir)

    if cfg is not None:
        firmware.sync_extra_packages(ws.root, cfg)
        if not (firmware.dev_install(ws.root) / firmware.DEV_MARKER).is_file():
            build_dev_workspace(ws.root, runner, opts.verbose, opts.jobs)

    with locked(tdir):
        started = time.monotonic()
        toolchain_file = _prepare_toolchain(tdir, target, facts)
        meta_path = tdir / "colcon.meta"
        write_if_changed(meta_path, meta_mod.dump_meta(meta, f"uros build --toolchain {target.key}"))
        env, scrubbed = _host_env(ws.root, cfg, facts.cmake_version)
        if scrubbed:
            console.warn(f"ignoring the sourced environment for this build: {', '.join(scrubbed)}")
        skipped = packages_mod.host_only(packages_mod.discover(ws.source_dir))
        if skipped:
            console.info(f"not building {len(skipped)} pure-Python packages: {', '.join(skipped)}")
        plan = colcon_mod.ColconPlan(
            base_paths=(ws.source_dir,),
            packages_ignore=tuple(skipped),
            build_base=tdir / "build",
            install_base=tdir / "install",
            log_base=tdir / "log",
            metas=(meta_path,),
            toolchain_file=toolchain_file,
            python=colcon_mod.host_python(),
            generator="Ninja" if shutil.which("ninja", path=env["PATH"]) else None,
            verbose=opts.verbose,
            packages_up_to=opts.packages_up_to,
            parallel_workers=opts.jobs,
        )
        console.step("colcon build")
        runner.run(
            colcon_mod.colcon_argv(plan, colcon_prog),
            step="colcon build",
            cwd=ws.root,
            env=env,
            hint=f"the first error is above; the full output is in {runner.log_path}",
        )
        staging = out.with_name(f".{out.name}.staging-{os.getpid()}")
        try:
            info = _stage_output(runner, target, tdir, staging, facts, meta)
            info["skipped_python_packages"] = skipped
            (staging / export.BUILD_INFO).write_text(export.dump_json(info), encoding="utf-8")
            _swap_into_place(staging, out)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
    lib = out / "libmicroros.a"
    console.step(
        f"built {lib} ({lib.stat().st_size:,} bytes, {info['library']['members']} objects) "
        f"and {info['include']['files']} headers in {out / 'include'} ({time.monotonic() - started:.1f} s)"
    )
    return out


def locate_compiler(runner: Runner, profile: TargetProfile) -> str | None:
    """None when <prefix>gcc is on PATH, else the profile's compiler_search folder holding it."""
    gcc = profile.tool("gcc")
    try:
        runner.which(gcc, profile.install_hint or None)
        return None
    except MissingToolError:
        if not profile.compiler_search:
            raise
    found = toolsearch.search_compiler(profile, os.environ, Path.home())
    if found is None:
        places = toolsearch.searched_places(profile, os.environ, Path.home())
        raise MissingToolError(
            f"'{gcc}' was found neither on PATH nor in {' or '.join(places)}", profile.install_hint or None
        )
    console.info(f"using {found / gcc} (not on PATH)")
    return str(found)


def _prepare_toolchain(tdir: Path, target: Target, facts: _Facts) -> Path:
    if target.profile is None:
        assert target.toolchain_file is not None
        return target.toolchain_file
    header = tdir / CLOCK_HEADER_NAME
    if target.profile.micro_ros.declare_clock_gettime:
        write_if_changed(header, CLOCK_HEADER_TEXT)
    req = ToolchainRequest(
        target.profile,
        micro_ros=True,
        gcc_major=_major(facts.gcc_version),
        clock_header=str(header) if target.profile.micro_ros.declare_clock_gettime else None,
        tool_dir=facts.tool_dir,
        command=f"uros build --toolchain {target.profile.name}",
    )
    path = tdir / "toolchain.cmake"
    if write_if_changed(path, render_toolchain(req)):
        _forget_configured_flags(tdir / "build")
    return path


def _forget_configured_flags(build_base: Path) -> None:
    """A changed toolchain file must reach the compiles: CMake reads CMAKE_<LANG>_FLAGS_INIT only
    when it creates the CMAKE_<LANG>_FLAGS cache entry, on the first configure
    (https://cmake.org/cmake/help/latest/variable/CMAKE_LANG_FLAGS_INIT.html), so a reconfigure
    would keep compiling with the old flags. Dropping each package's CMakeCache.txt makes colcon
    configure afresh in the same folder; ninja then recompiles what the new flags change."""
    for cache in sorted(build_base.glob("*/CMakeCache.txt")):
        cache.unlink()


def _bintools_for(target: Target, tdir: Path, tool_dir: str | None) -> BinTools:
    if target.profile is not None:
        tools = tool_paths(target.profile, tool_dir)
        return BinTools(ar=tools["ar"], ranlib=tools["ranlib"], nm=tools["nm"])
    # A user toolchain file: use the archiver CMake recorded for it (the target's); the host
    # binutils read foreign ELF archives too, as a fallback.
    return _bintools_from_build(tdir) or BinTools(ar="ar", ranlib="ranlib", nm="nm")


def _stage_output(
    runner: Runner, target: Target, tdir: Path, staging: Path, facts: _Facts, meta: meta_mod.Meta
) -> dict[str, Any]:
    install = tdir / "install"
    libs = sorted((install / "lib").glob("*.a"))
    if not libs:
        raise StepFailed(
            f"colcon built no static library into {install / 'lib'}",
            "check that the packages install their libraries: install(TARGETS ... ARCHIVE DESTINATION lib)",
        )
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir(parents=True)
    tools = _bintools_for(target, tdir, facts.tool_dir)
    console.step(f"merging {len(libs)} libraries into libmicroros.a")
    library = staging / "libmicroros.a"
    report = merge_archives(runner, tools, libs, library, tdir / "merge")
    profile = target.profile
    # Before the output is swapped in: a library that fails the check never replaces a good one.
    abi_check = _check_abi(runner, library, profile)
    inc = includes.flatten_includes(install / "include", staging / "include")
    info: dict[str, Any] = {
        "generated_by": f"uros {__version__}",
        "target": target.key,
        "profile": Path(profile.source).name if profile else None,
        "toolchain_file": str(target.toolchain_file) if target.toolchain_file else None,
        "compiler": {"path": facts.gcc, "version": facts.gcc_version} if profile else None,
        "cmake_version": facts.cmake_version,
        "flags": {
            "cpu": list(profile.cpu_flags) if profile else [],
            "c": list(profile.c_flags) if profile else [],
            "cxx": list(profile.cxx_flags) if profile else [],
            "optimization": profile.optimization if profile else None,
            "micro_ros_only": list(_microros_flags(profile, facts)) if profile else [],
        },
        "transport": meta_transport(meta),
        "packages": _built_packages(install),
        "library": {
            "file": "libmicroros.a",
            "bytes": library.stat().st_size,
            "sha256": _sha256(library),
            "members": report.members,
            "defined_global_symbols": report.symbols,
            "renamed_duplicate_members": report.renamed_duplicates,
            "inputs": list(report.inputs),
        },
        "include": {"dir": "include", "files": inc.files, "bytes": inc.bytes, "packages": inc.packages},
        "abi_check": abi_check,
    }
    if profile is not None and profile.idf_target:
        info["idf_target"] = profile.idf_target
    if profile is not None:
        size_tool = tool_paths(profile, facts.tool_dir)["size"]
        info["library"]["size"] = _size_totals(runner, size_tool, library)
        firmware_tc = render_toolchain(
            ToolchainRequest(profile, micro_ros=False, command=f"uros toolchain render {profile.name}")
        )
        (staging / "toolchain.cmake").write_text(firmware_tc, encoding="utf-8")
    export.write_cmake_package(staging, info)
    return info


def _check_abi(runner: Runner, library: Path, profile: TargetProfile | None) -> dict[str, Any]:
    if profile is None:
        return {"checked": False, "reason": "your own toolchain file: no target profile to compare with"}
    console.step(f"checking every object against {profile.name}'s ELF facts")
    summary = abi.check_library(runner, library, profile)
    console.info(abi.describe(summary))
    return summary


def _bintools_from_build(tdir: Path) -> BinTools | None:
    for cache in sorted((tdir / "build").glob("*/CMakeCache.txt")):
        values: dict[str, str] = {}
        for line in cache.read_text(encoding="utf-8", errors="replace").splitlines():
            for key in ("CMAKE_AR", "CMAKE_RANLIB", "CMAKE_NM"):
                if line.startswith(f"{key}:"):
                    values[key] = line.split("=", 1)[1]
        if values.get("CMAKE_AR") and values.get("CMAKE_NM"):
            return BinTools(
                ar=values["CMAKE_AR"], ranlib=values.get("CMAKE_RANLIB") or "ranlib", nm=values["CMAKE_NM"]
            )
    return None


def _microros_flags(profile: TargetProfile, facts: _Facts) -> list[str]:
    req = ToolchainRequest(
        profile, micro_ros=True, gcc_major=_major(facts.gcc_version), clock_header=CLOCK_HEADER_NAME
    )
    return microros_flags(req)


def meta_transport(meta: meta_mod.Meta) -> str | None:
    """The XRCE-DDS transport the merged meta selects (recorded in build-info.json)."""
    args = meta.names.get("rmw_microxrcedds", {}).get("cmake-args", ())
    for arg in args if isinstance(args, tuple) else ():
        if arg.startswith("-DRMW_UXRCE_TRANSPORT="):
            return arg.split("=", 1)[1]
    return None


__all__ = ["BuildOptions", "Target", "UrosError", "build", "create_firmware", "meta_for", "resolve_target"]
