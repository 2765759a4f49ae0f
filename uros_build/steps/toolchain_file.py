"""The toolchain file a build uses: rendered from the target's profile (or the user's own, used
unchanged), its seeded form (CMake's compiler facts found once per target and given to every
configure), and the host stage's (the host compilers' facts, found once per stage).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path

from uros_build import __version__, console
from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import hosttools
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.plan import BuildPlan, ProfileTarget, meta_transport
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.steps.context import Context
from uros_build.steps.prepare import compiler_identity, forget_configured_flags
from uros_build.target.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    ToolchainRequest,
    render_toolchain,
    seed_module_text,
    seeded_toolchain_text,
)

# 2: per-language CMakeDetermine<LANG>Compiler.cmake (1 put every language's facts in the toolchain);
# 3: the archive rules name GCC's LTO plugin (hosttools.archive_plugin)
SEED_FORMAT = "3"


def seeded_toolchain(ctx: Context, toolchain_file: Path, env: Mapping[str, str]) -> Path:
    """The toolchain file colcon passes to every package: the target's, with CMake's compiler facts
    found once per target (and again only when the toolchain, compiler or CMake changes), in colcon's
    environment ``env``. The rendered toolchain file stays what the build key and build-info describe."""
    plan, facts, runner = ctx.plan, ctx.facts, ctx.runner
    if not plan.compiler_seed:  # UROS_COMPILER_SEED=off (config/settings.py)
        return toolchain_file
    identity = (compiler_identity(facts), facts.cmake, facts.cmake_version, str(colcon.generator(env)))
    return seed_compilers(plan.target_dir, toolchain_file, identity, facts.cmake, runner, env)


def host_toolchain(
    plan: BuildPlan, folder: Path, facts: HostFacts, runner: Runner, env: Mapping[str, str]
) -> Path:
    """The host stage's toolchain file: none of its own (CMake takes the host's compilers), with
    the host compilers' facts found once for the stage, as a target's are (each of its packages
    would otherwise identify the host's C and C++ compilers again, ~1 s per configure)."""
    plain = folder / "host-toolchain.cmake"
    write_if_changed(
        plain,
        f"# Written by uros {__version__} build: the host stage compiles nothing for the target; CMake\n"
        "# takes the host's compilers (their facts come from the seed beside this file).\n",
    )
    if not plan.compiler_seed:
        return plain
    compilers = []
    for name in ("cc", "c++"):
        found = shutil.which(name, path=env.get("PATH"))
        real = Path(os.path.realpath(found)) if found else None
        compilers.append(f"{name}={real}:{fp.stat_key(real) if real else ''}")
    identity = (*compilers, facts.cmake, facts.cmake_version, str(colcon.generator(env)))
    return seed_compilers(folder, plain, identity, facts.cmake, runner, env)


def seed_compilers(
    folder: Path,
    toolchain_file: Path,
    identity: tuple[str, ...],
    cmake: str,
    runner: Runner,
    env: Mapping[str, str],
) -> Path:
    """``toolchain_file`` with CMake's compiler facts for it found once (in ``folder``) and given
    to every configure; found again only when the toolchain file or ``identity`` (compilers,
    CMake, generator) changes. ``toolchain_file`` itself when not found."""
    seed = folder / "toolchain-seeded.cmake"
    stamp = folder / "toolchain-seeded.key"
    modules = folder / "compiler-seed"
    # the seed names its folder and the toolchain file: a workspace moved or copied seeds again
    key = fp.digest(SEED_FORMAT, str(folder), str(toolchain_file), fp.file_sha256(toolchain_file), *identity)
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


def write_toolchain(ctx: Context) -> Path:
    """The target's toolchain file: rendered from its profile (written only when it changes), or the
    user's own; a changed one makes every package configure afresh (its flags reach no compile
    otherwise)."""
    plan, facts = ctx.plan, ctx.facts
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
    if write_if_changed(path, render_toolchain(toolchain_request(plan, facts, plan.workspace.root))):
        forget_configured_flags(plan.target_dir / "build")
    return path


def toolchain_request(plan: BuildPlan, facts: HostFacts, root: Path) -> ToolchainRequest:
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
