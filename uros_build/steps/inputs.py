"""What a build is made of: every input as a digest (the fingerprint), the last good build's state,
up to date or what changed, and the portable build key; and what the next build would see changed,
asked without building (`uros doctor`: the workspace's inputs, the RTOS headers a library records).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import __version__, console
from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.config.targets import target_profile
from uros_build.errors import ConfigError, UrosError
from uros_build.output.buildinfo import read_build_info
from uros_build.output.folders import owned_entries
from uros_build.sources import packages as packages_mod
from uros_build.sources.workspace import Workspace, check_extra_package
from uros_build.sources.wsfiles import CONFIG, load_config
from uros_build.steps.colcon_setup import ColconSetup, meta_text
from uros_build.steps.context import Context
from uros_build.steps.prepare import compiler_identity
from uros_build.target.rtos import CONFIG_HEADER, recorded_digest


def build_key(ctx: Context, toolchain_file: Path, parts: Mapping[str, str]) -> str:
    """The build's inputs by content alone, so that two machines (or two checkouts) that build the
    same thing get the same key (issue 19): the sources' names and contents, the merged colcon.meta,
    the toolchain text with the workspace's path taken out, the profile's file, the compiler's version
    and program, the package selection, uros's own code. Known before anything is built, so that a
    cache can be asked for it: the headers read outside the workspace are known only after a build,
    so they are not in the key; a cache entry lists them and is used only where they match."""
    plan, facts = ctx.plan, ctx.facts
    toolchain = ctx.kind.portable_toolchain(toolchain_file)
    profile, rtos, stack = target_profile(plan.target), plan.platform.rtos, plan.platform.ip_stack
    profile_text = (
        Path(profile.source).read_bytes() if profile is not None and Path(profile.source).is_file() else b""
    )
    try:
        driver = fp.program_sha256(Path(os.path.realpath(facts.gcc))) if facts.gcc else ""
    except OSError:
        driver = ""
    return fp.digest_json(
        {
            "sources": parts["sources"],
            "colcon.meta": parts["colcon.meta"],
            "toolchain": fp.digest(toolchain),
            "profile": fp.digest(profile_text),
            "compiler": fp.digest(facts.gcc_version, driver),
            "packages": parts["packages"],
            # the RTOS headers by content (the toolchain text has their folders as placeholders)
            "rtos": fp.digest_json([rtos.name, list(rtos.port), rtos.headers_sha256] if rtos else None),
            # the IP stack's headers (lwIP's, its port's, lwipopts.h and arch/cc.h) by content
            "ip_stack": fp.digest_json([stack.name, stack.headers_sha256] if stack else None),
            "uros": fp.uros_code_digest(),
        }
    )


def _versions(*distributions: str) -> str:
    found = []
    for name in distributions:
        try:
            found.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            found.append(f"{name} -")
    return ", ".join(found)


_ENV_THAT_MATTERS = ("CMAKE_GENERATOR", "CMAKE_POLICY_VERSION_MINIMUM", "PYTHONPATH", "AMENT_PREFIX_PATH")


def scan_sources(
    ws: Workspace, target_dir: Path, out: Path
) -> tuple[dict[str, fp.FileRecord], dict[str, fp.FileRecord]]:
    """The workspace's sources as they are now, and as the target's stat cache last saw them
    (which lets the scan hash only files whose stat changed). Reads only."""
    cached = fp.load_sources_cache(target_dir / fp.SOURCES_CACHE)
    # An --output inside a plain workspace (and its staging folders beside it) is not a source.
    sources = fp.scan_tree(ws.source_dir, cached, (str(out), str(out.parent / f".{out.name}.")))
    return sources, cached


def workspace_parts(ws: Workspace, sources_digest: str) -> dict[str, str]:
    """The inputs that are the workspace's alone, whatever the command line said: the sources'
    content and the workspace's settings files (uros.yaml, its colcon.meta). `uros doctor` judges
    a target by these (it does not know the last build's command line); a build has them too."""
    settings = [p.read_bytes() if p.is_file() else b"" for p in (ws.root / CONFIG, ws.user_meta)]
    return {"sources": sources_digest, "workspace settings": fp.digest(*settings)}


def content_parts(plan: BuildPlan, sources_digest: str) -> dict[str, str]:
    """The inputs known without running a tool or writing a file: :func:`workspace_parts`, the
    merged colcon.meta, the profile, the ESP-IDF project, the packages and the output; a build adds
    the rest (:func:`_input_parts`)."""
    skipped = packages_mod.host_only(list(plan.workspace_packages))
    return {
        **workspace_parts(plan.workspace, sources_digest),
        "colcon.meta": fp.digest(meta_text(plan)),
        "profile": fp.digest(repr(target_profile(plan.target))),
        # the ESP-IDF project's version, target, include folders, flags and sdkconfig.h hash
        "ESP-IDF project": fp.digest(repr(plan.platform.idf)),
        # the RTOS's folders, port and headers (kernel, port, FreeRTOSConfig.h) by content
        "RTOS": fp.digest(repr(plan.platform.rtos)),
        # the IP stack's folders and headers (lwIP's, its port's, lwipopts.h, arch/cc.h) by content
        "IP stack": fp.digest(repr(plan.platform.ip_stack)),
        "packages": fp.digest_json([list(plan.requested), list(skipped)]),
        "output": fp.digest(str(plan.output)),
    }


def changes(previous: fp.BuildState, parts: Mapping[str, str], complete: bool) -> list[str]:
    """What differs from the target's last good build: the parts of ``parts`` whose digest is
    another (``complete``: ``parts`` is every input, so a part the last build had and this one
    lacks counts too), and the output folder when it is not as that build wrote it. [] means up to
    date. The one judgement of `uros build` (every input) and `uros doctor` (:func:`content_parts`)."""
    before = previous.parts if complete else {k: v for k, v in previous.parts.items() if k in parts}
    changed = fp.differing(before, parts)
    if not _output_intact(Path(previous.output), previous):
        changed.append("the output folder")
    return changed


def scan(ctx: Context) -> dict[str, fp.FileRecord]:
    """The workspace's sources now (their stat cache updated, files whose content changed under
    an old mtime made newer, so that CMake and ninja see them)."""
    plan = ctx.plan
    ws = plan.workspace
    sources, cached = scan_sources(ws, plan.target_dir, plan.output)
    newer = fp.content_changed(cached, sources)
    if newer:
        fp.make_newer(ws.source_dir, newer, sources)
    if sources != cached:
        fp.save_sources_cache(plan.target_dir / fp.SOURCES_CACHE, sources)
    return sources


def _input_parts(
    plan: BuildPlan,
    facts: HostFacts,
    toolchain_file: Path,
    setup: ColconSetup,
    sources: Mapping[str, fp.FileRecord],
) -> dict[str, str]:
    """Every input of the build, each as a digest: equal parts, equal build."""
    ws = plan.workspace
    ninja = colcon.ninja_program(setup.env)
    parts = content_parts(plan, fp.tree_digest(sources))
    return {
        **parts,
        "toolchain file": fp.file_sha256(toolchain_file),
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
            # uros's own code by content (a development checkout changes without a version), read
            # once a run for the build key too: its files' stat was another walk of them
            fp.uros_code_digest(),
        ),
        "dev_ws": fp.digest(ws.dev_built_from(), fp.stat_key(ws.dev_marker)),
        **colcon_parts(facts, setup),
    }


def colcon_parts(facts: HostFacts, setup: ColconSetup) -> dict[str, str]:
    """The colcon command (without what does not change its result: progress output, workers)
    and the environment variables that reach the objects; the host stage's packages, and what
    their files came from (their sources are in "sources")."""
    stable = colcon.colcon_argv(
        dataclasses.replace(setup.plan, verbose=False, parallel_workers=None), facts.colcon
    )
    env = {
        k: v
        for k, v in setup.env.items()
        if k in _ENV_THAT_MATTERS
        or k in colcon.FINGERPRINTED_VARIABLES
        or (
            k.startswith(("GIT_CONFIG_", *colcon.FINGERPRINTED_PREFIXES))
            and k not in colcon.UNFINGERPRINTED_VARIABLES
        )
    }
    return {
        "colcon": fp.digest_json([stable, sorted(env.items())]),
        "host stage": fp.digest(setup.stage.key if setup.stage and setup.shared else "", *setup.shared),
    }


def _output_intact(output: Path, state: fp.BuildState) -> bool:
    """The output folder is what the recorded build wrote (its build-info.json names the
    library's sha256, and every file is as written)."""
    try:
        info = read_build_info(output)
    except ConfigError:
        return False
    return fp.output_intact(state, output, info.library.file, info.library.sha256, owned_entries(output))


def flags_fingerprint(parts: Mapping[str, str]) -> str:
    """What every package of the target is compiled with: the toolchain file, the compiler and
    colcon's CMake arguments (a package's own colcon.meta entry is added per package)."""
    return fp.digest(parts["toolchain file"], parts["compiler"], parts["colcon"])


@dataclass(frozen=True)
class Inputs:
    """What this build is made of (a new record, never an edit, when the host stage or colcon's run
    tell more: :func:`with_colcon`, :func:`with_outside_headers`)."""

    toolchain_file: Path  # the rendered one (the build key's); colcon gets its seeded form
    parts: Mapping[str, str]  # every input as a digest (the fingerprint's parts)
    previous: fp.BuildState | None  # the last good build's state
    state_path: Path
    key: str  # the portable build key


def resolve(
    ctx: Context,
    toolchain_file: Path,
    setup: ColconSetup,
    sources: Mapping[str, fp.FileRecord],
    outside_headers: str,
) -> Inputs:
    """Every input as a digest (``outside_headers``: the headers read outside the workspace, as
    prepare found them), the last good build's state, the build key."""
    plan, facts = ctx.plan, ctx.facts
    parts = _input_parts(plan, facts, toolchain_file, setup, sources)
    parts["headers outside the workspace"] = outside_headers
    state_path = plan.target_dir / fp.STATE
    key = build_key(ctx, toolchain_file, parts)
    return Inputs(toolchain_file, parts, fp.read_state(state_path), state_path, key)


def with_colcon(ctx: Context, inputs: Inputs, setup: ColconSetup) -> Inputs:
    """``inputs`` with colcon's command as ``setup`` has it now (the host stage may share fewer
    packages than expected); the build key stays the one the team cache was asked for."""
    return dataclasses.replace(inputs, parts={**inputs.parts, **colcon_parts(ctx.facts, setup)})


def with_outside_headers(inputs: Inputs, digest: str) -> Inputs:
    """``inputs`` with the headers outside the workspace that colcon's run read (their digest)."""
    return dataclasses.replace(inputs, parts={**inputs.parts, "headers outside the workspace": digest})


def up_to_date(ctx: Context, inputs: Inputs, repaired: bool) -> bool:
    """No input changed since the last good build and its output is as written (else say what
    changed). A repair changed the trees the state vouches for: never up to date then."""
    plan = ctx.plan
    previous = inputs.previous
    if previous is None or plan.rebuild or repaired:
        return False
    changed = changes(previous, inputs.parts, complete=True)
    if not changed and previous.fingerprint == fp.combine(inputs.parts):
        console.step(f"up to date: {plan.output} (no input changed since its build; --rebuild forces one)")
        return True
    console.info(f"changed since the last build: {', '.join(changed)}")
    return False


# ---------------------------------------------------------------------------------------------
# what the next build would see changed, asked without building (uros doctor)


def output_changes(ws: Workspace, key: str) -> list[str] | None:
    """What changed since the target's last good build among the inputs that are the workspace's
    alone, judged as `uros build` judges them (steps.inputs.changes), by content, with the extra
    packages as the build's sync will copy them in. Reads the build's stat cache to hash only what
    changed; writes nothing and touches no mtime."""
    state = fp.read_state(ws.target_dir(key) / fp.STATE)
    if state is None:
        return None
    sources, _ = scan_sources(ws, ws.target_dir(key), Path(state.output))
    extras = _extra_packages(ws)
    synced = as_synced(sources, {prefix: files for prefix, (_, files) in extras.items()})
    parts = workspace_parts(ws, fp.tree_digest(synced))
    changed = changes(state, parts, complete=False)
    moved = [f"extra package {prefix.rsplit('/', 1)[-1]} ({src})" for prefix, (src, _) in extras.items()
             if _under(sources, prefix) != _under(synced, prefix)]  # fmt: skip
    if moved and "sources" in changed:
        changed[changed.index("sources")] = f"sources ({', '.join(moved)} changed)"
    return changed


def rtos_change(out: Path) -> str | None:
    """The RTOS headers a library was compiled against (build-info.json's ``rtos``: the kernel's,
    the port's and FreeRTOSConfig.h), when their content now differs from its ``headers_sha256``:
    what the next build sees as a changed input (the headers' folders may come from uros.yaml or
    from the command line, which doctor does not know, so the record's folders are read)."""
    try:
        info = read_build_info(out, "OUTPUT")
    except UrosError:
        return None
    rtos = info.rtos
    if rtos is None:
        return None
    try:
        now = recorded_digest(rtos.kernel, rtos.port, rtos.config)
    except OSError:
        now = ""
    if now == rtos.headers_sha256:
        return None
    return f"the FreeRTOS headers ({CONFIG_HEADER} in {rtos.config}, the kernel's or the port's)"


def _under(records: Mapping[str, fp.FileRecord], prefix: str) -> dict[str, str]:
    return {rel: r.sha256 for rel, r in records.items() if rel.startswith(prefix + "/")}


def as_synced(
    sources: Mapping[str, fp.FileRecord], extras: Mapping[str, Mapping[str, fp.FileRecord]]
) -> dict[str, fp.FileRecord]:
    """The sources as the next build sees them (pure): the copy of each extra package (``extras``:
    its folder in the sources -> the files of the package's own folder) replaced by what the
    build's sync copies in (workspace.sync_tree: everything but names starting with .git)."""
    out = {rel: r for rel, r in sources.items() if not any(rel.startswith(p + "/") for p in extras)}
    for prefix, files in extras.items():
        for rel, record in files.items():
            if not any(part.startswith(".git") for part in rel.split("/")):
                out[f"{prefix}/{rel}"] = record
    return out


def _extra_packages(ws: Workspace) -> dict[str, tuple[Path, dict[str, fp.FileRecord]]]:
    """uros.yaml's extra packages that the next build copies in: their copy's folder in the
    sources -> (their own folder, its files). One gone, or not a package, is left as the build
    leaves it (it keeps the copy, or stops with its own message)."""
    try:
        cfg = load_config(ws.root)
    except UrosError:
        return {}
    found: dict[str, tuple[Path, dict[str, fp.FileRecord]]] = {}
    for entry in cfg.extra_packages if cfg else ():
        src = Path(entry)
        try:
            name = check_extra_package(src, "extra_packages")
        except UrosError:
            continue
        copy = ws.extra_dir / name
        if copy.is_relative_to(ws.source_dir):
            found[copy.relative_to(ws.source_dir).as_posix()] = (src, fp.scan_tree(src, {}))
    return found
