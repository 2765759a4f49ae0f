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
from uros_build.colcon import compilerfacts
from uros_build.colcon import fingerprint as fp
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.files import write_if_changed
from uros_build.proc import Runner
from uros_build.steps.context import Context
from uros_build.steps.prepare import compiler_identity
from uros_build.target.toolchain import (
    seed_module_text,
    seeded_toolchain_text,
)

# 2: per-language CMakeDetermine<LANG>Compiler.cmake (1 put every language's facts in the toolchain);
# 3: the archive rules name GCC's LTO plugin (compilerfacts.archive_plugin)
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
    found = compilerfacts.cmake_compiler_facts(
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
    """The target's toolchain file, as its kind makes it (written only when it changes; a changed
    one makes every package configure afresh: its flags reach no compile otherwise)."""
    return ctx.kind.write_toolchain()
