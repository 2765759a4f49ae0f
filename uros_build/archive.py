"""Merge static libraries into one, keeping every member, and prove it did.

Existing tools do ``ar x`` of each library into one folder, rename, and ``ar rc``: a library that
holds two members of the same name (two ``common.c.obj`` from different source folders, or
test_msgs' msg/ and srv/ types of the same name) keeps only the last, so objects vanish without a
word (12 of 1,093 in a real Humble build). Here every instance is extracted with ``ar xN``, given a
unique name, and the result is checked: the same number of members and the same multiset of
defined global symbols as all inputs together.
"""

from __future__ import annotations

import re
import shutil
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import VerifyError
from uros_build.proc import Runner


@dataclass(frozen=True)
class BinTools:
    ar: str
    ranlib: str
    nm: str


@dataclass(frozen=True)
class ArchiveContents:
    members: tuple[str, ...]
    symbols: Counter[str]  # defined global symbols, counted per member that defines them


@dataclass(frozen=True)
class MergeReport:
    inputs: tuple[str, ...]
    members: int
    symbols: int
    renamed_duplicates: int


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name)


def list_members(runner: Runner, tools: BinTools, archive: Path) -> tuple[str, ...]:
    lines = runner.run([tools.ar, "t", str(archive)], step=f"list {archive.name}", quiet=True)
    return tuple(line for line in lines if line.strip())


def defined_globals(runner: Runner, tools: BinTools, archive: Path) -> Counter[str]:
    # POSIX format: "name type value size"; member headers end with ':'. nm exits 0 on members
    # without symbols and prints "no symbols" to stderr, which the runner merges: skip those.
    lines = runner.run(
        [tools.nm, "-g", "--defined-only", "--format=posix", str(archive)],
        step=f"read symbols of {archive.name}",
        quiet=True,
    )
    symbols: Counter[str] = Counter()
    for line in lines:
        parts = line.split()
        if len(parts) >= 2 and not line.endswith(":") and len(parts[1]) == 1:
            symbols[parts[0]] += 1
    return symbols


def read_contents(runner: Runner, tools: BinTools, archive: Path) -> ArchiveContents:
    return ArchiveContents(list_members(runner, tools, archive), defined_globals(runner, tools, archive))


def merge_archives(
    runner: Runner, tools: BinTools, inputs: list[Path], output: Path, workdir: Path
) -> MergeReport:
    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    ordered: list[str] = []  # member files in the order they go into the output
    expected_members = 0
    expected_symbols: Counter[str] = Counter()
    renamed = 0
    for index, archive in enumerate(sorted(inputs, key=lambda p: p.name)):
        contents = read_contents(runner, tools, archive)
        expected_members += len(contents.members)
        expected_symbols += contents.symbols
        stem = _safe(archive.name.removesuffix(".a"))
        here = workdir / f"{index:03d}"
        here.mkdir()
        counts = Counter(contents.members)
        runner.run(
            [tools.ar, "x", str(archive.resolve())], step=f"extract {archive.name}", cwd=here, quiet=True
        )
        seen: Counter[str] = Counter()
        for member in contents.members:
            seen[member] += 1
            instance = seen[member]
            if counts[member] == 1:
                source = here / member
            else:
                # ar x keeps only the last same-named member; take each instance by its count.
                inst_dir = here / f"_instance{instance}"
                inst_dir.mkdir(exist_ok=True)
                runner.run(
                    [tools.ar, "xN", str(instance), str(archive.resolve()), member],
                    step=f"extract {member} #{instance} of {archive.name}",
                    cwd=inst_dir,
                    quiet=True,
                )
                source = inst_dir / member
                renamed += 1
            suffix = f"{instance}_" if counts[member] > 1 else ""
            target = workdir / f"{stem}__{suffix}{_safe(member)}"
            if target.exists():
                raise VerifyError(f"two members would both be named {target.name} in {archive}")
            source.rename(target)
            ordered.append(target.name)
        shutil.rmtree(here)
    if output.exists():
        output.unlink()
    # One response file instead of ~1,100 arguments; D: deterministic (zero timestamps and uids).
    listing = workdir / "members.rsp"
    listing.write_text("\n".join(ordered) + "\n", encoding="utf-8")
    runner.run(
        [tools.ar, "qcD", str(output.resolve()), f"@{listing.name}"], step="write libmicroros.a", cwd=workdir
    )
    runner.run(
        [tools.ranlib, "-D", str(output.resolve())], step="index libmicroros.a", cwd=workdir, quiet=True
    )
    result = read_contents(runner, tools, output)
    if len(result.members) != expected_members:
        raise VerifyError(
            f"libmicroros.a has {len(result.members)} members but its inputs have {expected_members}",
            f"the merge lost objects; the work folder {workdir} is kept for inspection",
        )
    if result.symbols != expected_symbols:
        missing = sorted((expected_symbols - result.symbols).elements())[:5]
        raise VerifyError(
            f"libmicroros.a lacks defined symbols its inputs have: {', '.join(missing) or '(counts differ)'}",
            f"the work folder {workdir} is kept for inspection",
        )
    shutil.rmtree(workdir)
    return MergeReport(
        inputs=tuple(p.name for p in sorted(inputs, key=lambda p: p.name)),
        members=len(result.members),
        symbols=sum(result.symbols.values()),
        renamed_duplicates=renamed,
    )
