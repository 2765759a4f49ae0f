"""The team cache in a build (cache.py knows the entries and stores): an entry taken, checked as a
build's output would be, or this build's output uploaded.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

from uros_build import console
from uros_build.colcon import depfiles
from uros_build.colcon import fingerprint as fp
from uros_build.config.plan import BuildPlan
from uros_build.errors import (
    ConfigError,
    VerifyError,
)
from uros_build.output import folders as outputs
from uros_build.output import swap
from uros_build.output import team_cache as cache_mod
from uros_build.output.buildinfo import (
    BuildInfo,
    read_build_info,
)
from uros_build.output.team_cache import CacheSettings, CacheUnusable
from uros_build.proc import Runner
from uros_build.steps.deliver import Assembled
from uros_build.target import abi


def _from_cache(runner: Runner, plan: BuildPlan, settings: CacheSettings, key: str) -> Assembled | None:
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
        swap.remove_tree(staging)
        console.step(f"cache: entry {key[:16]} found in {shown} ({len(data):,} bytes): checking it")
        cache_mod.unpack(data, manifest, staging)
        info = _check_cached(runner, plan, staging, key)
        origin = {"url": shown, "key": key, "archive_sha256": manifest.archive_sha256}
        return Assembled(staging, dataclasses.replace(info, from_cache=origin))
    except CacheUnusable as exc:
        swap.remove_tree(staging)
        console.warn(f"cache {shown}: {exc}: building instead")
        return None
    except BaseException:
        swap.remove_tree(staging)
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


def take(runner: Runner, plan: BuildPlan, key: str) -> Assembled | None:
    """The team cache's output for this build key, checked (None: no cache, --rebuild, a miss or
    an entry that cannot be used)."""
    if plan.cache is None or plan.rebuild:
        return None
    return _from_cache(runner, plan, plan.cache, key)


def upload_if_asked(plan: BuildPlan, key: str, entries: list[str]) -> None:
    if plan.cache is not None and plan.cache.upload:
        _upload(plan, key, entries)
