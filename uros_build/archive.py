"""Merge static libraries into one, keeping every member, and prove it did.

Existing tools do ``ar x`` of each library into one folder, rename, and ``ar rc``: a library that
holds two members of the same name (two ``common.c.obj`` from different source folders, or
test_msgs' msg/ and srv/ types of the same name) keeps only the last, so objects vanish without a
word (12 of 1,093 in a real Humble build). Here every instance is extracted with ``ar xN``, given a
unique name, and the result is checked: the same number of members and the same multiset of
defined global symbols as all inputs together.

Plan, then execute (as in :mod:`uros_build.abi`): :func:`parse_ar` reads an archive's member
table (what ``ar t`` prints, from the file itself), :func:`parse_defined_globals` reads ``nm``
text, :func:`plan_merge` decides every extraction and every output name, :func:`verify_merge`
compares inputs with the output; all are pure. Only :func:`merge_archives` runs commands, and few
of them: one ``nm`` over all inputs at once, per input archive one ``ar x`` (plus one ``ar xN``
per instance number where a name repeats), one ``ar qcsD`` that also writes the index, and one
``nm`` of the output: about 115 processes for real Humble's 111 archives, where one ``ar t``,
``nm`` and ``ar x`` per archive made ~340.
"""

from __future__ import annotations

import os
import re
import shutil
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

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


@dataclass(frozen=True)
class ArchiveListing:
    """An input archive and its members in archive order, as ``ar t`` lists them."""

    path: Path
    members: tuple[str, ...]

    @property
    def name(self) -> str:
        return self.path.name


@dataclass(frozen=True)
class Extraction:
    """One ``ar`` call that extracts ``members`` of ``archive`` into ``folder`` (relative to the
    work folder). Each call gets a folder of its own, so no extraction overwrites another's file."""

    archive: Path
    folder: str
    members: tuple[str, ...]
    # None: plain ``ar x``; N: ``ar xN N``, the Nth member of each given name
    instance: int | None = None
    # ``members`` is the whole archive: ``ar x archive`` without names says the same, shorter
    whole: bool = False


@dataclass(frozen=True)
class PlannedMember:
    """Where one input member comes from and what it is called in the output."""

    archive: Path
    member: str
    instance: int  # 1-based position among the members of this name in its archive
    duplicate: bool  # its name occurs more than once in its archive
    source: str  # the file its extraction leaves, relative to the work folder
    output: str  # its name in the merged library, unique there


@dataclass(frozen=True)
class MergePlan:
    extractions: tuple[Extraction, ...]  # in the order they run
    members: tuple[PlannedMember, ...]  # in output order

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(m.output for m in self.members)

    @property
    def renamed_duplicates(self) -> int:
        return sum(1 for m in self.members if m.duplicate)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name)


_AR_MAGIC = b"!<arch>\n"
_AR_HEADER = 60
# Symbol tables: GNU/SysV "/" and "/SYM64/", BSD "__.SYMDEF[ SORTED]" and its 64-bit forms.
_SYMBOL_TABLES = (b"/", b"/SYM64/")


def parse_ar(stream: BinaryIO, source: str) -> tuple[str, ...]:
    """Member names of an ar archive in archive order, as ``ar t`` lists them (pure over the
    stream): GNU/SysV names (``name/``, long names as ``/offset`` into the ``//`` table) and BSD
    names (``#1/length`` before the data), symbol tables left out
    (https://en.wikipedia.org/wiki/Ar_(Unix)#File_format_details). Reading the table here saves one
    ``ar t`` process per archive."""
    if stream.read(len(_AR_MAGIC)) != _AR_MAGIC:
        raise VerifyError(
            f"{source}: not an ar archive (thin archives are not supported)",
            "the package installed something that is not a static library under lib/",
        )
    names: list[str] = []
    long_names = b""
    while True:
        header = stream.read(_AR_HEADER)
        if not header.strip(b"\n"):
            return tuple(names)
        size_text = header[48:58].strip()
        if len(header) < _AR_HEADER or header[58:60] != b"`\n" or not size_text.isdigit():
            raise VerifyError(f"{source}: a damaged ar archive", "rebuild it: uros build --rebuild")
        size = int(size_text)
        raw = header[:16].rstrip(b" ")
        body = stream.read(size + (size & 1))
        if raw == b"//":
            long_names = body[:size]
        elif raw in _SYMBOL_TABLES or raw.startswith(b"__.SYMDEF"):
            continue
        elif raw.startswith(b"#1/") and raw[3:].isdigit():
            name = body[: int(raw[3:])].rstrip(b"\0")
            if not name.startswith(b"__.SYMDEF"):
                names.append(os.fsdecode(name))
        elif raw.startswith(b"/") and raw[1:].isdigit():
            start = int(raw[1:])
            end = long_names.find(b"\n", start)
            entry = long_names[start : end if end >= 0 else len(long_names)]
            names.append(os.fsdecode(entry.removesuffix(b"/")))
        else:
            names.append(os.fsdecode(raw.removesuffix(b"/")))


def read_members(archive: Path) -> tuple[str, ...]:
    with archive.open("rb") as stream:
        return parse_ar(stream, str(archive))


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
    """Every extraction and every output name, for ``listings`` in the order given (pure).

    Output names are ``<archive stem>__<member>``, and ``<archive stem>__<i>_<member>`` for the
    i-th of several same-named members of one archive: the stem keeps apart the ``util.c.obj`` of
    two libraries, the instance number the two ``common.c.obj`` of one. VerifyError if two members
    would still get one name (``lib a.a`` and ``lib_a.a``; a member literally named ``2_x.o`` next
    to two ``x.o``), before anything is extracted.
    """
    extractions: list[Extraction] = []
    members: list[PlannedMember] = []
    taken: dict[str, str] = {}  # output name -> "archive(member)" that has it, for the error
    for index, listing in enumerate(listings):
        stem = _safe(listing.name.removesuffix(".a"))
        base = f"{index:03d}"
        counts = Counter(listing.members)
        unique = tuple(m for m in listing.members if counts[m] == 1)
        if unique:
            whole = len(unique) == len(listing.members)
            extractions.append(Extraction(listing.path, base, unique, whole=whole))
        # GNU ar applies xN's count to every name given, so one call per instance number takes the
        # i-th copy of all names that repeat at least i times; names in first-appearance order.
        repeated = tuple(dict.fromkeys(m for m in listing.members if counts[m] > 1))
        for instance in range(1, max((counts[m] for m in repeated), default=0) + 1):
            names = tuple(m for m in repeated if counts[m] >= instance)
            extractions.append(Extraction(listing.path, f"{base}.{instance}", names, instance=instance))
        seen: Counter[str] = Counter()
        for member in listing.members:
            seen[member] += 1
            instance = seen[member]
            duplicate = counts[member] > 1
            folder = f"{base}.{instance}" if duplicate else base
            output = f"{stem}__{instance}_{_safe(member)}" if duplicate else f"{stem}__{_safe(member)}"
            where = f"{listing.name}({member})" + (f" #{instance}" if duplicate else "")
            if output in taken:
                raise VerifyError(
                    f"{taken[output]} and {where} would both be named {output} in the merged library",
                    "rename one of the two archives or objects: the merge would lose one of them",
                )
            taken[output] = where
            members.append(
                PlannedMember(listing.path, member, instance, duplicate, f"{folder}/{member}", output)
            )
    return MergePlan(tuple(extractions), tuple(members))


def extraction_argv(ar: str, extraction: Extraction) -> list[str]:
    """The ``ar`` command line of one extraction, run in its folder (pure)."""
    archive = str(extraction.archive)
    if extraction.instance is not None:
        return [ar, "xN", str(extraction.instance), archive, *extraction.members]
    return [ar, "x", archive] if extraction.whole else [ar, "x", archive, *extraction.members]


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


def read_symbols(runner: Runner, tools: BinTools, archives: Sequence[Path], what: str) -> Counter[str]:
    """The defined global symbols of all ``archives`` together, from one ``nm`` run. ``query``
    hands the parser stdout alone, so nm's "no symbols" notes on stderr never reach it."""
    text = runner.query(
        [tools.nm, "-g", "--defined-only", "--format=posix", *map(str, archives)],
        step=f"read symbols of {what}",
    )
    return parse_defined_globals(text)


def merge_archives(
    runner: Runner, tools: BinTools, inputs: list[Path], output: Path, workdir: Path
) -> MergeReport:
    """Merge ``inputs`` (in name order) into ``output`` through ``workdir``, which is kept for
    inspection when the check fails and removed when it passes."""
    ordered = sorted(inputs, key=lambda p: p.name)
    # Absolute paths: every ar runs inside the work folder.
    resolved = [p.resolve() for p in ordered]
    listings = [ArchiveListing(p, read_members(p)) for p in resolved]
    expected = ArchiveContents(
        tuple(m for listing in listings for m in listing.members),
        read_symbols(runner, tools, resolved, f"{len(resolved)} libraries"),
    )
    plan = plan_merge(listings)

    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    for extraction in plan.extractions:
        folder = workdir / extraction.folder
        folder.mkdir()
        what = f" #{extraction.instance}" if extraction.instance is not None else ""
        runner.run(
            extraction_argv(tools.ar, extraction),
            step=f"extract{what} from {extraction.archive.name}",
            cwd=folder,
            quiet=True,
        )
    for planned in plan.members:
        source = workdir / planned.source
        # ar x exits 0 when a named member is not there ("no entry ... in archive" on stderr only).
        if not source.is_file():
            raise VerifyError(
                f"ar did not extract {planned.member} #{planned.instance} of {planned.archive.name}",
                f"the work folder {workdir} is kept for inspection",
            )
        source.rename(workdir / planned.output)
    for extraction in plan.extractions:
        shutil.rmtree(workdir / extraction.folder)

    output.unlink(missing_ok=True)
    # One response file instead of ~1,100 arguments; its names need no quoting (_safe keeps only
    # [A-Za-z0-9_.+-]). s: write the symbol index (no separate ranlib); D: deterministic (zero
    # timestamps and uids).
    listing = workdir / "members.rsp"
    listing.write_text("\n".join(plan.output_names) + "\n", encoding="utf-8")
    target = output.resolve()
    runner.run([tools.ar, "qcsD", str(target), f"@{listing.name}"], step="write libmicroros.a", cwd=workdir)

    result = ArchiveContents(read_members(target), read_symbols(runner, tools, [target], "libmicroros.a"))
    verify_merge([expected], result, workdir)
    shutil.rmtree(workdir)
    return MergeReport(
        inputs=tuple(p.name for p in ordered),
        members=len(result.members),
        symbols=sum(result.symbols.values()),
        renamed_duplicates=plan.renamed_duplicates,
    )
