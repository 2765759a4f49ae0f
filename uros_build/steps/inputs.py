"""What a build is made of: the toolchain file (and its seeded form), the colcon command and
environment (ccache, the Python shim of the generation cache), every input as a digest (the
fingerprint) and the portable build key.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import os
import shutil
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import uros_build
from uros_build import __version__, console
from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import hoststage, hosttools
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.plan import BuildPlan, ProfileTarget, meta_transport
from uros_build.errors import ConfigError, DiskFull, StepFailed
from uros_build.output.buildinfo import (
    read_build_info,
)
from uros_build.proc import Runner
from uros_build.shim import gencache, pyshim
from uros_build.sources import meta as meta_mod
from uros_build.sources import packages as packages_mod
from uros_build.sources.workspace import DEV_MARKER, Workspace
from uros_build.sources.wsfiles import CONFIG, write_if_changed
from uros_build.steps import host_stage
from uros_build.steps.prepare import (
    compiler_identity,
    drop_readers_of_changed_headers,
    forget_configured_flags,
)
from uros_build.target.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    render_toolchain,
    seed_module_text,
    seeded_toolchain_text,
)


@dataclass(frozen=True)
class ColconSetup:
    plan: colcon.ColconPlan
    argv: tuple[str, ...]
    env: Mapping[str, str]
    skipped: tuple[str, ...]  # pure-Python packages left out
    stage: hoststage.Stage | None = None  # the host stage this build takes packages from
    shared: tuple[str, ...] = ()  # the packages it takes from there (colcon skips them)

    @property
    def build_base(self) -> Path:
        return self.plan.build_base

    @property
    def install_base(self) -> Path:
        return self.plan.install_base


def _colcon_setup(
    plan: BuildPlan,
    facts: HostFacts,
    toolchain_file: Path,
    meta_path: Path,
    runner: Runner,
    records: Mapping[str, fp.FileRecord],
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
        python=str(_python_shim(plan, runner, plan.target_dir)),
        generator=colcon.generator(env),
        verbose=plan.verbose,
        packages_up_to=plan.packages_up_to,
        parallel_workers=plan.jobs,
        compiler_launcher=launcher,
    )
    building = building_names(plan, colcon_plan)
    stage = host_stage.stage_for(plan, facts, building, records, env)
    # what the stage shares, as its marker says (or, not built yet, every package it will build):
    # built only when colcon is about to run (ready_host_stage), after the team cache was asked
    shared = host_stage.expected_shares(plan, stage) if stage is not None else ()
    colcon_plan = dataclasses.replace(colcon_plan, packages_skip=shared)
    argv = tuple(colcon.colcon_argv(colcon_plan, facts.colcon))
    return ColconSetup(colcon_plan, argv, env, skipped, stage, shared)


def ready_host_stage(plan: BuildPlan, facts: HostFacts, runner: Runner, inputs: Inputs) -> None:
    """Just before colcon: the host stage built for its key (once), and its packages copied into
    the target's trees, under the stage's lock. Where the stage shares other packages than
    resolve expected (it failed, or a listed package compiled code), the colcon command and the
    fingerprint's parts are made to say so."""
    setup = inputs.setup
    stage = setup.stage
    if stage is None:
        return
    with host_stage.stage_lock(stage):
        found = host_stage.shared_if_built(plan, stage)
        if found is None:
            python = str(_python_shim(plan, runner, stage.folder))
            host_toolchain = _host_toolchain(stage.folder, facts, runner, setup.env)
            building = building_names(plan, setup.plan)
            found = host_stage.build(plan, facts, runner, stage, setup.env, building, python, host_toolchain)
        if found != setup.shared:
            colcon_plan = dataclasses.replace(setup.plan, packages_skip=found)
            argv = tuple(colcon.colcon_argv(colcon_plan, facts.colcon))
            inputs.setup = setup = dataclasses.replace(setup, plan=colcon_plan, argv=argv, shared=found)
            inputs.parts.update(_colcon_parts(facts, setup))
        host_stage.take_into(setup.build_base, setup.install_base, stage, found, plan.workspace.root)


def building_names(plan: BuildPlan, colcon_plan: colcon.ColconPlan) -> set[str]:
    """The packages colcon builds (or skips) for this target: the workspace's, or the closure of
    --packages-up-to, less what the plan ignores."""
    if colcon_plan.packages_up_to:
        names = packages_mod.closure(plan.packages, colcon_plan.packages_up_to)
    else:  # colcon also builds the CMake packages without a package.xml (Micro-CDR, the XRCE client)
        names = {p.name for p in plan.packages} | packages_mod.plain_cmake_packages(plan.workspace.source_dir)
    return colcon.kept_by_ignores(colcon_plan, names)


CCACHE_STATS = "ccache-stats.log"  # this build's ccache counters (the user's totals stay theirs)


def _ccache(plan: BuildPlan, env: Mapping[str, str], runner: Runner) -> str | None:
    """ccache's path when the build compiles through it: --ccache (then it must be installed),
    --no-ccache never, by default when it is on PATH. Only for uros's own toolchain: a user's
    toolchain file does not carry the path maps that keep the library the same under ccache."""
    if plan.ccache is False or not isinstance(plan.target, ProfileTarget):
        return None
    found = (
        runner.which("ccache", path=env.get("PATH"))
        if plan.ccache
        else shutil.which("ccache", path=env.get("PATH"))
    )
    if found is None:
        return None
    try:  # ccache that cannot compile fails every compile: a cache is never why a build fails
        trouble = colcon.ccache_trouble(
            colcon.ccache_settings(
                runner.query([found, "--show-config"], step="ccache --show-config", env=env)
            )
        )
    except (StepFailed, DiskFull) as exc:
        trouble = exc.message
    if trouble:
        console.warn(f"ccache cannot be used ({trouble}): compiling without it (the library is the same)")
        return None
    return found


SEED_SWITCH = "UROS_COMPILER_SEED"  # "off": every package's configure finds the compilers itself
# 2: per-language CMakeDetermine<LANG>Compiler.cmake (1 put every language's facts in the toolchain);
# 3: the archive rules name GCC's LTO plugin (hosttools.archive_plugin)
SEED_FORMAT = "3"


def _seeded_toolchain(
    plan: BuildPlan, facts: HostFacts, toolchain_file: Path, runner: Runner, env: Mapping[str, str]
) -> Path:
    """The toolchain file colcon passes to every package: the target's, with CMake's compiler facts
    found once per target (and again only when the toolchain, compiler or CMake changes). The
    rendered toolchain file stays what the build key and build-info describe."""
    identity = (compiler_identity(facts), facts.cmake, facts.cmake_version, str(colcon.generator(env)))
    return _seed_compilers(plan.target_dir, toolchain_file, identity, facts.cmake, runner, env)


def _host_toolchain(folder: Path, facts: HostFacts, runner: Runner, env: Mapping[str, str]) -> Path:
    """The host stage's toolchain file: none of its own (CMake takes the host's compilers), with
    the host compilers' facts found once for the stage, as a target's are (each of its packages
    would otherwise identify the host's C and C++ compilers again, ~1 s per configure)."""
    plain = folder / "host-toolchain.cmake"
    write_if_changed(
        plain,
        f"# Written by uros {__version__} build: the host stage compiles nothing for the target; CMake\n"
        "# takes the host's compilers (their facts come from the seed beside this file).\n",
    )
    compilers = []
    for name in ("cc", "c++"):
        found = shutil.which(name, path=env.get("PATH"))
        real = Path(os.path.realpath(found)) if found else None
        compilers.append(f"{name}={real}:{fp.stat_key(real) if real else ''}")
    identity = (*compilers, facts.cmake, facts.cmake_version, str(colcon.generator(env)))
    return _seed_compilers(folder, plain, identity, facts.cmake, runner, env)


def _seed_compilers(
    folder: Path,
    toolchain_file: Path,
    identity: tuple[str, ...],
    cmake: str,
    runner: Runner,
    env: Mapping[str, str],
) -> Path:
    """``toolchain_file`` with CMake's compiler facts for it found once (in ``folder``) and given
    to every configure; found again only when the toolchain file or ``identity`` (compilers,
    CMake, generator) changes. ``toolchain_file`` itself when switched off or not found."""
    if os.environ.get(SEED_SWITCH, "").lower() == "off":
        return toolchain_file
    seed = folder / "toolchain-seeded.cmake"
    stamp = folder / "toolchain-seeded.key"
    modules = folder / "compiler-seed"
    key = fp.digest(SEED_FORMAT, fp.file_sha256(toolchain_file), *identity)
    if seed.is_file() and stamp.is_file():
        # the stamp: the key, then the archive plugin the seed names ("" for none): one since
        # removed (the compiler's own files changed without its driver) is found again
        recorded, _, plugin = stamp.read_text(encoding="utf-8").partition("\n")
        if recorded.strip() == key and (not plugin.strip() or os.path.isfile(plugin.strip())):
            return seed
    generator = colcon.generator(env)
    found = hosttools.cmake_compiler_facts(
        runner, cmake, toolchain_file, folder / "compiler-facts", generator, env
    )
    if found is None:
        console.info("CMake could not find the compilers' facts once: each package's configure finds them")
        seed.unlink(missing_ok=True)
        return toolchain_file
    written_by = f"uros {__version__} build"
    modules.mkdir(exist_ok=True)
    for lang, text in found.languages.items():
        module = seed_module_text(lang, text, found.executable_format, written_by)
        write_if_changed(modules / f"CMakeDetermine{lang}Compiler.cmake", module)
    write_if_changed(seed, seeded_toolchain_text(toolchain_file, modules, written_by, found.archive_plugin))
    write_if_changed(stamp, f"{key}\n{found.archive_plugin}\n")
    return seed


SHARE_SWITCH = "UROS_GEN_CACHE"  # "off": every generator run and configure call runs as CMake asks
GEN_CACHE_DIR = "UROS_GEN_CACHE_DIR"


def gen_cache_dir(env: Mapping[str, str]) -> Path:
    """The user's generation and configure-call cache (pyshim.py): $UROS_GEN_CACHE_DIR, else
    uros/gen in the XDG cache folder (~/.cache), beside ccache's own. Shared by every workspace:
    no key or entry holds a workspace's folder."""
    if env.get(GEN_CACHE_DIR):
        return Path(env[GEN_CACHE_DIR]).expanduser()
    base = env.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "uros" / "gen"


def _python_shim(plan: BuildPlan, runner: Runner, folder: Path) -> Path:
    """The Python of the CMake builds of a target (or of the host stage: ``folder``): the real one,
    with rosidl's generator runs and the configures' Python calls going through the workspace's
    caches (shared by every target: pyshim.py), and FindPython's questions about the interpreter
    answered as it answered them once for this build."""
    if os.environ.get(SHARE_SWITCH, "").lower() == "off":
        return Path(colcon.host_python())
    shim = folder / "uros-python"
    python, code_dir = colcon.host_python(), Path(uros_build.__file__).resolve().parent.parent
    try:
        answers, has_distutils = pyshim.parse_answers(
            runner.query(
                pyshim.answers_argv(python, code_dir),
                step="ask Python what CMake will ask it",
                env={**os.environ, **pyshim.STDLIB_DISTUTILS},
            )
        )
    except ValueError:  # not what print_answers prints: every question goes to the interpreter
        answers, has_distutils = {}, False
    text = pyshim.shim_text(
        python,
        gen_cache_dir(os.environ),
        folder,
        plan.workspace.root,
        code_dir,
        f"uros {__version__} build",
        gencache.module_versions(),
        stdlib_distutils=has_distutils,
        answers=answers,
    )
    write_if_changed(shim, text)
    shim.chmod(0o755)
    return shim


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


def scan_sources(
    ws: Workspace, target_dir: Path, out: Path
) -> tuple[dict[str, fp.FileRecord], dict[str, fp.FileRecord]]:
    """The workspace's sources as they are now, and as the target's stat cache last saw them
    (which lets the scan hash only files whose stat changed). Reads only."""
    cached = fp.load_sources_cache(target_dir / fp.SOURCES_CACHE)
    # An --output inside a plain workspace (and its staging folders beside it) is not a source.
    sources = fp.scan_tree(ws.source_dir, cached, (str(out), str(out.parent / f".{out.name}.")))
    return sources, cached


def meta_text(plan: BuildPlan) -> str:
    """The merged colcon.meta as the build writes it."""
    return meta_mod.dump_meta(plan.meta, f"uros build --toolchain {plan.target.key}")


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
    skipped = packages_mod.host_only(list(plan.packages))
    return {
        **workspace_parts(plan.workspace, sources_digest),
        "colcon.meta": fp.digest(meta_text(plan)),
        "profile": fp.digest(repr(plan.profile)),
        # the ESP-IDF project's version, target, include folders, flags and sdkconfig.h hash
        "ESP-IDF project": fp.digest(repr(plan.idf)),
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


def _scan(plan: BuildPlan) -> dict[str, fp.FileRecord]:
    """The workspace's sources now (their stat cache updated, files whose content changed under
    an old mtime made newer, so that CMake and ninja see them)."""
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
    marker = ws.dev_install / DEV_MARKER
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
            _uros_code(),
        ),
        "dev_ws": fp.digest(
            marker.read_text(encoding="utf-8") if marker.is_file() else "", fp.stat_key(marker)
        ),
        **_colcon_parts(facts, setup),
    }


def _colcon_parts(facts: HostFacts, setup: ColconSetup) -> dict[str, str]:
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
        or k.startswith(("GIT_CONFIG_", *colcon.FINGERPRINTED_PREFIXES))
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
    return fp.output_intact(state, output, info.library.file, info.library.sha256)


def flags_fingerprint(parts: Mapping[str, str]) -> str:
    """What every package of the target is compiled with: the toolchain file, the compiler and
    colcon's CMake arguments (a package's own colcon.meta entry is added per package)."""
    return fp.digest(parts["toolchain file"], parts["compiler"], parts["colcon"])


def _prepare_toolchain(plan: BuildPlan, facts: HostFacts) -> Path:
    target = plan.target
    if not isinstance(target, ProfileTarget):
        # The user's own file: its flags, too, reach the compiles only through a fresh configure.
        seen = plan.target_dir / "toolchain-file.sha256"
        if write_if_changed(seen, fp.file_sha256(target.toolchain_file) + "\n"):
            forget_configured_flags(plan.target_dir / "build")
        return target.toolchain_file
    profile = target.profile
    header = plan.target_dir / CLOCK_HEADER_NAME
    if profile.micro_ros.declare_clock_gettime:
        write_if_changed(header, CLOCK_HEADER_TEXT)
    path = plan.target_dir / "toolchain.cmake"
    if write_if_changed(path, render_toolchain(_toolchain_request(plan, facts, plan.workspace.root))):
        forget_configured_flags(plan.target_dir / "build")
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


@dataclass
class Inputs:
    """What this build is made of: the step after resolve reads it, colcon_run adds the headers it
    read outside the workspace to ``parts``."""

    toolchain_file: Path  # the rendered one (the build key's); colcon gets its seeded form
    setup: ColconSetup
    parts: dict[str, str]  # every input as a digest (the fingerprint's parts)
    previous: fp.BuildState | None  # the last good build's state
    state_path: Path
    key: str  # the portable build key


def resolve(plan: BuildPlan, facts: HostFacts, runner: Runner) -> Inputs:
    """The toolchain file and colcon.meta written (only when they change), the colcon command,
    every input as a digest, the last good build's state, the build key."""
    toolchain_file = _prepare_toolchain(plan, facts)
    meta_path = plan.target_dir / "colcon.meta"
    write_if_changed(meta_path, meta_text(plan))
    sources = _scan(plan)
    setup = _colcon_setup(plan, facts, toolchain_file, meta_path, runner, sources)
    outside_digest = drop_readers_of_changed_headers(plan)
    parts = _input_parts(plan, facts, toolchain_file, setup, sources)
    parts["headers outside the workspace"] = outside_digest
    state_path = plan.target_dir / fp.STATE
    key = build_key(plan, facts, toolchain_file, parts)
    return Inputs(toolchain_file, setup, parts, fp.read_state(state_path), state_path, key)


def up_to_date(plan: BuildPlan, inputs: Inputs, repaired: bool) -> bool:
    """No input changed since the last good build and its output is as written (else say what
    changed). A repair changed the trees the state vouches for: never up to date then."""
    previous = inputs.previous
    if previous is None or plan.rebuild or repaired:
        return False
    changed = changes(previous, inputs.parts, complete=True)
    if not changed and previous.fingerprint == fp.combine(inputs.parts):
        console.step(f"up to date: {plan.output} (no input changed since its build; --rebuild forces one)")
        return True
    console.info(f"changed since the last build: {', '.join(changed)}")
    return False
