"""The team cache in a build (cache.py knows the entries and stores): an entry taken, checked as a
build's output would be, or this build's output uploaded.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import console
from uros_build.colcon import depfiles
from uros_build.colcon import fingerprint as fp
from uros_build.config.buildplan import BuildPlan
from uros_build.defaults import BUILD_INFO
from uros_build.errors import (
    ConfigError,
    VerifyError,
    interrupted,
)
from uros_build.files import remove_tree
from uros_build.output import folders as outputs
from uros_build.output import team_cache as cache_mod
from uros_build.output.buildinfo import (
    BuildInfo,
    read_build_info,
)
from uros_build.output.exports import cmake as cmake_export
from uros_build.output.team_cache import CacheSettings, CacheUnusable
from uros_build.steps.context import Context

if TYPE_CHECKING:  # at run time imported where an entry is taken or uploaded: most builds use no cache
    from uros_build.output import cache_store
    from uros_build.steps.deliver import Assembled


def _from_cache(
    ctx: Context, settings: CacheSettings, key: str, sources: Mapping[str, str]
) -> Assembled | None:
    """The output of the entry ``key``, unpacked beside the output and checked as a build's would
    be (every file has the manifest's size and sha256, its build-info names this key and target,
    the library has the sha256 it names, every object passes the ABI check, the CMake package and
    toolchain.cmake are what this uros writes, every header the workspace's sources hold is theirs:
    ``sources``, path -> sha256); None, with a line saying why, when there is none or it cannot be
    used."""
    from uros_build.output import cache_store  # with a cache only (start-up cost: see the top)
    from uros_build.steps.deliver import Assembled

    plan, shown = ctx.plan, settings.url.shown
    staging = outputs.staging_dir(plan.output)
    try:
        store = cache_store.store(settings.url, settings.timeout)
        raw = store.get(cache_mod.manifest_name(key), cache_mod.MAX_MANIFEST_BYTES)
        if raw is None:
            console.info(f"cache: no entry {key[:16]} in {shown}: building")
            return None
        manifest = cache_mod.parse_manifest(raw, key)
        differ = cache_mod.headers_differ(
            manifest, {p: cache_mod.local_sha256(p) for p in manifest.outside_headers}
        )
        if differ:
            more = f" and {len(differ) - 1} more" if len(differ) > 1 else ""
            console.info(
                f"cache: entry {key[:16]} was built against other headers outside the workspace "
                f"({differ[0]}{more}): building"
            )
            return None
        poisoned = cache_mod.headers_not_the_workspaces(manifest, cache_mod.workspace_headers(sources))
        if poisoned:
            more = f" and {len(poisoned) - 1} more" if len(poisoned) > 1 else ""
            raise CacheUnusable(
                f"the entry {key[:16]}'s {poisoned[0]}{more} is not the workspace's header of that name"
            )
        data = store.get(cache_mod.archive_name(key), manifest.archive_bytes)
        if data is None:
            raise CacheUnusable(f"the entry {key[:16]} has a manifest and no tarball")
        remove_tree(staging)
        console.step(f"cache: entry {key[:16]} found in {shown} ({len(data):,} bytes): checking it")
        cache_mod.unpack(data, manifest, staging)
        info = _check_cached(ctx, staging, key)
        origin = {"url": shown, "key": key, "archive_sha256": manifest.archive_sha256}
        return Assembled(staging, dataclasses.replace(info, from_cache=origin))
    except CacheUnusable as exc:
        _drop(staging)
        console.warn(f"cache {shown}: {cache_store.scrub(str(exc))}: building instead")
        return None
    except BaseException:
        _drop(staging)
        raise


def _drop(staging: Path) -> None:
    """The staging folder of an entry that is not used, removed; a folder that cannot be removed
    is the next build's staging to replace, never this build's failure."""
    try:
        remove_tree(staging)
    except OSError as exc:
        console.warn(f"could not remove {staging} ({exc.strerror}): the next build replaces it")


def _check_cached(ctx: Context, staging: Path, key: str) -> BuildInfo:
    plan = ctx.plan
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
    # The files a firmware's CMake runs are written by this uros for this target: an entry's must
    # be exactly those (a server's copy could add execute_process lines).
    expected = cmake_export.cmake_package_files(info.target, info.flags.cpu, info.rtos)
    firmware_toolchain = ctx.kind.firmware_toolchain()
    if firmware_toolchain is not None:
        expected["toolchain.cmake"] = firmware_toolchain
    for name in sorted(cache_mod.ENTRY_FILES - {BUILD_INFO, "libmicroros.a"}):
        path = staging / name
        there = path.read_bytes() if path.is_file() else None
        want = expected[name].encode("utf-8") if name in expected else None
        if there != want:
            raise CacheUnusable(
                f"the entry {key[:16]}'s {name} is not the one uros writes for {plan.target.key}"
            )
    try:  # as a build's library is checked (a user's toolchain file: nothing to check against)
        ctx.kind.check_library(ctx.runner, library, announce=False)
    except VerifyError as exc:
        raise CacheUnusable(f"the entry {key[:16]}'s library fails the ABI check: {exc}") from None
    return info


def _existing_entry_is_whole(store: cache_store.Store, key: str) -> None:
    """CacheUnusable unless the store's entry ``key`` passes the checks a reader makes of its
    bytes (a manifest of this format and key, a tarball of its size and sha256, every file as it
    lists): an entry that fails them is replaced by the next upload, not kept forever."""
    raw = store.get(cache_mod.manifest_name(key), cache_mod.MAX_MANIFEST_BYTES)
    if raw is None:
        raise CacheUnusable("no manifest")
    manifest = cache_mod.parse_manifest(raw, key)
    data = store.get(cache_mod.archive_name(key), manifest.archive_bytes)
    if data is None:
        raise CacheUnusable(f"the entry {key[:16]} has a manifest and no tarball")
    cache_mod.unpack(data, manifest, None)


def _upload(plan: BuildPlan, key: str, entries: list[str]) -> None:
    """The output as the cache entry ``key`` (tarball first, manifest last), unless the cache has
    it already, whole. Only what uros wrote there (the output's marker names it) and an entry may
    hold is packed: never the user's own files beside it. A failure is a warning: the build itself
    succeeded."""
    from uros_build.output import cache_store  # with a cache only (start-up cost: see the top)

    assert plan.cache is not None
    shown = plan.cache.url.shown
    try:
        store = cache_store.store(plan.cache.url, plan.cache.timeout)
        if store.get(cache_mod.manifest_name(key), cache_mod.MAX_MANIFEST_BYTES) is not None:
            try:
                _existing_entry_is_whole(store, key)
                console.info(f"cache: {shown} already has entry {key[:16]}")
                return
            except CacheUnusable as exc:
                console.info(f"cache: the entry {key[:16]} in {shown} fails its checks ({exc}): replacing it")
        info = read_build_info(plan.output)
        if info.from_cache:
            return  # taken from a cache: not this machine's to upload
        owned = outputs.owned_entries(plan.output) or frozenset()
        names = sorted(
            n for n in set(entries) & owned if n in cache_mod.ENTRY_FILES or n == cache_mod.INCLUDE
        )
        if "libmicroros.a" not in names or BUILD_INFO not in names:
            raise CacheUnusable(f"{plan.output}: its marker does not name the library uros wrote there")
        data, files = cache_mod.pack_entry(plan.output, names)
        record = depfiles.read_record(plan.target_dir / depfiles.RECORD)
        headers = {path: sha for per in record.values() for path, sha in per.items()}
        manifest = cache_mod.Manifest(
            key=key,
            archive_sha256=hashlib.sha256(data).hexdigest(),
            archive_bytes=len(data),
            target=plan.target.key,
            generated_by=info.generated_by,
            outside_headers=headers,
            files=files,
        )
        store.put(cache_mod.archive_name(key), data)
        store.put(cache_mod.manifest_name(key), manifest.to_json().encode("utf-8"))
        console.step(f"cache: uploaded entry {key[:16]} to {shown} ({len(data):,} bytes)")
    except (CacheUnusable, ConfigError, OSError) as exc:
        console.warn(f"cache {shown}: not uploaded: {cache_store.scrub(str(exc))}")


def take(ctx: Context, key: str, sources: Mapping[str, fp.FileRecord]) -> Assembled | None:
    """The team cache's output for this build key, checked against this uros's files and the
    workspace's ``sources`` (None: no cache, --rebuild, a miss or an entry that cannot be used)."""
    plan = ctx.plan
    if plan.cache is None or plan.rebuild:
        return None
    return _from_cache(ctx, plan.cache, key, {rel: record.sha256 for rel, record in sources.items()})


def upload_if_asked(ctx: Context, key: str, entries: list[str]) -> None:
    """The output uploaded as the entry ``key`` when the build asks (--cache-upload)."""
    plan = ctx.plan
    if plan.cache is not None and plan.cache.upload:
        try:
            _upload(plan, key, entries)
        except KeyboardInterrupt as stop:  # Ctrl-C, SIGTERM, SIGHUP: the new output is in place already
            raise interrupted(
                stop,
                f"the upload of entry {key[:16]} to the team cache {plan.cache.url.shown} was interrupted",
                f"this build's output is in place in {plan.output}; the cache holds no usable entry for it "
                "(its manifest is written last): run the same uros build --cache-upload again to upload it",
            ) from None
