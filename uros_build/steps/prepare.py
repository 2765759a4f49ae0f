"""The target's trees made fit to build in, before anything is decided: what a killed build left
(running tools, a half swap, configures cut short), a changed compiler (every object again), a full
disk (every configure again), packages the workspace lost, readers of changed outside headers.
"""

from __future__ import annotations

import os
from pathlib import Path

from uros_build import console
from uros_build.colcon import depfiles, installtree, relocate
from uros_build.colcon import fingerprint as fp
from uros_build.colcon.damage import damaged_archives, damaged_configures
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.files import remove_tree, write_if_changed
from uros_build.output import swap
from uros_build.proc import stop_leftovers
from uros_build.sources import packages as packages_mod
from uros_build.steps.context import Context


def compiler_identity(facts: HostFacts) -> str:
    """The target compiler as content, not as a place: its path, version and the sha256 of the
    driver program itself (a replaced or upgraded compiler at the same path is another compiler)."""
    if not facts.gcc:
        return fp.digest("")
    real = Path(os.path.realpath(facts.gcc))
    try:
        content = fp.program_sha256(real)
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
            remove_tree(tree)
    write_if_changed(identity, now + "\n")


DISK_FULL_MARK = "disk-full"


def _reconfigure_after_a_full_disk(plan: BuildPlan) -> None:
    mark = plan.target_dir / DISK_FULL_MARK
    if mark.is_file():
        console.info("the last build ran out of disk space: configuring every package afresh")
        installtree.forget_configured_flags(plan.target_dir / "build")
        mark.unlink()


def drop_readers_of_changed_headers(ctx: Context) -> str:
    """Packages that read a header outside the workspace whose content changed since their build
    (a C library upgrade, a profile's -I folder, an edit restored with an old mtime) are built
    afresh: ninja goes by mtimes, and such a header need not be newer than the objects. Returns
    the digest of those headers' current content, for the fingerprint."""
    plan = ctx.plan
    record = depfiles.read_record(plan.target_dir / depfiles.RECORD)
    changed, digest = depfiles.changed_packages(record)
    existing = [p for p in changed if (plan.target_dir / "build" / p).is_dir()]
    if existing:
        names = ", ".join(existing)
        console.info(f"headers outside the workspace changed since the last build: building {names} afresh")
        for package in existing:
            remove_tree(plan.target_dir / "build" / package)
    return digest


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
    for line in swap.recover(plan.output):
        console.info(line)
        repaired = True
    trees = plan.target_dir
    for path, why in damaged_archives([trees / "install" / "lib", *sorted((trees / "build").glob("*/"))]):
        # ninja builds it again, colcon's install step copies it again
        console.warn(f"{path.name} {why} (a full disk or a crash?): removing {path}")
        remove_tree(path)
        repaired = True
    for folder, why in damaged_configures(plan.target_dir / "build"):
        console.warn(f"{folder.name}: {why} (a full disk or a crash?): configuring it afresh in {folder}")
        remove_tree(folder)
        repaired = True
    return repaired or bool(stopped)


def drop_removed_packages(ctx: Context) -> None:
    """A package the workspace no longer has must leave the target's trees, or its archive and
    headers would ship in the next library."""
    plan = ctx.plan
    build_base, install_base = plan.target_dir / "build", plan.target_dir / "install"
    names = {p.name for p in plan.workspace_packages}
    if installtree.tree_packages(build_base) - names:
        names |= packages_mod.plain_cmake_packages(plan.workspace.source_dir)
    gone = installtree.drop_removed(build_base, install_base, names)
    if gone:
        console.info(f"dropped from the target's trees (no longer in the workspace): {', '.join(gone)}")


def prepare_trees(ctx: Context) -> bool:
    """Under the target's lock, before anything is decided: repair what a killed build left, redo
    what a changed compiler, a full disk or a moved workspace requires. True when a repair changed
    the trees (the recorded state no longer vouches for them)."""
    plan = ctx.plan
    repaired = _repair(plan)
    _redo_what_must_be_redone(plan, ctx.facts)
    _reconfigure_after_a_full_disk(plan)
    moved = relocate.reconfigure_moved(plan.target_dir / "build", f"{plan.target.key}'s build tree")
    return repaired or moved
