"""Merge static libraries into one, keeping every member, and prove it did.

Existing tools do ``ar x`` of each library into one folder, rename, and ``ar rc``: a library that
holds two members of the same name (two ``common.c.obj`` from different source folders, or
test_msgs' msg/ and srv/ types of the same name) keeps only the last, so objects vanish without a
word (12 of 1,093 in a real Humble build). Here every member, each instance of a repeated name
too, is given a unique name, and the result is checked: the same number of members and the same
multiset of defined global symbols as all inputs together.

Plan, then execute (as in :mod:`uros_build.target.abi`): :func:`parse_ar` reads an archive's members
(what ``ar t`` lists and what ``ar x`` writes, from the file itself), :func:`parse_defined_globals`
reads ``nm`` text, :func:`plan_merge` decides every output name, :func:`verify_merge` compares
inputs with the output; all are pure. Only :func:`merge_archives` runs commands, and few of them:
one ``nm`` over all inputs at once, one ``ar qcsD`` that also writes the index, and one ``nm`` of
the output, whose text also says which global symbols two members define (output/symbols.py).
The members are written from the archives' own bytes: one ``ar x`` per archive (and one ``ar xN``
per instance number) cost real Humble 119 processes, about 2 s of every build.
"""

from __future__ import annotations

import re
import shutil
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from uros_build.errors import VerifyError
from uros_build.output import symbols as syms
from uros_build.proc import Runner
from uros_build.target import arfile
from uros_build.target.toolsearch import BinTools


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
    # global symbols two members define (a --whole-archive link fails on them), from the output's nm
    duplicates: tuple[syms.Duplicate, ...] = ()


@dataclass(frozen=True)
class ArchiveListing:
    """An input archive and its members in archive order, as ``ar t`` lists them."""

    path: Path
    members: tuple[str, ...]

    @property
    def name(self) -> str:
        return self.path.name


@dataclass(frozen=True)
class PlannedMember:
    """Where one input member comes from and what it is called in the output."""

    archive: Path
    member: str
    position: int  # its place among its archive's members (0-based, symbol tables not counted)
    instance: int  # 1-based position among the members of this name in its archive
    duplicate: bool  # its name occurs more than once in its archive
    output: str  # its name in the merged library, unique there


@dataclass(frozen=True)
class MergePlan:
    members: tuple[PlannedMember, ...]  # in output order

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(m.output for m in self.members)

    @property
    def renamed_duplicates(self) -> int:
        return sum(1 for m in self.members if m.duplicate)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name)


def parse_ar(stream: BinaryIO, source: str) -> tuple[str, ...]:
    """Member names of an ar archive in archive order, as ``ar t`` lists them (pure over the
    stream). Reading the table here saves one ``ar t`` process per archive."""
    return tuple(name for name, _ in parse_ar_members(stream, source))


def parse_ar_members(stream: BinaryIO, source: str) -> tuple[tuple[str, bytes], ...]:
    """Each member of an ar archive in archive order: its name, as ``ar t`` lists it, and its
    content, the bytes ``ar x`` writes (pure over the stream; the format: target/arfile.py)."""
    try:
        return arfile.members(*arfile.stream_reader(stream))
    except arfile.ArFormatError as exc:
        if exc.kind == "not ar":
            raise VerifyError(
                f"{source}: not an ar archive (thin archives are not supported)",
                "the package installed something that is not a static library under lib/",
            ) from None
        what = "a cut" if exc.kind == "cut" else "a damaged"
        raise VerifyError(f"{source}: {what} ar archive", "rebuild it: uros build --rebuild") from None


def read_members(archive: Path) -> tuple[str, ...]:
    with archive.open("rb") as stream:
        return parse_ar(stream, str(archive))


def read_member_data(archive: Path) -> tuple[tuple[str, bytes], ...]:
    with archive.open("rb") as stream:
        return parse_ar_members(stream, str(archive))


def parse_defined_globals(nm_posix_text: str) -> Counter[str]:
    """``nm -g --defined-only --format=posix`` output over an archive -> how many members define
    each symbol.

    Member headers are ``lib.a[member.o]:`` (GNU nm) or ``member.o:`` (llvm-nm, which also puts a
    blank line before each); symbol lines are ``name TYPE [value [size]]``. A header is the only
    line that ends with ':' (a symbol line ends with its type letter or a hex number), so it is
    told apart first, whatever spaces a path holds. A member without symbols is a header alone.
    """
    symbols: Counter[str] = Counter()
    for line in nm_posix_text.splitlines():
        text = line.rstrip()
        if not text or text.endswith(":"):
            continue
        parts = text.split()
        if 2 <= len(parts) <= 4 and len(parts[1]) == 1:
            symbols[parts[0]] += 1
    return symbols


def plan_merge(listings: Sequence[ArchiveListing]) -> MergePlan:
    """Every output name, for ``listings`` in the order given (pure).

    Output names are ``<archive stem>__<member>``, and ``<archive stem>__<i>_<member>`` for the
    i-th of several same-named members of one archive: the stem keeps apart the ``util.c.obj`` of
    two libraries, the instance number the two ``common.c.obj`` of one. VerifyError if two members
    would still get one name (``lib a.a`` and ``lib_a.a``; a member literally named ``2_x.o`` next
    to two ``x.o``), before anything is written.
    """
    members: list[PlannedMember] = []
    taken: dict[str, str] = {}  # output name -> "archive(member)" that has it, for the error
    for listing in listings:
        stem = _safe(listing.name.removesuffix(".a"))
        counts = Counter(listing.members)
        seen: Counter[str] = Counter()
        for position, member in enumerate(listing.members):
            seen[member] += 1
            instance = seen[member]
            duplicate = counts[member] > 1
            output = f"{stem}__{instance}_{_safe(member)}" if duplicate else f"{stem}__{_safe(member)}"
            where = f"{listing.name}({member})" + (f" #{instance}" if duplicate else "")
            if output in taken:
                raise VerifyError(
                    f"{taken[output]} and {where} would both be named {output} in the merged library",
                    "rename one of the two archives or objects: the merge would lose one of them",
                )
            taken[output] = where
            members.append(PlannedMember(listing.path, member, position, instance, duplicate, output))
    return MergePlan(tuple(members))


def verify_merge(expected: Sequence[ArchiveContents], actual: ArchiveContents, workdir: Path) -> None:
    """VerifyError unless ``actual`` has as many members as all of ``expected`` together and
    the same multiset of defined global symbols (pure; ``workdir`` is only named in the hint)."""
    expected_members = sum(len(c.members) for c in expected)
    expected_symbols: Counter[str] = Counter()
    for contents in expected:
        expected_symbols += contents.symbols
    if len(actual.members) != expected_members:
        raise VerifyError(
            f"libmicroros.a has {len(actual.members)} members but its inputs have {expected_members}",
            f"the merge lost objects; the work folder {workdir} is kept for inspection",
        )
    if actual.symbols != expected_symbols:
        missing = sorted((expected_symbols - actual.symbols).elements())[:5]
        raise VerifyError(
            f"libmicroros.a lacks defined symbols its inputs have: {', '.join(missing) or '(counts differ)'}",
            f"the work folder {workdir} is kept for inspection",
        )


def read_defined_globals(runner: Runner, tools: BinTools, archives: Sequence[Path], what: str) -> str:
    """The defined global symbols of all ``archives`` together as nm text, from one ``nm`` run.
    ``query`` hands the parser stdout alone, so nm's "no symbols" notes on stderr never reach it."""
    return runner.query(
        [tools.nm, "-g", "--defined-only", "--format=posix", *map(str, archives)],
        step=f"read symbols of {what}",
    )


def merge_archives(
    runner: Runner, tools: BinTools, inputs: list[Path], output: Path, workdir: Path
) -> MergeReport:
    """Merge ``inputs`` (in name order) into ``output`` through ``workdir``, which is kept for
    inspection when the check fails and removed when it passes."""
    ordered = sorted(inputs, key=lambda p: p.name)
    # Absolute paths: ar runs inside the work folder.
    resolved = [p.resolve() for p in ordered]
    contents = {p: read_member_data(p) for p in resolved}
    listings = [ArchiveListing(p, tuple(name for name, _ in contents[p])) for p in resolved]
    expected = ArchiveContents(
        tuple(m for listing in listings for m in listing.members),
        parse_defined_globals(read_defined_globals(runner, tools, resolved, f"{len(resolved)} libraries")),
    )
    plan = plan_merge(listings)

    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    for planned in plan.members:
        _, data = contents[planned.archive][planned.position]
        # "x": a second writer of one name would be a planning error, never a silent overwrite
        with (workdir / planned.output).open("xb") as f:
            f.write(data)

    output.unlink(missing_ok=True)
    # One response file instead of ~1,100 arguments; its names need no quoting (_safe keeps only
    # [A-Za-z0-9_.+-]). s: write the symbol index (no separate ranlib); D: deterministic (zero
    # timestamps and uids).
    listing = workdir / "members.rsp"
    listing.write_text("\n".join(plan.output_names) + "\n", encoding="utf-8")
    target = output.resolve()
    runner.run([tools.ar, "qcsD", str(target), f"@{listing.name}"], step="write libmicroros.a", cwd=workdir)

    merged = read_defined_globals(runner, tools, [target], "libmicroros.a")
    result = ArchiveContents(read_members(target), parse_defined_globals(merged))
    verify_merge([expected], result, workdir)
    shutil.rmtree(workdir)
    return MergeReport(
        inputs=tuple(p.name for p in ordered),
        members=len(result.members),
        symbols=sum(result.symbols.values()),
        renamed_duplicates=plan.renamed_duplicates,
        # the same nm text: no other tool run
        duplicates=syms.duplicate_globals(syms.parse_nm(merged, target.name)),
    )
