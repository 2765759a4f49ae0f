"""target/arfile.py: the one ar reader, shared by the merge and the full-disk check."""

from __future__ import annotations

import io

import pytest

from uros_build.target import arfile


def _member(name: bytes, data: bytes) -> bytes:
    head = name.ljust(16) + b"0".ljust(12) + b"0".ljust(6) + b"0".ljust(6) + b"644".ljust(8)
    return head + str(len(data)).encode().ljust(10) + b"`\n" + data + (b"\n" if len(data) % 2 else b"")


GNU = (
    arfile.MAGIC
    + _member(b"/", b"\0\0\0\0")
    + _member(b"//", b"a_name_longer_than_sixteen.c.obj/\n")
    + _member(b"/0", b"long")
    + _member(b"short.o/", b"odd")
)


def _read(data: bytes) -> tuple[arfile.ReadAt, int]:
    return arfile.stream_reader(io.BytesIO(data))


def test_members_names_and_contents_gnu_long_names_and_symbol_table_left_out() -> None:
    assert arfile.members(*_read(GNU)) == (("a_name_longer_than_sixteen.c.obj", b"long"), ("short.o", b"odd"))


def test_entries_read_only_the_headers() -> None:
    reads: list[tuple[int, int]] = []

    def read_at(offset: int, length: int) -> bytes:
        reads.append((offset, length))
        return GNU[offset : offset + length]

    assert [e.field for e in arfile.entries(read_at, len(GNU))] == [b"/", b"//", b"/0", b"short.o/"]
    assert {length for _, length in reads} == {len(arfile.MAGIC), arfile.HEADER}


@pytest.mark.parametrize(
    ("data", "kind"),
    [
        (b"", "not ar"),
        (b"!<thin>\n", "not ar"),
        (GNU[:-3], "cut"),
        (GNU[:70], "cut"),
        (GNU[:40], "broken"),
        (GNU + b"x" * 60, "broken"),
    ],
)
def test_what_is_wrong_is_told_by_kind(data: bytes, kind: str) -> None:
    with pytest.raises(arfile.ArFormatError) as caught:
        arfile.members(*_read(data))
    assert caught.value.kind == kind


def test_the_last_padding_byte_may_be_missing() -> None:
    assert arfile.members(*_read(GNU[:-1]))[-1] == ("short.o", b"odd")
