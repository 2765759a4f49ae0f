"""`uros build`: one target's libmicroros.a, include tree, CMake package and build-info.json.

plan (validate every input) → probe the host → sync extra packages, dev_ws once → render the
toolchain and colcon.meta → colcon → merge, check, stage → swap the output into place.
"""

from __future__ import annotations

import hashlib
import shutil
import time
from pathlib import Path
from typing import Any

from uros_build import __version__, abi, colcon, console, export, hosttools, includes, outputs
from uros_build import meta as meta_mod
from uros_build import packages as packages_mod
from uros_build.archive import BinTools, merge_archives
from uros_build.buildinfo import BUILD_INFO, BuildInfo, Compiler, Flags, IdfInfo, Include, Library
from uros_build.errors import DiskFull, StepFailed, interrupted
from uros_build.hosttools import HostFacts
from uros_build.plan import BuildArgs, BuildPlan, ProfileTarget, expand_targets, meta_transport, plan_build
from uros_build.proc import Runner, disk_full_line, disk_full_path, first_error, stop_leftovers
from uros_build.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    microros_flags,
    render_toolchain,
    tool_paths,
)
from uros_build.workspace import damaged_archives, damaged_configures, locked, write_if_changed


def build_all(args: BuildArgs) -> list[Path]:
    """`uros build`: the target the command line names, else each one the workspace's uros.yaml
    names (target: or targets:)."""
    requests = expand_targets(args)
    if len(requests) > 1:
        names = ", ".join(str(r.toolchain) for r in requests)
        console.step(f"building {len(requests)} targets ({names}) from {requests[0].toolchain_from}")
    return [build(request) for request in requests]


def build(args: BuildArgs) -> Path:
    plan = plan_build(args)
    ws = plan.workspace
    ws.mark_ignored()
    runner = Runner(ws.new_log("build", plan.target.key), verbose=plan.verbose, owner=str(plan.target_dir))
    console.step(f"uros build: target {plan.target.key}, workspace {ws.root}")
    console.info(f"log: {runner.log_path}")
    for warning in plan.warnings:
        console.warn(warning)
    if plan.idf is not None:
        idf = plan.idf
        console.info(
            f"ESP-IDF {idf.version_text} project {idf.build_dir} ({idf.target}): {idf.components} "
            f"components, {len(idf.include_dirs)} include folders, sdkconfig.h {idf.sdkconfig_sha256[:12]}"
        )
    facts = hosttools.probe_host(
        runner, plan.profile, plan.target_dir, check_libraries=plan.config is not None
    )
    if plan.config is not None:
        ws.sync_extra_packages(plan.config)
        if not ws.dev_built():
            hosttools.build_dev_workspace(ws, plan.config, runner, plan.verbose, plan.jobs)
    with locked(plan.target_dir, plan.target.key):
        _repair(plan)
        started = time.monotonic()
        toolchain_file = _prepare_toolchain(plan, facts)
        meta_path = plan.target_dir / "colcon.meta"
        write_if_changed(
            meta_path, meta_mod.dump_meta(plan.meta, f"uros build --toolchain {plan.target.key}")
        )
        skipped = _run_colcon(plan, facts, runner, toolchain_file, meta_path)
        staging = outputs.staging_dir(plan.output)
        try:
            info = _stage_output(runner, plan, facts, staging, skipped)
            (staging / BUILD_INFO).write_text(info.to_json(), encoding="utf-8")
            outputs.write_marker(staging, plan.target.key, [p.name for p in staging.iterdir()])
            left = outputs.install_output(staging, plan.output)
        except BaseException:
            outputs.remove_tree(staging)
            raise
    try:
        for why in left:  # the new output is in place: a warning, not a failure
            console.warn(f"could not remove the previous output {why}: remove it by hand")
        lib = plan.output / "libmicroros.a"
        console.step(
            f"built {lib} ({lib.stat().st_size:,} bytes, {info.library.members} objects) and "
            f"{info.include.files} headers in {plan.output / 'include'} ({time.monotonic() - started:.1f} s)"
        )
    except KeyboardInterrupt as stop:
        raise interrupted(
            stop, "interrupted", f"the new output was already in place: {plan.output}"
        ) from None
    return plan.output


def _repair(plan: BuildPlan) -> None:
    """Before the target's trees or output are touched (its lock held): stop what a killed build of
    it left running, finish or undo a swap it left half-way, and drop package build folders whose
    configure a full disk (or a crash) cut short."""
    stopped = stop_leftovers(str(plan.target_dir))
    if stopped:
        console.warn(
            f"stopped {len(stopped)} processes left running by an earlier uros build of {plan.target.key} "
            f"that was killed (pids {' '.join(map(str, stopped))})"
        )
    for line in outputs.recover(plan.output):
        console.info(line)
    trees = plan.target_dir
    for path, why in damaged_archives([trees / "install" / "lib", *sorted((trees / "build").glob("*/"))]):
        # ninja builds it again, colcon's install step copies it again
        console.warn(f"{path.name} {why} (a full disk or a crash?): removing {path}")
        outputs.remove_tree(path)
    for folder, why in damaged_configures(plan.target_dir / "build"):
        console.warn(f"{folder.name}: {why} (a full disk or a crash?): configuring it afresh in {folder}")
        outputs.remove_tree(folder)


def _run_colcon(
    plan: BuildPlan, facts: HostFacts, runner: Runner, toolchain_file: Path, meta_path: Path
) -> tuple[str, ...]:
    """colcon build into the target's own trees; returns the pure-Python packages left out."""
    ws = plan.workspace
    env, scrubbed = hosttools.colcon_env(ws, plan.config, facts.cmake_version)
    if scrubbed:
        console.warn(f"ignoring the sourced environment for this build: {', '.join(scrubbed)}")
    skipped = tuple(packages_mod.host_only(list(plan.packages)))
    if skipped:
        console.info(f"not building {len(skipped)} pure-Python packages: {', '.join(skipped)}")
    colcon_plan = colcon.ColconPlan(
        base_paths=(ws.source_dir,),
        packages_ignore=skipped,
        build_base=plan.target_dir / "build",
        install_base=plan.target_dir / "install",
        log_base=plan.target_dir / "log",
        metas=(meta_path,),
        toolchain_file=toolchain_file,
        python=colcon.host_python(),
        generator=colcon.generator(env),
        verbose=plan.verbose,
        packages_up_to=plan.packages_up_to,
        parallel_workers=plan.jobs,
    )
    console.step("colcon build")
    try:
        runner.run(
            colcon.colcon_argv(colcon_plan, facts.colcon),
            step="colcon build",
            cwd=ws.root,
            env=env,
            hint=f"the full output is in {runner.log_path}",
        )
    except StepFailed as exc:
        raise _colcon_failure(exc, colcon_plan.log_base, runner.log_path) from None
    return skipped


def _colcon_failure(exc: StepFailed, log_base: Path, run_log: Path) -> StepFailed | DiskFull:
    """Name the package that failed and its own first error, read from colcon's log of that
    package (the interleaved output of parallel packages can put another's line first)."""
    failed = colcon.failed_packages(exc.output)
    if not failed:
        return _disk_full(exc.output, log_base, "colcon build failed") or exc
    package = failed[0]
    log = colcon.package_log(log_base, package)
    lines = log.read_text(encoding="utf-8", errors="replace").splitlines() if log.is_file() else []
    full = _disk_full([*lines, *exc.output], log_base, f"colcon build failed in package {package}")
    if full is not None:
        return full
    cause = first_error(lines) or first_error(exc.output) or "no error line in its output"
    others = f" (also failed: {', '.join(failed[1:])})" if failed[1:] else ""
    where = f"its log: {log}; everything: {run_log}" if lines else f"the full output is in {run_log}"
    return StepFailed(f"colcon build failed in package {package}{others}: {cause}", where, exc.output)


# Below this, a failed build is taken for a full disk even when no tool said so (some, like CMake's
# file(WRITE) or an install step, report a short write in their own words).
_NEARLY_FULL = 1 << 20


def _disk_full(lines: list[str] | tuple[str, ...], where: Path, what: str) -> DiskFull | None:
    full = disk_full_line(lines)
    error = DiskFull.at((full and disk_full_path(full)) or where, f"{what}: {full}" if full else what)
    if full is not None or (error.free is not None and error.free < _NEARLY_FULL):
        return error
    return None


def _prepare_toolchain(plan: BuildPlan, facts: HostFacts) -> Path:
    target = plan.target
    if not isinstance(target, ProfileTarget):
        return target.toolchain_file
    profile = target.profile
    header = plan.target_dir / CLOCK_HEADER_NAME
    if profile.micro_ros.declare_clock_gettime:
        write_if_changed(header, CLOCK_HEADER_TEXT)
    req = ToolchainRequest(
        profile,
        micro_ros=True,
        gcc_major=facts.gcc_major,
        clock_header=str(header) if profile.micro_ros.declare_clock_gettime else None,
        tool_dir=facts.tool_dir,
        command=f"uros build --toolchain {profile.name}",
        prefix_map=str(plan.workspace.root),
        idf=plan.idf,
        transport=meta_transport(plan.meta),
    )
    path = plan.target_dir / "toolchain.cmake"
    if write_if_changed(path, render_toolchain(req)):
        _forget_configured_flags(plan.target_dir / "build")
    return path


def _forget_configured_flags(build_base: Path) -> None:
    """A changed toolchain file must reach the compiles: CMake reads CMAKE_<LANG>_FLAGS_INIT only
    when it creates the CMAKE_<LANG>_FLAGS cache entry, on the first configure
    (https://cmake.org/cmake/help/latest/variable/CMAKE_LANG_FLAGS_INIT.html), so a reconfigure
    would keep compiling with the old flags. Dropping each package's CMakeCache.txt makes colcon
    configure afresh in the same folder; ninja then recompiles what the new flags change."""
    for cache in sorted(build_base.glob("*/CMakeCache.txt")):
        cache.unlink()


def _bintools(plan: BuildPlan, facts: HostFacts) -> BinTools:
    if isinstance(plan.target, ProfileTarget):
        tools = tool_paths(plan.target.profile, facts.tool_dir)
        return BinTools(ar=tools["ar"], ranlib=tools["ranlib"], nm=tools["nm"])
    # A user toolchain file: use the archiver CMake recorded for it (the target's); the host
    # binutils read foreign ELF archives too, as a fallback.
    return hosttools.bintools_from_build(plan.target_dir / "build") or BinTools("ar", "ranlib", "nm")


def _built_packages(install: Path) -> tuple[str, ...]:
    # colcon records every package it installed into a merged prefix here.
    marker = install / "share" / "colcon-core" / "packages"
    return tuple(sorted(p.name for p in marker.iterdir())) if marker.is_dir() else ()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _stage_output(
    runner: Runner, plan: BuildPlan, facts: HostFacts, staging: Path, skipped: tuple[str, ...]
) -> BuildInfo:
    install = plan.target_dir / "install"
    libs = sorted((install / "lib").glob("*.a"))
    if not libs:
        raise StepFailed(
            f"colcon built no static library into {install / 'lib'}",
            "check that the packages install their libraries: install(TARGETS ... ARCHIVE DESTINATION lib)",
        )
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir(parents=True)
    console.step(f"merging {len(libs)} libraries into libmicroros.a")
    library = staging / "libmicroros.a"
    report = merge_archives(runner, _bintools(plan, facts), libs, library, plan.target_dir / "merge")
    profile = plan.profile
    # Before the output is swapped in: a library that fails the check never replaces a good one.
    abi_check: dict[str, Any]
    if profile is None:
        abi_check = {"checked": False, "reason": "your own toolchain file: no target profile to compare with"}
    else:
        console.step(f"checking every object against {profile.name}'s ELF facts")
        abi_check = abi.check_library(runner, library, profile)
        console.info(abi.describe(abi_check))
        for warning in abi_check.get("warnings", ()):
            console.warn(warning)
    inc = includes.flatten_includes(install / "include", staging / "include")
    size = None
    if profile is not None:
        size = hosttools.size_totals(runner, tool_paths(profile, facts.tool_dir)["size"], library)
        firmware_tc = render_toolchain(
            ToolchainRequest(profile, micro_ros=False, command=f"uros toolchain render {profile.name}")
        )
        (staging / "toolchain.cmake").write_text(firmware_tc, encoding="utf-8")
        # recorded without the workspace's folder, so that build-info.json does not depend on it
        mr_req = ToolchainRequest(
            profile,
            micro_ros=True,
            gcc_major=facts.gcc_major,
            clock_header=CLOCK_HEADER_NAME,
            prefix_map="<workspace>",
        )
    target = plan.target
    info = BuildInfo(
        generated_by=f"uros {__version__}",
        target=target.key,
        profile=Path(profile.source).name if profile else None,
        toolchain_file=None if isinstance(target, ProfileTarget) else str(target.toolchain_file),
        compiler=Compiler(facts.gcc, facts.gcc_version) if profile else None,
        cmake_version=facts.cmake_version,
        flags=Flags(
            cpu=profile.cpu_flags,
            c=profile.c_flags,
            cxx=profile.cxx_flags,
            optimization=profile.optimization,
            micro_ros_only=tuple(microros_flags(mr_req)),
        )
        if profile
        else Flags(),
        transport=meta_transport(plan.meta),
        packages=_built_packages(install),
        library=Library(
            file="libmicroros.a",
            bytes=library.stat().st_size,
            sha256=_sha256(library),
            members=report.members,
            defined_global_symbols=report.symbols,
            renamed_duplicate_members=report.renamed_duplicates,
            inputs=report.inputs,
            size=size,
        ),
        include=Include(dir="include", files=inc.files, bytes=inc.bytes, packages=inc.packages),
        abi_check=abi_check,
        skipped_python_packages=skipped,
        idf_target=profile.idf_target or None if profile else None,
        idf=_idf_info(plan),
    )
    export.write_cmake_package(staging, info)
    return info


def _idf_info(plan: BuildPlan) -> IdfInfo | None:
    idf = plan.idf
    if idf is None:
        return None
    return IdfInfo(
        version=idf.version_text,
        target=idf.target,
        sdkconfig_sha256=idf.sdkconfig_sha256,
        components=idf.components,
        include_dirs=len(idf.include_dirs),
        c_flags=idf.c_flags,
        cxx_flags=idf.cxx_flags,
    )
