"""The output delivered: this build's archives merged (or the previous library reused), checked
against the target's ELF facts, the include tree, the CMake package and build-info.json, assembled
beside its final place; then swapped in, and the state that vouches for it.
"""

from __future__ import annotations

import dataclasses
import errno
import shutil
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import __version__, console
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import installtree
from uros_build.config.buildplan import BuildPlan
from uros_build.config.colconmeta import meta_transport
from uros_build.config.targets import target_profile
from uros_build.defaults import BUILD_INFO
from uros_build.errors import (
    ConfigError,
    DiskFull,
    StepFailed,
    interrupted,
    written_path,
)
from uros_build.files import locked, remove_tree
from uros_build.output import contents, exports, fit, includes, msgsize, swap, symbols
from uros_build.output import folders as outputs
from uros_build.output.archive import MergeReport, merge_archives
from uros_build.output.buildinfo import (
    BuildInfo,
    Include,
    Library,
    read_build_info,
)
from uros_build.output.exports import cmake as cmake_export
from uros_build.output.exports.base import write_files
from uros_build.sources import clones
from uros_build.sources.options import known_options
from uros_build.sources.wsfiles import read_lock
from uros_build.steps.colcon_run import Compiled
from uros_build.steps.colcon_setup import ColconSetup
from uros_build.steps.context import Context
from uros_build.steps.inputs import Inputs
from uros_build.steps.renders import kept_render


@dataclass(frozen=True)
class Assembled:
    """An output ready to be swapped in: its folder beside the output, and its build-info."""

    folder: Path
    info: BuildInfo
    merge_key: str = ""  # what its library was merged from ("" for a team cache entry's)


def _put_in_place(plan: BuildPlan, assembled: Assembled) -> list[str]:
    """build-info.json and the marker into the assembled folder, then the swap: the assembled folder
    becomes the output (removed if anything fails first). Returns what of the previous output
    could not be removed."""
    staging = assembled.folder
    try:
        (staging / BUILD_INFO).write_text(assembled.info.to_json(), encoding="utf-8")
        exports.carry_over(plan.output, staging, assembled.info)  # `uros export KIND` beside the library
        outputs.write_marker(staging, plan.target.key, [p.name for p in staging.iterdir()])
        # Two targets' builds into one --output: one writer at a time, and the second does not
        # replace the first's output unless --force (checked again now that it is its turn).
        # (the lock lives in the workspace's .uros/, not beside the output in the user's folder)
        writers = plan.workspace.state_dir / "output-locks" / fp.digest(str(plan.output))[:16]
        with locked(writers, f"the output {plan.output}"):
            outputs.check_output_owner(plan.output, plan.target.key, plan.force, plan.output_flag)
            try:
                return swap.install_output(staging, plan.output)
            except OSError as exc:
                # the output's disk, not the workspace's (where the log is): a mount point is
                # filled in place, so its own disk can be the full one
                if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                    raise
                raise DiskFull.at(plan.output, f"writing the output {plan.output}: {exc.strerror}") from exc
    except BaseException:
        remove_tree(staging)
        raise


def _record(plan: BuildPlan, state_path: Path, parts: Mapping[str, str], assembled: Assembled) -> None:
    """The state that vouches for the output just swapped in (the next build compares with it)."""
    fp.write_state(
        state_path,
        fp.BuildState(
            fingerprint=fp.combine(parts),
            parts=dict(parts),
            output=str(plan.output),
            output_files=fp.stat_folder(plan.output, outputs.owned_entries(plan.output)),
            library_sha256=assembled.info.library.sha256,
            merge_key=assembled.merge_key,
            packages=assembled.info.packages,
        ),
    )


def say_done(ctx: Context, assembled: Assembled, left: list[str], started: float, origin: str) -> None:
    """What the build delivered (``origin``: where it came from, when not built), and what of the
    previous output is left."""
    plan = ctx.plan
    try:
        for why in left:  # the new output is in place: a warning, not a failure
            console.warn(f"could not remove the previous output {why}: remove it by hand")
        lib = plan.output / "libmicroros.a"
        verb, origin = ("took", f" {origin}") if origin else ("built", "")
        console.step(
            f"{verb} {lib} ({lib.stat().st_size:,} bytes, {assembled.info.library.members} objects) and "
            f"{assembled.info.include.files} headers in {plan.output / 'include'}{origin} "
            f"({time.monotonic() - started:.1f} s)"
        )
        symbols.warn_duplicates(assembled.info.library.duplicate_globals)
        firmware = plan.selection.firmware if plan.selection else None
        if firmware is not None:  # --for-firmware: its messages against MTU x history
            for _, warn, line in msgsize.verdicts(plan.output, assembled.info, firmware.packages):
                if warn:
                    console.warn(line)
            fitted = fit.library_fit(plan.output, assembled.info, firmware, known_options(), {})
            for warn, line in fit.summary(fitted):
                (console.warn if warn else console.info)(line)
    except KeyboardInterrupt as stop:
        raise interrupted(
            stop, "interrupted", f"the new output was already in place: {plan.output}"
        ) from None


def _free_bytes(folder: Path) -> int:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return 1 << 62


@dataclass(frozen=True)
class _Library:
    """libmicroros.a in the staging folder, merged (or the previous one reused), with its checks,
    and the include tree beside it."""

    info: Library
    abi_check: Mapping[str, Any]
    include: includes.IncludeReport
    merge_key: str  # what the library depends on


def _library(
    ctx: Context, staging: Path, setup: ColconSetup, built: tuple[str, ...], previous: fp.BuildState | None
) -> _Library:
    """The archives and headers of this build's packages only, into ``staging``: the library
    merged and checked against the target's ELF facts (or the last one reused when its archives
    did not change), the include tree copied meanwhile."""
    plan, runner = ctx.plan, ctx.runner
    install = setup.install_base
    by_package = installtree.archives(setup.build_base, install, built)
    libs = sorted({lib for libs in by_package.values() for lib in libs}, key=lambda p: p.name)
    if not libs:
        raise StepFailed(
            f"colcon built no static library into {install / 'lib'}",
            "check that the packages install their libraries: install(TARGETS ... ARCHIVE DESTINATION lib)",
        )
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir(parents=True)
    library = staging / "libmicroros.a"
    tools = ctx.kind.bintools()
    profile = target_profile(plan.target)
    merge_key = fp.digest_json(
        {
            "archives": fp.stat_files(libs),
            "tools": [tools.ar, tools.nm, tools.ranlib],
            "profile": repr(profile),
            "uros": __version__,
        }
    )
    reused = _previous_library(plan, previous, merge_key) if not plan.rebuild else None
    abi_check: Mapping[str, Any]
    # The include tree (1,688 headers copied for micro-ROS) is made beside the merge and the checks,
    # which mostly wait on ar, nm, readelf and size: one thread copies while they run. Nothing
    # else writes staging/include; when the merge fails, the copy finishes before the error goes up.
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="uros-includes") as pool:
        include_tree = pool.submit(
            includes.flatten_includes,
            install / "include",
            staging / "include",
            only=installtree.headers(setup.build_base, install, built),
        )
        if reused is not None:
            console.step(f"no archive changed: reusing libmicroros.a of {plan.output}")
            shutil.copy2(plan.output / reused.library.file, library)
            lib_info = dataclasses.replace(reused.library)
            abi_check = reused.abi_check
        else:
            console.step(f"merging {len(libs)} libraries into libmicroros.a")
            report = merge_archives(runner, tools, libs, library, plan.target_dir / "merge")
            # Before the output is swapped in: a library that fails the check never replaces a good one.
            abi_check = ctx.kind.check_library(runner, library)
            lib_info = _library_info(ctx, library, report)
        inc = include_tree.result()
    for warning in abi_check.get("warnings", ()):
        console.warn(warning)
    return _Library(lib_info, abi_check, inc, merge_key)


def _firmware_toolchain(ctx: Context, staging: Path) -> None:
    """The firmware's toolchain file beside the library, when the target's kind gives one."""
    text = ctx.kind.firmware_toolchain()
    if text is not None:
        (staging / "toolchain.cmake").write_text(text, encoding="utf-8")


def _cmake_package(plan: BuildPlan, staging: Path, info: BuildInfo) -> None:
    """The output's CMake package (what `uros export cmake` writes), its texts kept per target
    (steps/renders.py): a build that only runs colcon over its trees imports no jinja2."""
    import json

    args = (info.target, info.flags.cpu, info.rtos)
    text = kept_render(
        plan.target_dir,
        "cmake package",
        repr(args),
        tuple(f"{name}.j2" for name in cmake_export.CMAKE_FILES),
        lambda: json.dumps(cmake_export.cmake_package_files(*args)),
    )
    write_files(staging, json.loads(text))


def _build_info(
    ctx: Context, inputs: Inputs, setup: ColconSetup, compiled: Compiled, lib: _Library
) -> BuildInfo:
    """build-info.json's record of this build: what was built, from what, with what, and the
    library it made."""
    plan, built = ctx.plan, compiled.packages
    target, inc = ctx.kind.described(), lib.include
    return BuildInfo(
        generated_by=f"uros {__version__}",
        target=plan.target.key,
        profile=target.profile,
        toolchain_file=target.toolchain_file,
        compiler=target.compiler,
        cmake_version=ctx.facts.cmake_version,
        flags=target.flags,
        transport=meta_transport(plan.meta),
        packages=built,
        library=lib.info,
        include=Include(dir="include", files=inc.files, bytes=inc.bytes, packages=inc.packages),
        abi_check=lib.abi_check,
        skipped_python_packages=setup.skipped,
        host_stage_packages=setup.shared,
        idf_target=target.idf_target,
        idf=target.idf,
        rtos=target.rtos,
        ip_stack=target.ip_stack,
        cmake_options=contents.cmake_options(plan.meta),
        sources=_sources(plan, built),
        build_key=inputs.key,
        ccache=compiled.ccache,
    )


def _sources(plan: BuildPlan, built: tuple[str, ...]) -> dict[str, dict[str, str]]:
    """The clone and commit each built package came from (uros info shows them from here, not from
    a workspace that may have moved on since)."""
    ws = plan.workspace
    if not ws.lock_path.is_file():
        return {}
    clone_paths = read_lock(ws.lock_path, "uros.lock").repositories
    wanted = set(built)
    located = [(p.name, p.path.resolve()) for p in plan.workspace_packages if p.name in wanted]
    found = clones.built_from(located, ws.root, clone_paths)
    for entry in found.values():  # the library says which of its packages came from a stand-in
        stand_in = clone_paths[entry["repository"]].stand_in
        if stand_in:
            entry["stand_in"] = stand_in
    return found


def _library_info(ctx: Context, library: Path, report: MergeReport) -> Library:
    return Library(
        file="libmicroros.a",
        bytes=library.stat().st_size,
        sha256=fp.file_sha256(library),
        members=report.members,
        defined_global_symbols=report.symbols,
        renamed_duplicate_members=report.renamed_duplicates,
        duplicate_globals={d.name: d.members for d in report.duplicates},
        inputs=report.inputs,
        size=ctx.kind.library_size(ctx.runner, library),
    )


def _previous_library(plan: BuildPlan, previous: fp.BuildState | None, merge_key: str) -> BuildInfo | None:
    """The last build's output when its library was merged from the very archives this build
    installed (same sizes and mtimes: CMake's install leaves an unchanged file alone) and is
    still intact; None otherwise."""
    if previous is None or previous.merge_key != merge_key or previous.output != str(plan.output):
        return None
    try:
        info = read_build_info(plan.output)
    except ConfigError:
        return None
    lib = plan.output / info.library.file
    if info.library.sha256 != previous.library_sha256 or not lib.is_file():
        return None
    return info if fp.file_sha256(lib) == previous.library_sha256 else None


def assemble(ctx: Context, inputs: Inputs, setup: ColconSetup, compiled: Compiled) -> Assembled:
    """This build's archives merged (or the previous library reused) and checked, the include tree,
    the firmware's toolchain file, build-info and the CMake package: the output assembled beside
    its final place (removed again if anything fails)."""
    plan = ctx.plan
    staging = outputs.staging_dir(plan.output)
    try:
        lib = _library(ctx, staging, setup, compiled.packages, inputs.previous)
        _firmware_toolchain(ctx, staging)
        info = _build_info(ctx, inputs, setup, compiled, lib)
        _cmake_package(plan, staging, info)
    except OSError as exc:
        remove_tree(staging)
        # a file named (a copy's destination, the path a call or write names) is main's to report;
        # with none, the disk of the step's folders with the least room is the full one (not the
        # log's, which main would name)
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT) or written_path(exc) is not None:
            raise
        fullest = min((plan.target_dir, staging.parent), key=_free_bytes)
        raise DiskFull.at(fullest, f"merging the library in {fullest}: {exc.strerror}") from exc
    except BaseException:
        remove_tree(staging)
        raise
    return Assembled(staging, info, lib.merge_key)


def swap_in(ctx: Context, inputs: Inputs, assembled: Assembled) -> list[str]:
    """The assembled output swapped into place and the state that vouches for it recorded. Returns
    what of the previous output could not be removed."""
    left = _put_in_place(ctx.plan, assembled)
    _record(ctx.plan, inputs.state_path, inputs.parts, assembled)
    return left
