"""The generation cache (issue 19, item 1) with a stand-in generator script: a generator run is
the same function of its inputs for every target, so the second target's run is a hit that writes
the same bytes; any input's content changes the key; a generator that writes its own folder into
the code is never shared. (The generator runs in-process through runpy: no process is started.)"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from uros_build.shim import gencache, pyshim, shimfile

MODULES = {"empy": "3.3.4", "lark": "1.1.1"}
MODULES_JSON = json.dumps(MODULES, sort_keys=True)  # as uros writes it into the shim
WS = Path("/nowhere/ws")  # the workspace's folder (the tests' targets are elsewhere)

GENERATOR = """
import argparse, json, os, pathlib
parser = argparse.ArgumentParser()
parser.add_argument("--generator-arguments-file", required=True)
parser.add_argument("--typesupports", nargs="*", default=[])
ns = parser.parse_args()
args = json.loads(pathlib.Path(ns.generator_arguments_file).read_text())
out = pathlib.Path(args["output_dir"])
counter = pathlib.Path(os.environ["GEN_COUNTER"])
counter.write_text(counter.read_text() + "x")
for item in args["idl_tuples"]:
    base, _, rel = item.rpartition(":")
    idl = pathlib.Path(base, rel).read_text()
    name = pathlib.Path(rel).stem.lower()
    target = out / "msg" / f"{name}.h"
    target.parent.mkdir(parents=True, exist_ok=True)
    embed = str(out) if "EMBED" in idl else ""
    target.write_text(f"/* from {rel} {' '.join(ns.typesupports)} */ {idl} {embed}\\n")
"""


def _target(root: Path, name: str, idl: str = "struct Bool { boolean data; };") -> tuple[list[str], Path]:
    """A target folder laid out as colcon leaves it before a generator run; returns the argv the
    shim receives and the target folder."""
    target = root / ".uros" / "targets" / name
    script = target / "install" / "lib" / "rosidl_generator_c" / "rosidl_generator_c"
    script.parent.mkdir(parents=True)
    script.write_text(GENERATOR)
    site = target / "install" / "lib" / "python3.11" / "site-packages" / "rosidl_parser"
    site.mkdir(parents=True)
    (site / "__init__.py").write_text("# parser\n")
    adapter = target / "build" / "std_msgs" / "rosidl_adapter"
    (adapter / "msg").mkdir(parents=True)
    (adapter / "msg" / "Bool.idl").write_text(idl)
    arguments = {
        "package_name": "std_msgs",
        "output_dir": str(target / "build" / "std_msgs" / "rosidl_generator_c" / "std_msgs"),
        "idl_tuples": [f"{adapter}:msg/Bool.idl"],
        "target_dependencies": [str(script), str(adapter / "msg" / "Bool.idl")],
    }
    arguments_file = target / "build" / "std_msgs" / "rosidl_generator_c__arguments.json"
    arguments_file.write_text(json.dumps(arguments))
    return [str(script), gencache.ARGUMENTS_FLAG, str(arguments_file), "--typesupports", "a", "b"], target


def _header(target: Path) -> Path:
    return target / "build" / "std_msgs" / "rosidl_generator_c" / "std_msgs" / "msg" / "bool.h"


@pytest.fixture
def counter(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The file the stand-in generator adds an x to on every run."""
    runs = tmp_path / "runs"
    runs.write_text("")
    monkeypatch.setenv("GEN_COUNTER", str(runs))
    return runs


def test_the_second_target_takes_the_first_ones_code(tmp_path: Path, counter: Path) -> None:
    cache = tmp_path / "ws" / ".uros" / "gen-cache"
    argv7, m7 = _target(tmp_path / "ws", "cortex-m7")
    argv4, m4 = _target(tmp_path / "ws", "cortex-m4f")
    assert gencache.is_generator_run(argv7)

    assert gencache.generate(argv7, cache, m7, MODULES_JSON, WS) == "miss"
    assert gencache.generate(argv4, cache, m4, MODULES_JSON, WS) == "hit"
    assert counter.read_text() == "x"  # the generator ran once for both targets
    assert _header(m4).read_bytes() == _header(m7).read_bytes()
    assert _header(m4).read_text().startswith("/* from msg/Bool.idl a b */ struct Bool")

    # a hit over a file already as it should be leaves its time alone (ninja's restat)
    before = _header(m4).stat().st_mtime_ns
    assert gencache.generate(argv4, cache, m4, MODULES_JSON, WS) == "hit"
    assert _header(m4).stat().st_mtime_ns == before

    # another .idl, another generator option, another parser: another key, the generator runs
    (m4 / "build" / "std_msgs" / "rosidl_adapter" / "msg" / "Bool.idl").write_text("struct Bool { int8 d; };")
    assert gencache.generate(argv4, cache, m4, MODULES_JSON, WS) == "miss"
    assert "int8" in _header(m4).read_text()
    assert gencache.generate([*argv7[:4], "a"], cache, m7, MODULES_JSON, WS) == "miss"
    (m7 / "install/lib/python3.11/site-packages/rosidl_parser/__init__.py").write_text("# parser 2\n")
    assert gencache.generate(argv7, cache, m7, MODULES_JSON, WS) == "miss"
    assert counter.read_text() == "xxxx"
    # another package's Python installed meanwhile (colcon's order varies): the same key
    for name in ("micro_ros_utilities", "rosidl_generator_dds_idl"):
        other = m7 / "install/lib/python3.11/site-packages" / name
        other.mkdir()
        (other / "__init__.py").write_text("")
        assert gencache.generate(argv7, cache, m7, MODULES_JSON, WS) == "hit"


def test_code_that_names_its_folder_is_not_shared(tmp_path: Path, counter: Path) -> None:
    cache = tmp_path / "ws" / ".uros" / "gen-cache"
    argv, m7 = _target(tmp_path / "ws", "cortex-m7", idl="EMBED")
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "bypass"
    assert str(_header(m7).parent.parent) in _header(m7).read_text()  # as CMake asked, its own folder
    assert not list(cache.rglob("*.entry"))


def test_the_shim_sends_only_generator_runs_to_the_cache(tmp_path: Path) -> None:
    def shim(stdlib_distutils: bool) -> str:
        return shimfile.shim_text(
            shimfile.Shim(
                "/venv/bin/python3", tmp_path / "c d", tmp_path / "t", tmp_path / "w", Path("/code"),
                "uros 1 build", MODULES, stdlib_distutils=stdlib_distutils,
            )
        )  # fmt: skip

    text = shim(True)
    assert text.startswith("#!/bin/sh\n# Written by uros 1 build")
    assert f"'{tmp_path / 'c d'}'" in text  # quoted for the shell
    assert """'{"empy": "3.3.4", "lark": "1.1.1"}'""" in text  # the versions, found once by uros
    assert text.rstrip().endswith('exec /venv/bin/python3 "$@"')
    # only CMake's FindPython probe gets the standard library's distutils, and only where there is one
    assert "*'from distutils import sysconfig'*)" in text and "SETUPTOOLS_USE_DISTUTILS=stdlib" in text
    assert "SETUPTOOLS_USE_DISTUTILS" not in shim(False)
    # uros's own calls keep their compiled modules in the cache, even under PYTHONDONTWRITEBYTECODE
    # (one shell function: the call, and once more after cut compiled modules are dropped)
    to_uros = [line for line in text.splitlines() if "from uros_build.shim.pyshim import main" in line]
    prefix = f"/venv/bin/python3 -X pycache_prefix='{tmp_path / 'c d' / 'pycache'}'"
    assert [line.strip().partition(" -c ")[0] for line in to_uros] == [
        f"PYTHONDONTWRITEBYTECODE= {prefix}",
        f"PYTHONDONTWRITEBYTECODE= exec {prefix}",
    ], to_uros
    assert text.count('uros "$@"') == 3  # generator runs, ament's calls, rosidl_adapter
    assert pyshim.count_runs("hit a\nmiss b\nhit c\nbypass d\ncall-hit -m rosidl_adapter\n") == {
        "hit": 2,
        "miss": 1,
        "bypass": 1,
        "call-hit": 1,
        "call-miss": 0,
        "call-bypass": 0,
    }


def test_other_generator_module_versions_are_another_key(tmp_path: Path, counter: Path) -> None:
    cache = tmp_path / "ws" / ".uros" / "gen-cache"
    argv, m7 = _target(tmp_path / "ws", "cortex-m7")
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    assert (
        gencache.generate(argv, cache, m7, json.dumps({**MODULES, "empy": "4.0"}, sort_keys=True), WS)
        == "miss"
    )
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "hit"


PARSER = """
import os, pathlib
def parse_idl_string(idl_string, png_file=None):
    counter = pathlib.Path(os.environ["PARSE_COUNTER"])
    counter.write_text(counter.read_text() + "p")
    return {"parsed": idl_string.upper(), "by": VERSION}
def parse_idl_file(path, png_file=None):
    return parse_idl_string(pathlib.Path(path).read_text(), png_file=png_file)
VERSION = 1
"""

PARSING_GENERATOR = """
import json, pathlib, sys
from rosidl_parser.parser import parse_idl_file
args = json.loads(pathlib.Path(sys.argv[2]).read_text())
out = pathlib.Path(args["output_dir"])
for item in args["idl_tuples"]:
    base, _, rel = item.rpartition(":")
    content = parse_idl_file(pathlib.Path(base, rel))
    target = out / (pathlib.Path(sys.argv[0]).name + ".h")
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(f"/* {content} */\\n")
"""


def test_the_idl_parses_of_a_miss_are_remembered(
    tmp_path: Path, counter: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The C generators of a package each parse the same .idl files: a miss keeps what the parser
    made of a text, and the next generator (or target) that parses the same text with the same
    parser takes it. Another text or another parser's code parses again; the output is the same
    as parsing."""
    cache = tmp_path / "ws" / ".uros" / "gen-cache"
    argv, m7 = _target(tmp_path / "ws", "cortex-m7")
    site = m7 / "install/lib/python3.11/site-packages"
    (site / "rosidl_parser" / "parser.py").write_text(PARSER)
    monkeypatch.syspath_prepend(str(site))  # as colcon's PYTHONPATH gives it to a build
    for name in [n for n in sys.modules if n.startswith("rosidl_parser")]:
        monkeypatch.delitem(sys.modules, name)
    parses = tmp_path / "parses"
    parses.write_text("")
    monkeypatch.setenv("PARSE_COUNTER", str(parses))
    generators = []
    for name in ("rosidl_generator_c", "rosidl_typesupport_c", "rosidl_typesupport_introspection_c"):
        script = m7 / "install" / "lib" / name / name
        script.parent.mkdir(parents=True, exist_ok=True)
        script.write_text(PARSING_GENERATOR)
        generators.append([str(script), *argv[1:3]])
    out = m7 / "build" / "std_msgs" / "rosidl_generator_c" / "std_msgs"

    assert [gencache.generate(g, cache, m7, MODULES_JSON, WS) for g in generators] == ["miss"] * 3
    assert parses.read_text() == "p"  # parsed once for three generators
    for g in generators:
        assert (
            out / f"{Path(g[0]).name}.h"
        ).read_text() == "/* {'parsed': 'STRUCT BOOL { BOOLEAN DATA; };', 'by': 1} */\n"
    # the parser as the generator left it: the memo was only for the generator runs
    import rosidl_parser.parser as parser_module  # type: ignore[import-not-found]

    assert parser_module.parse_idl_string.__module__ == "rosidl_parser.parser"

    (m7 / "build/std_msgs/rosidl_adapter/msg/Bool.idl").write_text("struct Bool { int8 d; };")
    assert gencache.generate(generators[0], cache, m7, MODULES_JSON, WS) == "miss"
    assert parses.read_text() == "pp"  # another text
    parser = site / "rosidl_parser" / "parser.py"
    parser.write_text(PARSER.replace("VERSION = 1", "VERSION = 2"))
    # the same size within the same second: a compiled copy of the first (where bytecode is
    # written) would pass Python's check of time and size; an edit a second later does not
    os.utime(parser, ns=(parser.stat().st_atime_ns, parser.stat().st_mtime_ns + 2_000_000_000))
    monkeypatch.delitem(sys.modules, "rosidl_parser.parser")
    assert gencache.generate(generators[1], cache, m7, MODULES_JSON, WS) == "miss"
    assert parses.read_text() == "ppp"  # another parser
    assert "'by': 2" in (out / "rosidl_typesupport_c.h").read_text()


def test_another_workspace_takes_the_same_code(tmp_path: Path, counter: Path) -> None:
    """The cache is the user's: a second checkout (another folder) of the same sources hits."""
    cache = tmp_path / "user-cache"
    argv1, t1 = _target(tmp_path / "ws1", "cortex-m7")
    argv2, t2 = _target(tmp_path / "checkout two", "cortex-m7")
    assert gencache.generate(argv1, cache, t1, MODULES_JSON, tmp_path / "ws1") == "miss"
    assert gencache.generate(argv2, cache, t2, MODULES_JSON, tmp_path / "checkout two") == "hit"
    assert counter.read_text() == "x"
    assert _header(t2).read_bytes() == _header(t1).read_bytes()


def test_an_entry_holds_its_files_and_a_cut_or_foreign_one_is_refused(tmp_path: Path, counter: Path) -> None:
    files = {"a/b.h": b"#pragma once\n", "c.c": b"", "d/e/f.c": b"\x00\xff"}
    data = gencache.pack(files)
    assert gencache.unpack_files(data) == files
    assert gencache.pack(dict(reversed(list(files.items())))) == data  # in name order
    for bad in (data[:-1], data + b"x", b"x" + data, data.replace(b"a/b.h", b"../.h"), b""):
        with pytest.raises(ValueError):
            gencache.unpack_files(bad)
    for name in ("/abs", "a//b", "a/../b", ""):
        with pytest.raises(ValueError):
            gencache.unpack_files(gencache.pack({name: b"x"}))
    with pytest.raises(ValueError):  # an entry could not say it: never kept
        gencache.pack({"a\nb": b"x"})
    header = gencache.ENTRY_MAGIC + b"13 a/b.h\n"  # the list of files cut before its end
    for bad in (header, header.replace(b"13", b"-1") + b"\n", header.replace(b"13 ", b"13") + b"\n"):
        with pytest.raises(ValueError):
            gencache.unpack_files(bad)
    # a cut entry in the cache is a miss: the generator runs and the entry is written whole again
    cache = tmp_path / "cache"
    argv, m7 = _target(tmp_path / "ws", "cortex-m7")
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    (index,) = cache.rglob(f"*{gencache.INDEX}")
    kept = index.read_bytes()
    index.write_bytes(b"")  # an index that names no output folder is not used: a miss
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    assert index.read_bytes() == kept  # written whole again
    (entry,) = cache.rglob("*.entry")
    whole = entry.read_bytes()
    entry.write_bytes(whole[:-2])
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    assert entry.read_bytes() == whole


def test_a_same_size_change_in_a_cached_file_is_a_miss(tmp_path: Path, counter: Path) -> None:
    """An entry's files carry their sha256: a byte changed on disk ("Int32" -> "Int3X", the same
    size) was written into the build; now it is a miss and the entry is written again."""
    data = gencache.pack({"types.c": b'const char *t = "Int32";\n'})
    with pytest.raises(ValueError, match="sha256"):
        gencache.unpack_files(data.replace(b"Int32", b"Int3X"))
    assert gencache.unseal(gencache.seal(b"out\na.idl")) == b"out\na.idl"
    with pytest.raises(ValueError):
        gencache.unseal(gencache.seal(b"out\na.idl").replace(b"a.idl", b"b.idl"))
    cache = tmp_path / "cache"
    argv, m7 = _target(tmp_path / "ws", "cortex-m7")
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    (entry,) = cache.rglob("*.entry")
    whole = entry.read_bytes()
    changed = bytearray(whole)
    changed[-2] ^= 0x01  # the last file's content, same size
    entry.write_bytes(bytes(changed))
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"
    assert entry.read_bytes() == whole
    (index,) = cache.rglob(f"*{gencache.INDEX}")
    index.write_bytes(index.read_bytes().replace(b"<target>", b"<targex>"))  # another output folder
    assert gencache.generate(argv, cache, m7, MODULES_JSON, WS) == "miss"


def test_cut_compiled_modules_are_dropped_and_others_kept(tmp_path: Path) -> None:
    import marshal

    good = b"\0" * 16 + marshal.dumps(compile("x = 1", "m", "exec"))
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "good.cpython-311.pyc").write_bytes(good)
    (tmp_path / "a" / "cut.cpython-311.pyc").write_bytes(good[: len(good) // 2])
    (tmp_path / "a" / "empty.cpython-311.pyc").write_bytes(b"")
    (tmp_path / "a" / "notes.txt").write_bytes(b"")
    assert pyshim.drop_unloadable(str(tmp_path)) == 2
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["good.cpython-311.pyc", "notes.txt"]
    assert pyshim.drop_unloadable(str(tmp_path)) == 0
