"""Largest serialized sizes from rosidl's C structs, and the verdicts against MTU x history
(output/msgsize.py). The headers are written in rosidl_generator_c's shape (its typedefs and
``__MAX_SIZE``/``__MAX_STRING_SIZE`` enums), not copied from generated code."""

from __future__ import annotations

from pathlib import Path

from uros_build.output import msgsize
from uros_build.output.msgsize import Limits

HEADER = """
// generated from rosidl_generator_c/resource/idl__struct.h.em
enum
{
  demo__msg__Mixed__names__MAX_SIZE = 2
};
enum
{
  demo__msg__Mixed__names__MAX_STRING_SIZE = 5
};
enum
{
  demo__msg__Mixed__label__MAX_STRING_SIZE = 3
};
typedef struct demo__msg__Mixed
{
  bool flag;
  /// a comment between fields
  double value;
  uint8_t raw[3];
  rosidl_runtime_c__String label;
  rosidl_runtime_c__String__Sequence names;
  demo__msg__Point point;
} demo__msg__Mixed;

typedef struct demo__msg__Mixed__Sequence
{
  demo__msg__Mixed * data;
  size_t size;
  size_t capacity;
} demo__msg__Mixed__Sequence;
"""
POINT = "typedef struct demo__msg__Point\n{\n  int16_t x;\n  int64_t y;\n} demo__msg__Point;\n"


def _tree(tmp_path: Path, extra: str = "") -> Path:
    detail = tmp_path / "include" / "demo" / "msg" / "detail"
    detail.mkdir(parents=True)
    (detail / "mixed__struct.h").write_text(HEADER, encoding="utf-8")
    (detail / "point__struct.h").write_text(POINT, encoding="utf-8")
    if extra:
        (detail / "open__struct.h").write_text(extra, encoding="utf-8")
    return tmp_path / "include"


def test_parse_struct_header_reads_fields_arrays_and_bounds() -> None:
    structs = msgsize.parse_struct_header(HEADER)
    mixed = structs["demo__msg__Mixed"]
    assert [(f.name, f.ctype, f.array) for f in mixed.fields] == [
        ("flag", "bool", None),
        ("value", "double", None),
        ("raw", "uint8_t", 3),
        ("label", "rosidl_runtime_c__String", None),
        ("names", "rosidl_runtime_c__String__Sequence", None),
        ("point", "demo__msg__Point", None),
    ]
    assert mixed.max_size == {"names": 2} and mixed.max_string == {"names": 5, "label": 3}


def test_cdr_sizes_align_each_primitive_and_follow_nested_types(tmp_path: Path) -> None:
    include = _tree(tmp_path)
    sizes = msgsize.message_sizes(include, {"demo": frozenset({"msg/mixed"})})
    # flag 1, value padded to 8 (16), raw 3 (19), label padded to 20: 4 + 3 + 1 (28), names: 4 (32)
    # and each 4 + 5 + 1 (42, padded to 44: 54), point: x 2 (56), y 8 (64)
    assert sizes == [("demo/msg/Mixed", 64, "")]


def test_an_unbounded_field_makes_the_type_unbounded_and_is_named(tmp_path: Path) -> None:
    opened = (
        "typedef struct demo__msg__Open\n{\n  demo__msg__Point at;\n"
        "  rosidl_runtime_c__double__Sequence values;\n} demo__msg__Open;\n"
    )
    include = _tree(tmp_path, opened)
    assert msgsize.message_sizes(include, {"demo": frozenset({"msg/open", "srv/other", "msg/absent"})}) == [
        ("demo/msg/Open", None, "values")
    ]


def test_limits_come_from_the_options_in_force() -> None:
    assert msgsize.limits({}, None) == Limits(
        512, "UCLIENT_CUSTOM_TRANSPORT_MTU", 4, "RMW_UXRCE_STREAM_HISTORY"
    )
    options = {
        "microxrcedds_client": {"UCLIENT_UDP_TRANSPORT_MTU": "1024"},
        "rmw_microxrcedds": {"RMW_UXRCE_STREAM_HISTORY_INPUT": "2", "RMW_UXRCE_STREAM_HISTORY_OUTPUT": "8"},
    }
    assert msgsize.limits(options, "udp") == Limits(
        1024, "UCLIENT_UDP_TRANSPORT_MTU", 8, "RMW_UXRCE_STREAM_HISTORY_OUTPUT"
    )


def test_verdicts_name_the_option_and_a_value_that_fits() -> None:
    lim = msgsize.limits({}, "serial")
    assert lim.best_effort == 500 and lim.reliable() == 2008
    assert msgsize.verdict("t/msg/A", 500, "", lim)[0] is False
    warn, line = msgsize.verdict("t/msg/B", 501, "", lim)
    assert warn and "UCLIENT_SERIAL_TRANSPORT_MTU=513" in line
    assert msgsize.verdict("t/msg/C", 2008, "", lim)[0] is True
    warn, line = msgsize.verdict("t/msg/D", 2009, "", lim)
    # 8 slots of 504 carry 4,024; or 4 slots of ceil(2017 / 4) + 8 = 513
    assert warn and "set RMW_UXRCE_STREAM_HISTORY=8 or UCLIENT_SERIAL_TRANSPORT_MTU=513" in line
    assert lim.reliable(history=8) >= 2009 and lim.reliable(mtu=513) >= 2009 and lim.reliable(mtu=512) < 2009
    warn, line = msgsize.verdict("t/msg/E", None, "data", lim)
    assert not warn and line.startswith("t/msg/E: unbounded (data): a sample over 500 bytes")
