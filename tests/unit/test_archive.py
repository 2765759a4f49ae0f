"""The archive merge's pure parts, over real tool output (tests/unit/data/archive-*, LC_ALL=C).

libfx_core.a (core.c.obj, util.c.obj), libfx_util.a (util.c.obj, scale.c.obj) and libfx_dup.a
(three common.c.obj from three folders, one defining a weak symbol, with an empty.c.obj without
symbols and a util.c.obj with a common symbol between them), built with arm-none-eabi-gcc 12;
``*.ar-t.txt`` is ``arm-none-eabi-ar t``, ``*.nm.txt`` is GNU nm 2.40
``-g --defined-only --format=posix`` (``lib.a[member]:`` headers), ``archive-fx_dup.llvm-nm.txt``
the same from llvm-nm 14 (``member:`` headers after a blank line). ``archive-merged.*`` is the
libmicroros.a that merge_archives made of the three.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import cast

import pytest

from uros_build.errors import VerifyError
from uros_build.output import archive, symbols
from uros_build.output.archive import ArchiveContents, ArchiveListing
from uros_build.proc import Runner
from uros_build.target.toolsearch import BinTools

DATA = Path(__file__).parent / "data"
INPUTS = ("libfx_core.a", "libfx_dup.a", "libfx_util.a")


def _text(name: str) -> str:
    return (DATA / name).read_text(encoding="utf-8")


def _ar_t(text: str) -> tuple[str, ...]:
    """``ar t`` output (the recorded listings in data/) -> member names in archive order."""
    return tuple(line for line in text.splitlines() if line.strip())


def _contents(stem: str) -> ArchiveContents:
    return ArchiveContents(
        _ar_t(_text(f"archive-{stem}.ar-t.txt")),
        archive.parse_defined_globals(_text(f"archive-{stem}.nm.txt")),
    )


def _listings() -> list[ArchiveListing]:
    return [ArchiveListing(Path("/ws/install/lib") / name, _contents(name[3:-2]).members) for name in INPUTS]


# --- the recorded listings --------------------------------------------------------------------


def test_the_recorded_listing_keeps_every_same_named_member_in_order() -> None:
    assert _ar_t(_text("archive-fx_dup.ar-t.txt")) == (
        "common.c.obj",
        "empty.c.obj",
        "common.c.obj",
        "util.c.obj",
        "common.c.obj",
    )


# --- parse_defined_globals -------------------------------------------------------------------

FX_DUP_SYMBOLS = Counter(
    {
        "common_one": 1,
        "shared_data": 1,
        "common_two": 1,
        "weak_hook": 1,  # W: weak definitions count, a merge must keep them too
        "util_buffer": 1,  # C: a common symbol
        "util_call": 1,
        "common_three": 1,
    }
)


def test_parse_defined_globals_gnu_headers_with_brackets() -> None:
    # libfx_dup.a[empty.c.obj]: is a header with no symbol lines after it
    assert archive.parse_defined_globals(_text("archive-fx_dup.nm.txt")) == FX_DUP_SYMBOLS


def test_parse_defined_globals_bare_member_headers_read_the_same() -> None:
    assert archive.parse_defined_globals(_text("archive-fx_dup.llvm-nm.txt")) == FX_DUP_SYMBOLS


def test_parse_defined_globals_counts_a_symbol_once_per_member_that_defines_it() -> None:
    text = "lib.a[a.o]:\nf T 0 4\nlib.a[b.o]:\nf T 0 4\nlib.a[c.o]:\n"
    assert archive.parse_defined_globals(text) == Counter({"f": 2})


def test_parse_defined_globals_odd_lines() -> None:
    text = (
        "my lib.a[odd name.o]:\n"  # spaces in a header: still a header, not a symbol
        "x T y.o:\n"  # a member called "x T y.o": it ends with ':', so a header
        "abs_sym A 10\n"  # no size
        "bare_sym T\n"  # neither value nor size
        "weak_obj V 8 4\n"
    )
    assert archive.parse_defined_globals(text) == Counter({"abs_sym": 1, "bare_sym": 1, "weak_obj": 1})
    assert archive.parse_defined_globals("") == Counter()


# --- plan_merge ------------------------------------------------------------------------------


def test_plan_merge_names_every_member_uniquely_in_output_order() -> None:
    plan = archive.plan_merge(_listings())
    assert plan.output_names == (
        "libfx_core__core.c.obj",
        "libfx_core__util.c.obj",
        "libfx_dup__1_common.c.obj",
        "libfx_dup__empty.c.obj",
        "libfx_dup__2_common.c.obj",
        "libfx_dup__util.c.obj",
        "libfx_dup__3_common.c.obj",
        "libfx_util__util.c.obj",
        "libfx_util__scale.c.obj",
    )
    # the same names ar t lists in the library merge_archives made of these three
    assert plan.output_names == _ar_t(_text("archive-merged.ar-t.txt"))
    assert plan.renamed_duplicates == 3
    assert len(set(plan.output_names)) == len(plan.members)  # no member overwrites another


def test_plan_merge_takes_each_member_by_its_place_in_its_archive() -> None:
    plan = archive.plan_merge(_listings())
    third = plan.members[6]
    assert (third.member, third.position, third.instance, third.duplicate) == ("common.c.obj", 4, 3, True)
    assert third.output == "libfx_dup__3_common.c.obj"
    util = plan.members[5]
    assert (util.position, util.output, util.duplicate) == (3, "libfx_dup__util.c.obj", False)


def test_plan_merge_numbers_every_instance_of_a_repeated_name() -> None:
    plan = archive.plan_merge(
        [ArchiveListing(Path("libm.a"), ("a.o", "b.o", "a.o", "b.o", "b.o"))]  # only repeated names
    )
    assert plan.output_names == ("libm__1_a.o", "libm__1_b.o", "libm__2_a.o", "libm__2_b.o", "libm__3_b.o")
    assert [(m.position, m.instance) for m in plan.members] == [(0, 1), (1, 1), (2, 2), (3, 2), (4, 3)]


def test_plan_merge_makes_names_safe_and_skips_empty_archives() -> None:
    plan = archive.plan_merge(
        [ArchiveListing(Path("libempty.a"), ()), ArchiveListing(Path("libx y.a"), ("odd name.o",))]
    )
    assert plan.output_names == ("libx_y__odd_name.o",)
    assert [(m.archive, m.position) for m in plan.members] == [(Path("libx y.a"), 0)]
    assert plan.renamed_duplicates == 0


def test_plan_merge_two_archives_with_one_stem_collide() -> None:
    with pytest.raises(VerifyError) as err:
        archive.plan_merge(
            [ArchiveListing(Path("lib a.a"), ("x.o",)), ArchiveListing(Path("lib_a.a"), ("x.o",))]
        )
    assert (
        err.value.message
        == "lib a.a(x.o) and lib_a.a(x.o) would both be named lib_a__x.o in the merged library"
    )
    assert err.value.exit_code == 5


def test_plan_merge_member_named_like_an_instance_collides() -> None:
    with pytest.raises(
        VerifyError, match=r"libq.a\(x.o\) #2 and libq.a\(2_x.o\) would both be named libq__2_x.o"
    ):
        archive.plan_merge([ArchiveListing(Path("libq.a"), ("x.o", "x.o", "2_x.o"))])


# --- verify_merge ----------------------------------------------------------------------------


def _inputs() -> list[ArchiveContents]:
    return [_contents(name[3:-2]) for name in INPUTS]


def test_verify_merge_passes_on_the_real_merge() -> None:
    archive.verify_merge(_inputs(), _contents("merged"), Path("/ws/merge"))


def test_verify_merge_fails_when_a_member_is_lost() -> None:
    merged = _contents("merged")
    # what ar x into one folder gives: one common.c.obj where there were three
    lost = ArchiveContents(
        (*(m for m in merged.members if "_common" not in m), "libfx_dup__common.c.obj"),
        merged.symbols - Counter({"common_one": 1, "shared_data": 1, "common_two": 1, "weak_hook": 1}),
    )
    with pytest.raises(VerifyError) as err:
        archive.verify_merge(_inputs(), lost, Path("/ws/merge"))
    assert err.value.message == "libmicroros.a has 7 members but its inputs have 9"
    assert err.value.hint == "the merge lost objects; the work folder /ws/merge is kept for inspection"
    assert err.value.exit_code == 5


def test_verify_merge_names_up_to_five_missing_symbols() -> None:
    expected = [ArchiveContents(("a.o",), Counter({f"s{i}": 1 for i in range(7)} | {"kept": 1}))]
    actual = ArchiveContents(("x__a.o",), Counter({"kept": 1}))
    with pytest.raises(VerifyError) as err:
        archive.verify_merge(expected, actual, Path("/ws/merge"))
    assert err.value.message == "libmicroros.a lacks defined symbols its inputs have: s0, s1, s2, s3, s4"
    assert err.value.hint == "the work folder /ws/merge is kept for inspection"


def test_verify_merge_fails_when_a_symbol_is_defined_fewer_times() -> None:
    expected = [ArchiveContents(("a.o",), Counter({"f": 1})), ArchiveContents(("a.o",), Counter({"f": 1}))]
    with pytest.raises(VerifyError, match=r"lacks defined symbols its inputs have: f$"):
        archive.verify_merge(expected, ArchiveContents(("1", "2"), Counter({"f": 1})), Path("w"))


def test_verify_merge_fails_on_extra_symbols_too() -> None:
    expected = [ArchiveContents(("a.o",), Counter({"f": 1}))]
    with pytest.raises(VerifyError, match=r"inputs have: \(counts differ\)"):
        archive.verify_merge(expected, ArchiveContents(("x__a.o",), Counter({"f": 1, "g": 1})), Path("w"))


# --- merge_archives, over a runner that starts nothing ---------------------------------------


def ar_bytes(names: Sequence[str], symbol_table: bool = True, bodies: Sequence[bytes] = ()) -> bytes:
    """A GNU ar archive holding members of these names (long names through the // table), as
    GNU ar writes it; each member's content from ``bodies`` (default ``obj``)."""

    def header(name: bytes, size: int) -> bytes:
        return (
            name.ljust(16)
            + b"0".ljust(12)
            + b"0".ljust(6)
            + b"0".ljust(6)
            + b"644".ljust(8)
            + (str(size).encode().ljust(10))
            + b"`\n"
        )

    out = bytearray(b"!<arch>\n")
    if symbol_table:
        out += header(b"/", 4) + b"\0\0\0\0"
    table = bytearray()
    refs = []
    for name in names:
        raw = name.encode()
        if len(raw) > 15:
            refs.append(b"/" + str(len(table)).encode())
            table += raw + b"/\n"
        else:
            refs.append(raw + b"/")
    if table:
        out += header(b"//", len(table)) + table + (b"\n" if len(table) % 2 else b"")
    for i, ref in enumerate(refs):
        body = bodies[i] if bodies else b"obj"
        out += header(ref, len(body)) + body + (b"\n" if len(body) % 2 else b"")
    return bytes(out)


class FakeRunner:
    """Answers nm from the fixtures and does what ar qcsD would to the files."""

    def __init__(self, lose: str | None = None) -> None:
        self.calls: list[list[str]] = []
        self.lose = lose  # a member the written library leaves out

    def query(self, argv: Sequence[str], *, step: str, cwd: Path | None = None) -> str:
        self.calls.append(list(argv))
        assert argv[1:4] == ["-g", "--defined-only", "--format=posix"]
        texts = []
        for path in argv[4:]:
            name = Path(path).name
            stem = name[3:-2] if name in INPUTS else "merged"
            texts.append(_text(f"archive-{stem}.nm.txt"))
        return "".join(texts)

    def run(
        self, argv: Sequence[str], *, step: str, cwd: Path | None = None, quiet: bool = False
    ) -> list[str]:
        self.calls.append(list(argv))
        assert cwd is not None and argv[1] == "qcsD"
        rsp = (cwd / argv[3].removeprefix("@")).read_text(encoding="utf-8").split()
        assert rsp == list(_ar_t(_text("archive-merged.ar-t.txt")))
        kept = [name for name in rsp if name != self.lose]
        Path(argv[2]).write_bytes(ar_bytes(kept, bodies=[(cwd / name).read_bytes() for name in kept]))
        return []


TOOLS = BinTools(ar="ar", ranlib="ranlib", nm="nm")


def _lib(tmp_path: Path) -> list[Path]:
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in reversed(INPUTS):  # merge_archives sorts them by name
        members = _contents(name[3:-2]).members
        bodies = [f"{name}:{i}:{m}".encode() for i, m in enumerate(members)]  # odd and even sizes
        (lib / name).write_bytes(ar_bytes(members, bodies=bodies))
    return [lib / name for name in reversed(INPUTS)]


def test_merge_archives_process_count(tmp_path: Path) -> None:
    runner = FakeRunner()
    libs = _lib(tmp_path)
    report = archive.merge_archives(
        cast(Runner, runner), TOOLS, libs, tmp_path / "libmicroros.a", tmp_path / "merge"
    )
    assert report == archive.MergeReport(inputs=INPUTS, members=9, symbols=11, renamed_duplicates=3)
    # one nm over the 3 archives (their members are read from the files), one ar qcsD (with the
    # index), one nm of the output
    assert [c[:2] for c in runner.calls] == [["nm", "-g"], ["ar", "qcsD"], ["nm", "-g"]]
    assert runner.calls[0][4:] == [str(p.resolve()) for p in sorted(libs)]
    assert not (tmp_path / "merge").exists()


def test_the_merge_finds_duplicates_in_the_nm_run_it_already_makes(tmp_path: Path) -> None:
    class TwinRunner(FakeRunner):
        """fx_core's core.c.obj and fx_util's scale.c.obj both define ``twin``."""

        def query(self, argv: object, *, step: str, cwd: Path | None = None) -> str:
            text = super().query(argv, step=step, cwd=cwd)  # type: ignore[arg-type]
            for line in ("fx_core_add T 0 4\n", "fx_util_scale T 0 10\n"):
                text = text.replace(line, line + "twin T 0 4\n")
            return text

    runner = TwinRunner()
    report = archive.merge_archives(
        cast(Runner, runner), TOOLS, _lib(tmp_path), tmp_path / "libmicroros.a", tmp_path / "merge"
    )
    assert report.duplicates == (
        symbols.Duplicate("twin", ("libfx_core__core.c.obj", "libfx_util__scale.c.obj")),
    )
    assert [c[:2] for c in runner.calls] == [["nm", "-g"], ["ar", "qcsD"], ["nm", "-g"]]  # no extra run


# --- parse_ar: the member table read from the archive itself ----------------------------------


@pytest.mark.parametrize("stem", ["fx_core", "fx_dup", "fx_util", "merged"])
def test_parse_ar_lists_what_ar_t_lists(stem: str) -> None:
    import io

    names = _ar_t(_text(f"archive-{stem}.ar-t.txt"))
    assert archive.parse_ar(io.BytesIO(ar_bytes(names)), stem) == names
    assert archive.parse_ar(io.BytesIO(ar_bytes(names, symbol_table=False)), stem) == names


def test_parse_ar_bsd_names_and_symbol_table() -> None:
    import io

    def member(name: bytes, body: bytes) -> bytes:
        size = len(body)
        head = name.ljust(16) + b"0".ljust(12) + b"0".ljust(6) + b"0".ljust(6) + b"644".ljust(8)
        return head + str(size).encode().ljust(10) + b"`\n" + body + (b"\n" if size % 2 else b"")

    data = (
        b"!<arch>\n"
        + member(b"#1/20", b"__.SYMDEF SORTED\0\0\0\0")
        + member(b"#1/36", b"a_long_name_with spaces_in_it.c.obj" + b"\0")
        + member(b"short.o", b"x")
    )
    assert archive.parse_ar(io.BytesIO(data), "bsd") == ("a_long_name_with spaces_in_it.c.obj", "short.o")


@pytest.mark.parametrize(
    "data", [b"", b"!<thin>\n", b"not an archive", b"!<arch>\nshort.o/        0  0 0 644 12345678ZZ"]
)
def test_parse_ar_refuses_what_is_not_an_archive(data: bytes) -> None:
    import io

    with pytest.raises(VerifyError):
        archive.parse_ar(io.BytesIO(data), "x.a")


def test_merge_archives_writes_each_members_own_bytes(tmp_path: Path) -> None:
    libs = _lib(tmp_path)
    archive.merge_archives(cast(Runner, FakeRunner()), TOOLS, libs, tmp_path / "o.a", tmp_path / "m")
    merged = dict(archive.read_member_data(tmp_path / "o.a"))
    # the third common.c.obj of libfx_dup.a is its 5th member; util.c.obj its 4th
    assert merged["libfx_dup__3_common.c.obj"] == b"libfx_dup.a:4:common.c.obj"
    assert merged["libfx_dup__util.c.obj"] == b"libfx_dup.a:3:util.c.obj"
    inputs = sorted(body for lib in libs for _, body in archive.read_member_data(lib))
    assert sorted(merged.values()) == inputs


def test_merge_archives_notices_a_member_the_library_lost(tmp_path: Path) -> None:
    with pytest.raises(VerifyError, match=r"libmicroros.a has 8 members but its inputs have 9"):
        archive.merge_archives(
            cast(Runner, FakeRunner(lose="libfx_dup__empty.c.obj")),
            TOOLS,
            _lib(tmp_path),
            tmp_path / "o.a",
            tmp_path / "m",
        )
    assert (tmp_path / "m").is_dir()  # kept for inspection
