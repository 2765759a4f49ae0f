"""`uros build`: one target's libmicroros.a, include tree, CMake package and build-info.json.

plan (validate every input) → probe the host → sync extra packages, dev_ws once → render the
toolchain and colcon.meta → fingerprint the inputs: unchanged and the output intact → done →
the team cache has this build key → its output, checked, is swapped in → done →
drop packages the workspace lost → colcon (stamping each package it finishes) → merge this
build's packages (or reuse the library when no archive changed), check, stage → swap the output
into place → record the state → upload to the team cache (--cache-upload).
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import hashlib
import importlib.metadata
import os
import shutil
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import uros_build
from uros_build import (
    __version__,
    abi,
    clones,
    colcon,
    console,
    contents,
    depfiles,
    export,
    gencache,
    hosttools,
    includes,
    installtree,
    outputs,
)
from uros_build import cache as cache_mod
from uros_build import fingerprint as fp
from uros_build import meta as meta_mod
from uros_build import packages as packages_mod
from uros_build.archive import BinTools, MergeReport, merge_archives
from uros_build.buildinfo import (
    BUILD_INFO,
    BuildInfo,
    Compiler,
    Flags,
    IdfInfo,
    Include,
    Library,
    read_build_info,
)
from uros_build.cache import CacheSettings, CacheUnusable
from uros_build.errors import (
    ConfigError,
    DiskFull,
    Interrupted,
    StepFailed,
    UrosError,
    VerifyError,
    interrupted,
)
from uros_build.hosttools import HostFacts
from uros_build.plan import BuildArgs, BuildPlan, ProfileTarget, expand_targets, meta_transport, plan_build
from uros_build.proc import Runner, disk_full_line, disk_full_path, first_error, stop_leftovers
from uros_build.profiles import TargetProfile
from uros_build.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    microros_flags,
    render_toolchain,
    seeded_toolchain_text,
    tool_paths,
)
from uros_build.workspace import (
    DEV_MARKER,
    damaged_archives,
    damaged_configures,
    locked,
    read_lock,
    write_if_changed,
)


@dataclass(frozen=True)
class Outcome:
    target: str
    output: Path
    how: str  # "built", "up to date", "from the cache"


def build_all(args: BuildArgs) -> list[Outcome]:
    """`uros build`: the targets the command line names (--toolchain, repeatable), else each one
    the workspace's uros.yaml names (target: or targets:). Several targets: every one is planned
    first (a typo in the last fails before the first builds), each is built even when another
    fails, and a line per target says how it ended; the first failure is the command's."""
    requests = expand_targets(args)
    if len(requests) == 1:
        return [build(requests[0])]
    names = ", ".join(str(r.toolchain) for r in requests)
    console.step(f"building {len(requests)} targets ({names}) from {requests[0].toolchain_from}")
    for request in requests:
        plan_build(request)
    outcomes: list[Outcome] = []
    ended: list[str] = []
    failure: UrosError | None = None
    for request in requests:
        started = time.monotonic()
        try:
            outcome = build(request)
        except Interrupted:
            raise
        except UrosError as exc:
            failure = failure or exc
            ended.append(f"{request.toolchain}: FAILED (exit {exc.exit_code}: {str(exc).splitlines()[0]})")
            continue
        outcomes.append(outcome)
        ended.append(f"{outcome.target}: {outcome.how} ({time.monotonic() - started:.1f} s)")
    console.step(f"{len(requests)} targets:")
    for line in ended:
        (console.warn if "FAILED" in line else console.info)(line)
    if failure is not None:
        raise failure
    return outcomes


def build(args: BuildArgs) -> Outcome:
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
    _say_selection(plan)
    facts = hosttools.probe_host(
        runner,
        plan.profile,
        plan.target_dir,
        check_libraries=plan.config is not None,
        cache=hosttools.ProbeCache(ws.state_dir / "probes.json"),
    )
    if plan.config is not None:
        ws.sync_extra_packages(plan.config)
        # a workspace with a hand-written uros.yaml may have no dev_ws: nothing to build then
        if ws.dev_dir.is_dir() and hosttools.dev_needs_building(ws, plan.packages):
            assert plan.distro is not None  # loaded with the config
            hosttools.build_dev_workspace(ws, plan.config, plan.distro, runner, plan.verbose, plan.jobs)
    with locked(plan.target_dir, plan.target.key):
        repaired = _repair(plan)
        started = time.monotonic()
        _redo_what_must_be_redone(plan, facts)
        _reconfigure_after_a_full_disk(plan)
        toolchain_file = _prepare_toolchain(plan, facts)
        meta_path = plan.target_dir / "colcon.meta"
        meta_text = meta_mod.dump_meta(plan.meta, f"uros build --toolchain {plan.target.key}")
        write_if_changed(meta_path, meta_text)
        setup = _colcon_setup(plan, facts, toolchain_file, meta_path, runner)
        outside_digest = _drop_readers_of_changed_headers(plan)
        parts = _input_parts(plan, facts, toolchain_file, meta_text, setup)
        parts["headers outside the workspace"] = outside_digest
        state_path = plan.target_dir / fp.STATE
        previous = fp.read_state(state_path)
        fingerprint = fp.combine(parts)
        # A repair changed the trees the state vouches for: build again.
        if previous is not None and not plan.rebuild and not repaired:
            if previous.fingerprint == fingerprint and _output_intact(plan, previous):
                console.step(
                    f"up to date: {plan.output} (no input changed since its build; --rebuild forces one)"
                )
                if plan.cache is not None and plan.cache.upload:
                    _upload(plan, build_key(plan, facts, toolchain_file, parts), _entries(plan.output))
                return Outcome(plan.target.key, plan.output, "up to date")
            changed = fp.differing(previous.parts, parts) or ["the output folder"]
            console.info(f"changed since the last build: {', '.join(changed)}")
        # From here the trees change: until this build succeeds, no state vouches for the output.
        fp.forget_state(state_path)
        key = build_key(plan, facts, toolchain_file, parts)
        if plan.cache is not None and not plan.rebuild:
            hit = _from_cache(runner, plan, plan.cache, key)
            if hit is not None:
                left = _deliver(plan, hit)
                _record(plan, state_path, parts, hit, merge_key="")
                origin = f"from the cache {plan.cache.url.shown} (entry {key[:16]})"
                _say_done(plan, hit, left, started, origin)
                return Outcome(plan.target.key, plan.output, "from the cache")
        _drop_removed_packages(plan)
        (plan.target_dir / gencache.RUNS).unlink(missing_ok=True)
        (plan.target_dir / CCACHE_STATS).unlink(missing_ok=True)
        progress = _run_colcon(plan, facts, runner, setup, parts)
        _say_generation(plan)
        ccache_counts = _say_ccache(plan, setup)
        built = _check_built(plan, setup, progress, parts)
        # what the compiler read outside the workspace this time: the state records its content
        parts["headers outside the workspace"] = _record_outside_headers(plan, runner, setup)
        staging = outputs.staging_dir(plan.output)
        try:
            info, merge_key = _stage_output(runner, plan, facts, staging, setup, built, progress, previous)
        except OSError as exc:
            outputs.remove_tree(staging)
            # Python names no file for a failed write(): the disk of the step's folders with the
            # least room is the full one (not the log's, which the catch-all would name)
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT) or exc.filename:
                raise
            fullest = min((plan.target_dir, staging.parent), key=_free_bytes)
            raise DiskFull.at(fullest, f"merging the library in {fullest}: {exc.strerror}") from exc
        except BaseException:
            outputs.remove_tree(staging)
            raise
        staged = Staged(staging, dataclasses.replace(info, build_key=key, ccache=ccache_counts))
        entries = _entries(staging)
        left = _deliver(plan, staged)
        _record(plan, state_path, parts, staged, merge_key)
    _say_done(plan, staged, left, started, "")
    if plan.cache is not None and plan.cache.upload:
        _upload(plan, key, entries)
    return Outcome(plan.target.key, plan.output, "built")


@dataclass(frozen=True)
class Staged:
    """An output ready to be swapped in: its folder beside the output, and its build-info."""

    folder: Path
    info: BuildInfo


def _entries(folder: Path) -> list[str]:
    """What uros writes into an output (build-info.json's folder), its marker left out."""
    return sorted(p.name for p in folder.iterdir() if p.name != outputs.MARKER)


def _deliver(plan: BuildPlan, staged: Staged) -> list[str]:
    """build-info.json and the marker into the staged folder, then the swap: the staged folder
    becomes the output (removed if anything fails first). Returns what of the previous output
    could not be removed."""
    staging = staged.folder
    try:
        (staging / BUILD_INFO).write_text(staged.info.to_json(), encoding="utf-8")
        outputs.write_marker(staging, plan.target.key, [p.name for p in staging.iterdir()])
        # Two targets' builds into one --output: one writer at a time, and the second does not
        # replace the first's output unless --force (checked again now that it is its turn).
        # (the lock lives in the workspace's .uros/, not beside the output in the user's folder)
        writers = plan.workspace.state_dir / "output-locks" / fp.digest(str(plan.output))[:16]
        with locked(writers, f"the output {plan.output}"):
            outputs.check_output_owner(plan.output, plan.target.key, plan.force, plan.output_flag)
            try:
                return outputs.install_output(staging, plan.output)
            except OSError as exc:
                # the output's disk, not the workspace's (where the log is): a mount point is
                # filled in place, so its own disk can be the full one
                if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                    raise
                raise DiskFull.at(plan.output, f"writing the output {plan.output}: {exc.strerror}") from exc
    except BaseException:
        outputs.remove_tree(staging)
        raise


def _record(plan: BuildPlan, state_path: Path, parts: dict[str, str], staged: Staged, merge_key: str) -> None:
    """The state that vouches for the output just swapped in (the next build compares with it)."""
    fp.write_state(
        state_path,
        fp.BuildState(
            fingerprint=fp.combine(parts),
            parts=parts,
            output=str(plan.output),
            output_files=fp.stat_folder(plan.output),
            library_sha256=staged.info.library.sha256,
            merge_key=merge_key,
            packages=staged.info.packages,
        ),
    )


def _say_done(plan: BuildPlan, staged: Staged, left: list[str], started: float, origin: str) -> None:
    try:
        for why in left:  # the new output is in place: a warning, not a failure
            console.warn(f"could not remove the previous output {why}: remove it by hand")
        lib = plan.output / "libmicroros.a"
        verb, origin = ("took", f" {origin}") if origin else ("built", "")
        console.step(
            f"{verb} {lib} ({lib.stat().st_size:,} bytes, {staged.info.library.members} objects) and "
            f"{staged.info.include.files} headers in {plan.output / 'include'}{origin} "
            f"({time.monotonic() - started:.1f} s)"
        )
    except KeyboardInterrupt as stop:
        raise interrupted(
            stop, "interrupted", f"the new output was already in place: {plan.output}"
        ) from None


# ---------------------------------------------------------------------------------------------
# the team cache (issue 19): cache.py knows the entries and stores; here they meet the build


def _from_cache(runner: Runner, plan: BuildPlan, settings: CacheSettings, key: str) -> Staged | None:
    """The output of the entry ``key``, unpacked beside the output and checked as a build's would
    be (its build-info names this key and target, the library has the sha256 it names, every object
    passes the ABI check); None, with a line saying why, when there is none or it cannot be used."""
    shown = settings.url.shown
    store = cache_mod.store(settings.url)
    staging = outputs.staging_dir(plan.output)
    try:
        raw = store.get(cache_mod.manifest_name(key))
        if raw is None:
            console.info(f"cache: no entry {key[:16]} in {shown}: building")
            return None
        manifest = cache_mod.parse_manifest(raw, key)
        differ = cache_mod.headers_differ(
            manifest, {p: depfiles.content(p) for p in manifest.outside_headers}
        )
        if differ:
            more = f" and {len(differ) - 1} more" if len(differ) > 1 else ""
            console.info(
                f"cache: entry {key[:16]} was built against other headers outside the workspace "
                f"({differ[0]}{more}): building"
            )
            return None
        data = store.get(cache_mod.archive_name(key))
        if data is None:
            raise CacheUnusable(f"the entry {key[:16]} has a manifest and no tarball")
        outputs.remove_tree(staging)
        console.step(f"cache: entry {key[:16]} found in {shown} ({len(data):,} bytes): checking it")
        cache_mod.unpack(data, manifest, staging)
        info = _check_cached(runner, plan, staging, key)
        origin = {"url": shown, "key": key, "archive_sha256": manifest.archive_sha256}
        return Staged(staging, dataclasses.replace(info, from_cache=origin))
    except CacheUnusable as exc:
        outputs.remove_tree(staging)
        console.warn(f"cache {shown}: {exc}: building instead")
        return None
    except BaseException:
        outputs.remove_tree(staging)
        raise


def _check_cached(runner: Runner, plan: BuildPlan, staging: Path, key: str) -> BuildInfo:
    try:
        info = read_build_info(staging, "the cache entry")
    except ConfigError as exc:
        raise CacheUnusable(str(exc)) from None
    if info.build_key != key or info.target != plan.target.key:
        raise CacheUnusable(f"the entry {key[:16]} holds the output of another build ({info.target})")
    library = staging / info.library.file
    if not library.is_file() or fp.file_sha256(library) != info.library.sha256:
        raise CacheUnusable(f"the entry {key[:16]}'s library does not have its build-info's sha256")
    if not (staging / info.include.dir).is_dir():
        raise CacheUnusable(f"the entry {key[:16]} has no {info.include.dir}/ folder")
    if plan.profile is not None:
        try:
            console.info(abi.describe(abi.check_library(runner, library, plan.profile)))
        except VerifyError as exc:
            raise CacheUnusable(f"the entry {key[:16]}'s library fails the ABI check: {exc}") from None
    return info


def _upload(plan: BuildPlan, key: str, entries: list[str]) -> None:
    """The output as the cache entry ``key`` (tarball first, manifest last), unless the cache has
    it already. A failure is a warning: the build itself succeeded."""
    assert plan.cache is not None
    shown = plan.cache.url.shown
    store = cache_mod.store(plan.cache.url)
    try:
        if store.get(cache_mod.manifest_name(key)) is not None:
            console.info(f"cache: {shown} already has entry {key[:16]}")
            return
        info = read_build_info(plan.output)
        if info.from_cache:
            return  # taken from a cache: not this machine's to upload
        data = cache_mod.pack(plan.output, entries)
        record = depfiles.read_record(plan.target_dir / depfiles.RECORD)
        headers = {path: sha for per in record.values() for path, sha in per.items()}
        manifest = cache_mod.Manifest(
            key=key,
            archive_sha256=hashlib.sha256(data).hexdigest(),
            archive_bytes=len(data),
            target=plan.target.key,
            generated_by=info.generated_by,
            outside_headers=headers,
        )
        store.put(cache_mod.archive_name(key), data)
        store.put(cache_mod.manifest_name(key), manifest.to_json().encode("utf-8"))
        console.step(f"cache: uploaded entry {key[:16]} to {shown} ({len(data):,} bytes)")
    except (CacheUnusable, ConfigError) as exc:
        console.warn(f"cache {shown}: not uploaded: {exc}")


def compiler_identity(facts: HostFacts) -> str:
    """The target compiler as content, not as a place: its path, version and the sha256 of the
    driver program itself (a replaced or upgraded compiler at the same path is another compiler)."""
    if not facts.gcc:
        return fp.digest("")
    real = Path(os.path.realpath(facts.gcc))
    try:
        content = fp.file_sha256(real)
    except OSError:
        content = ""
    return fp.digest(facts.gcc, str(real), facts.gcc_version, content)


def _redo_what_must_be_redone(plan: BuildPlan, facts: HostFacts) -> None:
    """Objects the build tools would keep but that no longer match: with --rebuild, all of them;
    after a compiler change, all of them too, since neither CMake nor ninja makes an object depend
    on the compiler program (the command line is the same). Dropping the target's colcon trees
    (uros's own) makes every package configure, compile and install afresh."""
    trees = [plan.target_dir / "build", plan.target_dir / "install"]
    identity = plan.target_dir / "compiler.sha256"
    was = identity.read_text(encoding="utf-8").strip() if identity.is_file() else None
    now = compiler_identity(facts)
    why = None
    if plan.rebuild:
        why = "--rebuild"
    elif was is not None and was != now:
        why = f"the compiler changed ({facts.gcc} {facts.gcc_version})"
    if why is not None and any(t.exists() for t in trees):
        console.info(f"{why}: building every package afresh (dropping the target's colcon trees)")
        for tree in trees:
            outputs.remove_tree(tree)
    write_if_changed(identity, now + "\n")


_DISK_FULL_MARK = "disk-full"


def _free_bytes(folder: Path) -> int:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return 1 << 62


def _reconfigure_after_a_full_disk(plan: BuildPlan) -> None:
    mark = plan.target_dir / _DISK_FULL_MARK
    if mark.is_file():
        console.info("the last build ran out of disk space: configuring every package afresh")
        _forget_configured_flags(plan.target_dir / "build")
        mark.unlink()


def _drop_readers_of_changed_headers(plan: BuildPlan) -> str:
    """Packages that read a header outside the workspace whose content changed since their build
    (a C library upgrade, a profile's -I folder, an edit restored with an old mtime) are built
    afresh: ninja goes by mtimes, and such a header need not be newer than the objects. Returns
    the digest of those headers' current content, for the fingerprint."""
    record = depfiles.read_record(plan.target_dir / depfiles.RECORD)
    changed, digest = depfiles.changed_packages(record)
    existing = [p for p in changed if (plan.target_dir / "build" / p).is_dir()]
    if existing:
        names = ", ".join(existing)
        console.info(f"headers outside the workspace changed since the last build: building {names} afresh")
        for package in existing:
            outputs.remove_tree(plan.target_dir / "build" / package)
    return digest


def _record_outside_headers(plan: BuildPlan, runner: Runner, setup: ColconSetup) -> str:
    """Read, from ninja's record of the compiler's dependency output, every header each package's
    objects included from outside the workspace, and keep their sha256 for the next build. With
    another generator than Ninja there is no such record: those headers are not tracked."""
    ninja = colcon.ninja_program(setup.env)
    if ninja is None:
        return depfiles.changed_packages({})[1]
    roots = (plan.workspace.root, plan.target_dir)
    per_package: dict[str, list[str]] = {}
    for folder in sorted(p for p in setup.build_base.iterdir() if (p / ".ninja_deps").is_file()):
        text = runner.query(
            [ninja, "-C", str(folder), "-t", "deps"], step=f"read {folder.name}'s dependencies"
        )
        per_package[folder.name] = depfiles.outside(depfiles.parse_ninja_deps(text), roots)
    snap = depfiles.snapshot(per_package)
    write_if_changed(plan.target_dir / depfiles.RECORD, depfiles.record_text(snap))
    return depfiles.changed_packages(snap)[1]


def _repair(plan: BuildPlan) -> bool:
    """Before the target's trees or output are touched (its lock held): stop what a killed build of
    it left running, finish or undo a swap it left half-way, and drop package build folders whose
    configure a full disk (or a crash) cut short. True when anything was repaired."""
    repaired = False
    stopped = stop_leftovers(str(plan.target_dir))
    if stopped:
        console.warn(
            f"stopped {len(stopped)} processes left running by an earlier uros build of {plan.target.key} "
            f"that was killed (pids {' '.join(map(str, stopped))})"
        )
    for line in outputs.recover(plan.output):
        console.info(line)
        repaired = True
    trees = plan.target_dir
    for path, why in damaged_archives([trees / "install" / "lib", *sorted((trees / "build").glob("*/"))]):
        # ninja builds it again, colcon's install step copies it again
        console.warn(f"{path.name} {why} (a full disk or a crash?): removing {path}")
        outputs.remove_tree(path)
        repaired = True
    for folder, why in damaged_configures(plan.target_dir / "build"):
        console.warn(f"{folder.name}: {why} (a full disk or a crash?): configuring it afresh in {folder}")
        outputs.remove_tree(folder)
        repaired = True
    return repaired or bool(stopped)


def _say_selection(plan: BuildPlan) -> None:
    sel = plan.selection
    if sel is None:
        return
    if sel.firmware is not None:
        console.info(f"the firmware uses ({sel.firmware.scanned} files read): {sel.firmware.describe()}")
    parts = [f"{', '.join(sel.wanted)} (asked for)"] if sel.wanted else []
    if sel.firmware is not None:
        parts.append(f"{', '.join(sorted(sel.firmware.packages))} (the firmware's)")
    if sel.core:
        parts.append(f"{', '.join(sel.core)} (core)")
    if sel.extra:
        parts.append(f"{', '.join(sel.extra)} (extra packages)")
    console.info(f"building {'; '.join(parts)} and what they depend on")


@dataclass(frozen=True)
class ColconSetup:
    plan: colcon.ColconPlan
    argv: tuple[str, ...]
    env: Mapping[str, str]
    skipped: tuple[str, ...]  # pure-Python packages left out

    @property
    def build_base(self) -> Path:
        return self.plan.build_base

    @property
    def install_base(self) -> Path:
        return self.plan.install_base


def _colcon_setup(
    plan: BuildPlan, facts: HostFacts, toolchain_file: Path, meta_path: Path, runner: Runner
) -> ColconSetup:
    ws = plan.workspace
    env, scrubbed = hosttools.colcon_env(ws, plan.config, plan.distro, facts.cmake_version)
    if scrubbed:
        console.warn(f"ignoring the sourced environment for this build: {', '.join(scrubbed)}")
    # colcon prints its job events with flush=True, but its other output is block-buffered in a
    # pipe: unbuffered, the live view sees each line when it is written.
    env = {**env, "PYTHONUNBUFFERED": "1"}
    launcher = _ccache(plan, env, runner)
    if launcher:
        env.update(colcon.ccache_env(ws.root, plan.target_dir / CCACHE_STATS))
    skipped = tuple(packages_mod.host_only(list(plan.packages)))
    # --packages/--for-firmware/uros.yaml packages: exactly their closure, without the test
    # dependencies colcon's --packages-up-to would add (a user's --packages-up-to stays colcon's)
    out = packages_mod.left_out(plan.packages, plan.selection.request) if plan.selection else None
    colcon_plan = colcon.ColconPlan(
        base_paths=(ws.source_dir,),
        packages_ignore=skipped if out is None else tuple(sorted(out | set(skipped))),
        build_base=plan.target_dir / "build",
        install_base=plan.target_dir / "install",
        log_base=plan.target_dir / "log",
        metas=(meta_path,),
        toolchain_file=_seeded_toolchain(plan, facts, toolchain_file, runner, env),
        python=str(_python_shim(plan)),
        generator=colcon.generator(env),
        verbose=plan.verbose,
        packages_up_to=plan.packages_up_to,
        parallel_workers=plan.jobs,
        compiler_launcher=launcher,
    )
    return ColconSetup(colcon_plan, tuple(colcon.colcon_argv(colcon_plan, facts.colcon)), env, skipped)


CCACHE_STATS = "ccache-stats.log"  # this build's ccache counters (the user's totals stay theirs)


def _ccache(plan: BuildPlan, env: Mapping[str, str], runner: Runner) -> str | None:
    """ccache's path when the build compiles through it: --ccache (then it must be installed),
    --no-ccache never, by default when it is on PATH. Only for uros's own toolchain: a user's
    toolchain file does not carry the path maps that keep the library the same under ccache."""
    if plan.ccache is False or not isinstance(plan.target, ProfileTarget):
        return None
    if plan.ccache:
        return runner.which("ccache", path=env.get("PATH"))
    return shutil.which("ccache", path=env.get("PATH"))


def _say_ccache(plan: BuildPlan, setup: ColconSetup) -> dict[str, int]:
    """This build's ccache hits and misses (empty without ccache)."""
    if not setup.plan.compiler_launcher:
        return {}
    try:
        counts = colcon.ccache_counts((plan.target_dir / CCACHE_STATS).read_text(encoding="utf-8"))
    except OSError:
        counts = {"hits": 0, "misses": 0}
    total = counts["hits"] + counts["misses"]
    rate = f" ({100 * counts['hits'] / total:.0f}%)" if total else ""
    console.info(f"ccache: {counts['hits']} of {total} compiles taken from the cache{rate}")
    return counts


SEED_SWITCH = "UROS_COMPILER_SEED"  # "off": every package's configure finds the compilers itself


def _seeded_toolchain(
    plan: BuildPlan, facts: HostFacts, toolchain_file: Path, runner: Runner, env: Mapping[str, str]
) -> Path:
    """The toolchain file colcon passes to every package: the target's, with CMake's compiler facts
    found once per target (and again only when the toolchain, compiler or CMake changes). The
    rendered toolchain file stays what the build key and build-info describe."""
    if os.environ.get(SEED_SWITCH, "").lower() == "off":
        return toolchain_file
    seed = plan.target_dir / "toolchain-seeded.cmake"
    stamp = plan.target_dir / "toolchain-seeded.key"
    generator = colcon.generator(env)
    identity = (compiler_identity(facts), facts.cmake, facts.cmake_version, str(generator))
    key = fp.digest(fp.file_sha256(toolchain_file), *identity)
    if seed.is_file() and stamp.is_file() and stamp.read_text(encoding="utf-8").strip() == key:
        return seed
    found = hosttools.cmake_compiler_facts(
        runner, facts.cmake, toolchain_file, plan.target_dir / "compiler-facts", generator, env
    )
    if found is None:
        console.info("CMake could not find the compilers' facts once: each package's configure finds them")
        seed.unlink(missing_ok=True)
        return toolchain_file
    write_if_changed(seed, seeded_toolchain_text(toolchain_file, found, f"uros {__version__} build"))
    write_if_changed(stamp, key + "\n")
    return seed


def _say_generation(plan: BuildPlan) -> None:
    try:
        runs = gencache.count_runs((plan.target_dir / gencache.RUNS).read_text(encoding="utf-8"))
    except OSError:
        return  # no interface code generated in this build
    bypass = f", {runs['bypass']} not cacheable" if runs["bypass"] else ""
    console.info(
        f"interface code: {sum(runs.values())} generator runs, {runs['hit']} taken from the "
        f"workspace's generation cache, {runs['miss']} generated{bypass}"
    )


def _python_shim(plan: BuildPlan) -> Path:
    """The Python of the target's CMake builds: the real one, with rosidl's generator runs going
    through the workspace's generation cache (shared by every target: gencache.py)."""
    shim = plan.target_dir / "uros-python"
    text = gencache.shim_text(
        colcon.host_python(),
        plan.workspace.state_dir / "gen-cache",
        plan.target_dir,
        Path(uros_build.__file__).resolve().parent.parent,
        f"uros {__version__} build",
    )
    write_if_changed(shim, text)
    shim.chmod(0o755)
    return shim


# ---------------------------------------------------------------------------------------------
# what the build is made of


def build_key(plan: BuildPlan, facts: HostFacts, toolchain_file: Path, parts: Mapping[str, str]) -> str:
    """The build's inputs by content alone, so that two machines (or two checkouts) that build the
    same thing get the same key (issue 19): the sources' names and contents, the merged colcon.meta,
    the toolchain text with the workspace's path taken out, the profile's file, the compiler's version
    and program, the package selection, uros's own code. Known before anything is built, so that a
    cache can be asked for it: the headers read outside the workspace are known only after a build,
    so they are not in the key; a cache entry lists them and is used only where they match."""
    if isinstance(plan.target, ProfileTarget):
        # rendered again with a placeholder for the workspace, quoted as a plain path is
        toolchain = render_toolchain(_toolchain_request(plan, facts, Path("/workspace")))
    else:
        toolchain = toolchain_file.read_text(encoding="utf-8", errors="replace")
    profile = plan.profile
    profile_text = (
        Path(profile.source).read_bytes() if profile is not None and Path(profile.source).is_file() else b""
    )
    try:
        driver = fp.file_sha256(Path(os.path.realpath(facts.gcc))) if facts.gcc else ""
    except OSError:
        driver = ""
    code = Path(uros_build.__file__).parent
    return fp.digest_json(
        {
            "sources": parts["sources"],
            "colcon.meta": parts["colcon.meta"],
            "toolchain": fp.digest(toolchain),
            "profile": fp.digest(profile_text),
            "compiler": fp.digest(facts.gcc_version, driver),
            "packages": parts["packages"],
            "uros": fp.digest(__version__, *(p.read_bytes() for p in sorted(code.rglob("*.py")))),
        }
    )


def _uros_code() -> str:
    """uros's own code, by file identity (a development checkout changes without a version)."""
    root = Path(uros_build.__file__).parent
    return fp.digest(*(fp.stat_key(p) for p in sorted(root.rglob("*.py"))))


def _versions(*distributions: str) -> str:
    found = []
    for name in distributions:
        try:
            found.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            found.append(f"{name} -")
    return ", ".join(found)


_ENV_THAT_MATTERS = ("CMAKE_GENERATOR", "CMAKE_POLICY_VERSION_MINIMUM", "PYTHONPATH", "AMENT_PREFIX_PATH")


def _input_parts(
    plan: BuildPlan, facts: HostFacts, toolchain_file: Path, meta_text: str, setup: ColconSetup
) -> dict[str, str]:
    """Every input of the build, each as a digest: equal parts, equal build."""
    ws = plan.workspace
    cache_path = plan.target_dir / fp.SOURCES_CACHE
    cached = fp.load_sources_cache(cache_path)
    # An --output inside a plain workspace (and its staging folders beside it) is not a source.
    out = plan.output
    sources = fp.scan_tree(ws.source_dir, cached, (str(out), str(out.parent / f".{out.name}.")))
    newer = fp.content_changed(cached, sources)
    if newer:
        fp.make_newer(ws.source_dir, newer, sources)
    if sources != cached:
        fp.save_sources_cache(cache_path, sources)
    # The colcon command without what does not change its result (progress output, workers).
    stable = colcon.colcon_argv(
        dataclasses.replace(setup.plan, verbose=False, parallel_workers=None), facts.colcon
    )
    env = {
        k: v
        for k, v in setup.env.items()
        if k in _ENV_THAT_MATTERS
        or k in colcon.FINGERPRINTED_VARIABLES
        or k.startswith(("GIT_CONFIG_", *colcon.FINGERPRINTED_PREFIXES))
    }
    marker = ws.dev_install / DEV_MARKER
    ninja = colcon.ninja_program(setup.env)
    return {
        "sources": fp.tree_digest(sources),
        "colcon.meta": fp.digest(meta_text),
        "toolchain file": fp.file_sha256(toolchain_file),
        "profile": fp.digest(repr(plan.profile)),
        # the ESP-IDF project's version, target, include folders, flags and sdkconfig.h hash
        "ESP-IDF project": fp.digest(repr(plan.idf)),
        "compiler": compiler_identity(facts),
        "tools": fp.digest(
            facts.cmake,
            facts.cmake_version,
            fp.stat_key(Path(facts.cmake)),
            fp.stat_key(Path(facts.colcon)),
            _versions("colcon-core", "colcon-cmake", "colcon-ros", "colcon-package-selection"),
            fp.stat_key(Path(ninja)) if ninja else "",
            sys.version,
            __version__,
            _uros_code(),
        ),
        "dev_ws": fp.digest(
            marker.read_text(encoding="utf-8") if marker.is_file() else "", fp.stat_key(marker)
        ),
        "packages": fp.digest_json([list(plan.requested), list(setup.skipped)]),
        "colcon": fp.digest_json([stable, sorted(env.items())]),
        "output": fp.digest(str(plan.output)),
    }


def _output_intact(plan: BuildPlan, state: fp.BuildState) -> bool:
    """The output folder is what the recorded build wrote (its build-info.json names the
    library's sha256, and every file is as written)."""
    try:
        info = read_build_info(plan.output)
    except ConfigError:
        return False
    return fp.output_intact(state, plan.output, info.library.file, info.library.sha256)


def _flags_fingerprint(parts: Mapping[str, str]) -> str:
    """What every package of the target is compiled with: the toolchain file, the compiler and
    colcon's CMake arguments (a package's own colcon.meta entry is added per package)."""
    return fp.digest(parts["toolchain file"], parts["compiler"], parts["colcon"])


def _drop_removed_packages(plan: BuildPlan) -> None:
    """A package the workspace no longer has must leave the target's trees, or its archive and
    headers would ship in the next library."""
    build_base, install_base = plan.target_dir / "build", plan.target_dir / "install"
    names = {p.name for p in plan.packages}
    if installtree.tree_packages(build_base) - names:
        names |= packages_mod.plain_cmake_packages(plan.workspace.source_dir)
    gone = installtree.drop_removed(build_base, install_base, names)
    if gone:
        console.info(f"dropped from the target's trees (no longer in the workspace): {', '.join(gone)}")


# ---------------------------------------------------------------------------------------------
# colcon


def _run_colcon(
    plan: BuildPlan, facts: HostFacts, runner: Runner, setup: ColconSetup, parts: Mapping[str, str]
) -> colcon.BuildProgress:
    """colcon build into the target's own trees, shown as it goes (colcon's own job events).
    Every package colcon reports finished is stamped with the flags it was built with; one being
    built vouches for nothing."""
    if setup.skipped:
        console.info(f"not building {len(setup.skipped)} pure-Python packages: {', '.join(setup.skipped)}")
    flags = _flags_fingerprint(parts)
    progress = colcon.BuildProgress(total=_expected_packages(plan, setup), started_at=time.monotonic())
    console.step("colcon build")
    view = console.ProgressView(progress.total, plain=plan.verbose)

    def on_line(line: str) -> None:
        event = progress.feed(line, time.monotonic())
        if event is None:
            return
        if event.kind == "start":
            (setup.build_base / event.package / installtree.STAMP).unlink(missing_ok=True)
        elif event.kind == "finish":
            entry = plan.meta.names.get(event.package, {})
            installtree.write_stamp(
                setup.build_base, event.package, installtree.package_stamp(flags, event.package, entry)
            )
        ended = None
        if event.kind != "start":
            what = {"finish": "built", "fail": "FAILED", "abort": "stopped"}[event.kind]
            ended = (what, event.package, event.seconds or 0.0)
        view.update(
            console.Progress(
                progress.done,
                progress.total,
                tuple(progress.running.items()),
                progress.started_at,
                tuple(progress.failed),
            ),
            ended,
        )

    # Files CMake generates when it configures (a package's <pkg>Config.cmake, its targets file)
    # can be cut short by a full disk, and CMake writes them again only when it configures. A mark
    # written now, while there is room, and removed unless the disk filled up, makes the next build
    # configure every package afresh (the objects stay: ninja redoes only what differs).
    mark = plan.target_dir / _DISK_FULL_MARK
    with contextlib.suppress(OSError):
        mark.write_text("a colcon build that may run out of disk\n", encoding="utf-8")
    try:
        runner.run(
            setup.argv,
            step="colcon build",
            cwd=plan.workspace.root,
            env=setup.env,
            hint=f"the full output is in {runner.log_path}",
            on_line=on_line,
            quiet=not plan.verbose,  # the command is in the log; the progress says the rest
        )
    except StepFailed as exc:
        failure = _colcon_failure(exc, setup.plan.log_base, runner.log_path)
        if not isinstance(failure, DiskFull):
            mark.unlink(missing_ok=True)
        raise failure from None
    finally:
        view.stop()
    mark.unlink(missing_ok=True)
    elapsed = time.monotonic() - progress.started_at
    slowest = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in progress.slowest(5))
    console.info(f"colcon built {len(progress.finished)} packages in {elapsed:.1f} s; slowest: {slowest}")
    return progress


def _expected_packages(plan: BuildPlan, setup: ColconSetup) -> int:
    """How many packages colcon will build (for the progress view; colcon does not say)."""
    if setup.plan.packages_up_to:
        names = packages_mod.closure(plan.packages, setup.plan.packages_up_to)
    else:  # colcon also builds the CMake packages without a package.xml (Micro-CDR, the XRCE client)
        names = {p.name for p in plan.packages} | packages_mod.plain_cmake_packages(plan.workspace.source_dir)
    return len(colcon.kept_by_ignores(setup.plan, names))


def _check_built(
    plan: BuildPlan, setup: ColconSetup, progress: colcon.BuildProgress, parts: Mapping[str, str]
) -> tuple[str, ...]:
    """The packages of this build (those colcon reported finished), each stamped with this
    build's flags: VerifyError otherwise, before anything is merged."""
    built = tuple(sorted(progress.finished))
    if not built:
        raise StepFailed(
            "colcon reported no package built",
            f"check that colcon finds packages in {plan.workspace.source_dir}; the log is above",
        )
    flags = _flags_fingerprint(parts)
    expected = {p: installtree.package_stamp(flags, p, plan.meta.names.get(p, {})) for p in built}
    stale = installtree.stale(setup.build_base, expected)
    if stale:
        raise VerifyError(
            f"{', '.join(stale)}: built with other flags than this build's (build stamp differs)",
            "run `uros build --rebuild` to build them again with the flags recorded",
        )
    return built


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
        # The user's own file: its flags, too, reach the compiles only through a fresh configure.
        seen = plan.target_dir / "toolchain-file.sha256"
        if write_if_changed(seen, fp.file_sha256(target.toolchain_file) + "\n"):
            _forget_configured_flags(plan.target_dir / "build")
        return target.toolchain_file
    profile = target.profile
    header = plan.target_dir / CLOCK_HEADER_NAME
    if profile.micro_ros.declare_clock_gettime:
        write_if_changed(header, CLOCK_HEADER_TEXT)
    path = plan.target_dir / "toolchain.cmake"
    if write_if_changed(path, render_toolchain(_toolchain_request(plan, facts, plan.workspace.root))):
        _forget_configured_flags(plan.target_dir / "build")
    return path


def _toolchain_request(plan: BuildPlan, facts: HostFacts, root: Path) -> ToolchainRequest:
    """The micro-ROS toolchain file's inputs, with ``root`` standing for the workspace (the real one,
    or a placeholder for the portable build key)."""
    target = plan.target
    assert isinstance(target, ProfileTarget)
    profile = target.profile
    header = root / plan.target_dir.relative_to(plan.workspace.root) / CLOCK_HEADER_NAME
    return ToolchainRequest(
        profile,
        micro_ros=True,
        gcc_major=facts.gcc_major,
        clock_header=str(header) if profile.micro_ros.declare_clock_gettime else None,
        tool_dir=facts.tool_dir,
        command=f"uros build --toolchain {profile.name}",
        prefix_map=str(root),
        idf=plan.idf,
        transport=meta_transport(plan.meta),
    )


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


def _stage_output(
    runner: Runner,
    plan: BuildPlan,
    facts: HostFacts,
    staging: Path,
    setup: ColconSetup,
    built: tuple[str, ...],
    progress: colcon.BuildProgress,
    previous: fp.BuildState | None,
) -> tuple[BuildInfo, str]:
    """The output in ``staging``: the archives and headers of this build's packages only.
    Returns its build-info and the merge key (what the library depends on)."""
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
    tools = _bintools(plan, facts)
    profile = plan.profile
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
    if reused is not None:
        console.step(f"no archive changed: reusing libmicroros.a of {plan.output}")
        shutil.copy2(plan.output / reused.library.file, library)
        lib_info = dataclasses.replace(reused.library)
        abi_check = reused.abi_check
    else:
        console.step(f"merging {len(libs)} libraries into libmicroros.a")
        report = merge_archives(runner, tools, libs, library, plan.target_dir / "merge")
        # Before the output is swapped in: a library that fails the check never replaces a good one.
        if profile is None:
            abi_check = {
                "checked": False,
                "reason": "your own toolchain file: no target profile to compare with",
            }
        else:
            console.step(f"checking every object against {profile.name}'s ELF facts")
            abi_check = abi.check_library(runner, library, profile)
            console.info(abi.describe(abi_check))
        lib_info = _library_info(runner, facts, profile, library, report)
    for warning in abi_check.get("warnings", ()):
        console.warn(warning)
    inc = includes.flatten_includes(
        install / "include", staging / "include", only=installtree.headers(setup.build_base, install, built)
    )
    if profile is not None:
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
        packages=built,
        library=lib_info,
        include=Include(dir="include", files=inc.files, bytes=inc.bytes, packages=inc.packages),
        abi_check=abi_check,
        skipped_python_packages=setup.skipped,
        idf_target=profile.idf_target or None if profile else None,
        idf=_idf_info(plan),
        package_seconds={p: round(progress.finished[p], 2) for p in built if p in progress.finished},
        cmake_options=contents.cmake_options(plan.meta),
        sources=_sources(plan, built),
    )
    export.write_cmake_package(staging, info)
    return info, merge_key


def _sources(plan: BuildPlan, built: tuple[str, ...]) -> dict[str, dict[str, str]]:
    """The clone and commit each built package came from (uros info shows them from here, not from
    a workspace that may have moved on since)."""
    ws = plan.workspace
    if not ws.lock_path.is_file():
        return {}
    clone_paths = read_lock(ws.lock_path, "uros.lock").repositories
    wanted = set(built)
    located = [(p.name, p.path.resolve()) for p in plan.packages if p.name in wanted]
    return clones.built_from(located, ws.root, clone_paths)


def _library_info(
    runner: Runner, facts: HostFacts, profile: TargetProfile | None, library: Path, report: MergeReport
) -> Library:
    size = None
    if profile is not None:
        size = hosttools.size_totals(runner, tool_paths(profile, facts.tool_dir)["size"], library)
    return Library(
        file="libmicroros.a",
        bytes=library.stat().st_size,
        sha256=fp.file_sha256(library),
        members=report.members,
        defined_global_symbols=report.symbols,
        renamed_duplicate_members=report.renamed_duplicates,
        inputs=report.inputs,
        size=size,
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
