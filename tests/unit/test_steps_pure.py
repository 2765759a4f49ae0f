"""`uros build`'s steps over a fake runner (tests/unit/fake_runner.py): no process starts."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from fake_runner import FakeRunner

from uros_build.colcon import compilerfacts
from uros_build.colcon import fingerprint as fp
from uros_build.errors import VerifyError
from uros_build.output import includes
from uros_build.steps import inputs, team_cache, toolchain_file

C_FACTS = 'set(CMAKE_C_COMPILER "/usr/bin/arm-none-eabi-gcc")\nset(CMAKE_C_COMPILER_ID "GNU")\n'


def _cmake_writes(langs: tuple[str, ...], archiver: str = "") -> Any:
    """A cmake that, like the real one configuring a project, leaves CMake<LANG>Compiler.cmake
    (and the probe's answers about the archiver, ``archiver``, when given)."""

    def answer(argv: Sequence[str]) -> str:
        build = Path(argv[argv.index("-B") + 1])
        platform = build / "CMakeFiles" / "3.25.1"
        platform.mkdir(parents=True)
        for lang in langs:
            (platform / f"CMake{lang}Compiler.cmake").write_text(C_FACTS.replace("C_", f"{lang}_"))
        (build / "CMakeCache.txt").write_text("CMAKE_EXECUTABLE_FORMAT:INTERNAL=ELF\n")
        if archiver:
            (build / "uros-archiver.txt").write_text(archiver)
        return ""

    return answer


def test_the_compilers_facts_come_from_one_configure(tmp_path: Path) -> None:
    runner = FakeRunner(tmp_path / "log", {"cmake": _cmake_writes(("C", "CXX"))})
    found = compilerfacts.cmake_compiler_facts(
        runner,  # type: ignore[arg-type]
        "cmake",
        tmp_path / "toolchain.cmake",
        tmp_path / "scratch",
        "Ninja",
        {},
    )
    assert found is not None and set(found.languages) == {"C", "CXX"}
    assert 'set(CMAKE_CXX_COMPILER_ID "GNU")' in found.languages["CXX"]
    assert found.executable_format == "ELF"  # identification's cache entry, kept for the seed
    argv = runner.calls[0]
    assert f"-DCMAKE_TOOLCHAIN_FILE={tmp_path / 'toolchain.cmake'}" in argv and "-GNinja" in argv
    assert not (tmp_path / "scratch").exists()  # the probe project is gone afterwards


def test_the_archive_plugin_is_gccs_own_when_the_archiver_is_gnu_ar(tmp_path: Path) -> None:
    plugin = tmp_path / "liblto_plugin.so"
    plugin.write_bytes(b"")
    gnu = f"{plugin}\nGNU ar (GNU Binutils for Debian) 2.40\nCopyright (C) 2023\n"
    runner = FakeRunner(tmp_path / "log", {"cmake": _cmake_writes(("C", "CXX"), gnu)})
    args = ("cmake", tmp_path / "t.cmake", tmp_path / "s", None, {})
    found = compilerfacts.cmake_compiler_facts(runner, *args)  # type: ignore[arg-type]
    assert found is not None and found.archive_plugin == str(plugin)
    plugin.unlink()  # the compiler named a plugin that is not there: CMake's own rules
    runner = FakeRunner(tmp_path / "log", {"cmake": _cmake_writes(("C", "CXX"), gnu)})
    found = compilerfacts.cmake_compiler_facts(runner, *args)  # type: ignore[arg-type]
    assert found is not None and found.archive_plugin == ""


def test_the_seed_is_found_again_when_its_archive_plugin_is_gone(tmp_path: Path) -> None:
    plugin = tmp_path / "liblto_plugin.so"
    plugin.write_bytes(b"")
    gnu = f"{plugin}\nGNU ar (GNU Binutils for Debian) 2.40\n"
    runner = FakeRunner(tmp_path / "log", {"cmake": _cmake_writes(("C", "CXX"), gnu)})
    toolchain = tmp_path / "toolchain.cmake"
    toolchain.write_text("set(CMAKE_SYSTEM_NAME Generic)\n")
    folder = tmp_path / "target"
    folder.mkdir()

    def seed() -> str:
        found = toolchain_file.seed_compilers(folder, toolchain, ("gcc 1",), "cmake", runner, {})  # type: ignore[arg-type]
        return found.read_text()

    assert f"--plugin {plugin} qcs" in seed() and len(runner.calls) == 1
    assert f"--plugin {plugin} qcs" in seed() and len(runner.calls) == 1  # kept: no configure
    plugin.unlink()  # the seed would name a plugin that is no longer there: found again, without it
    assert "--plugin" not in seed() and len(runner.calls) == 2
    assert "--plugin" not in seed() and len(runner.calls) == 2


def test_archive_plugin_only_for_gnu_ar_and_a_plain_absolute_path() -> None:
    gnu = "\nGNU ar (GNU Binutils) 2.40\n"
    assert compilerfacts.archive_plugin("/usr/lib/gcc/arm-none-eabi/12.2.1/liblto_plugin.so" + gnu) == (
        "/usr/lib/gcc/arm-none-eabi/12.2.1/liblto_plugin.so"
    )
    assert compilerfacts.archive_plugin("liblto_plugin.so" + gnu) == ""  # gcc did not find it: bare name
    assert compilerfacts.archive_plugin("/opt/my tools/liblto_plugin.so" + gnu) == ""  # would need quoting
    assert compilerfacts.archive_plugin("/opt/x;rm/liblto_plugin.so" + gnu) == ""
    llvm = "/usr/lib/gcc/x/liblto_plugin.so\nLLVM (http://llvm.org/):\n  LLVM version 14.0.6\n"
    assert compilerfacts.archive_plugin(llvm) == ""  # llvm-ar: not GNU ar
    assert compilerfacts.archive_plugin("") == "" and compilerfacts.archive_plugin("/a/b.so\n") == ""


def test_without_a_cxx_compiler_there_are_no_facts(tmp_path: Path) -> None:
    runner = FakeRunner(tmp_path / "log", {"cmake": _cmake_writes(("C",))})
    args = ("cmake", tmp_path / "t.cmake", tmp_path / "s", None, {})
    assert compilerfacts.cmake_compiler_facts(runner, *args) is None  # type: ignore[arg-type]
    failing = FakeRunner(tmp_path / "log", {})  # cmake fails: the build goes without the seed
    assert compilerfacts.cmake_compiler_facts(failing, *args) is None  # type: ignore[arg-type]


def _plan(tmp_path: Path, rebuild: bool = False) -> Any:
    return SimpleNamespace(rebuild=rebuild, output=tmp_path / "out", cache=None)


def _ctx(plan: Any, runner: Any = None) -> Any:
    return SimpleNamespace(plan=plan, runner=runner, facts=None)


def _inputs(previous: fp.BuildState | None, parts: dict[str, str]) -> inputs.Inputs:
    return inputs.Inputs(Path("t.cmake"), parts, previous, Path("state.json"), "k" * 64)


def _state(parts: dict[str, str], out: Path, library_sha: str) -> fp.BuildState:
    return fp.BuildState(
        fingerprint=fp.combine(parts),
        parts=parts,
        output=str(out),
        output_files=fp.stat_folder(out),
        library_sha256=library_sha,
        merge_key="",
    )


def test_up_to_date_needs_the_same_inputs_and_the_output_as_written(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "libmicroros.a").write_bytes(b"!<arch>\n")
    sha = fp.file_sha256(out / "libmicroros.a")
    info = {"generated_by": "uros 0", "target": "t", "library": {"file": "libmicroros.a", "sha256": sha}}
    (out / "build-info.json").write_text(json.dumps(info))
    parts = {"sources": "a", "colcon.meta": "b"}
    state = _state(parts, out, sha)
    plan = _plan(tmp_path)
    assert inputs.up_to_date(_ctx(plan), _inputs(state, dict(parts)), repaired=False)
    assert not inputs.up_to_date(_ctx(plan), _inputs(state, dict(parts)), repaired=True)  # a repair: build
    assert not inputs.up_to_date(_ctx(plan), _inputs(None, dict(parts)), repaired=False)  # never built
    assert not inputs.up_to_date(_ctx(plan), _inputs(state, {**parts, "sources": "c"}), repaired=False)
    assert not inputs.up_to_date(
        _ctx(_plan(tmp_path, rebuild=True)), _inputs(state, dict(parts)), repaired=False
    )
    (out / "libmicroros.a").write_bytes(b"!<arch>\nchanged")  # the output is not as written
    assert not inputs.up_to_date(_ctx(plan), _inputs(state, dict(parts)), repaired=False)


def test_no_cache_or_a_rebuild_never_asks_one(tmp_path: Path) -> None:
    runner = FakeRunner(tmp_path / "log")
    assert team_cache.take(_ctx(_plan(tmp_path), runner), "k" * 64, {}) is None
    settings = SimpleNamespace(url=SimpleNamespace(shown="file:///nowhere"))
    plan = SimpleNamespace(rebuild=True, output=tmp_path / "out", cache=settings)
    assert team_cache.take(_ctx(plan, runner), "k" * 64, {}) is None
    assert runner.calls == []


def test_the_include_tree_is_flattened_and_limited_to_the_build(tmp_path: Path) -> None:
    inc = tmp_path / "install" / "include"
    (inc / "rcl" / "rcl").mkdir(parents=True)
    (inc / "rcl" / "rcl" / "node.h").write_text("/* rcl */\n")
    (inc / "std_msgs" / "msg").mkdir(parents=True)
    (inc / "std_msgs" / "msg" / "bool.h").write_text("/* msg */\n")
    (inc / "other").mkdir()
    (inc / "other" / "o.h").write_text("/* not this build's */\n")
    only = frozenset({inc / "rcl" / "rcl" / "node.h", inc / "std_msgs" / "msg" / "bool.h"})
    report = includes.flatten_includes(inc, tmp_path / "out", only=only)
    assert (
        tmp_path / "out" / "rcl" / "node.h"
    ).read_text() == "/* rcl */\n"  # include/<pkg>/<pkg>/ flattened
    assert (tmp_path / "out" / "std_msgs" / "msg" / "bool.h").is_file()
    assert not (tmp_path / "out" / "other" / "o.h").exists()
    assert (report.files, report.packages) == (2, 2)


def test_two_different_headers_for_one_place_are_an_error(tmp_path: Path) -> None:
    """include/pkg/pkg/x.h and a sibling include/pkg/x.h both flatten to include/pkg/x.h: the same
    bytes are one header; different bytes would leave one of them out of the library's tree."""
    inc = tmp_path / "install" / "include"
    (inc / "pkg" / "pkg").mkdir(parents=True)
    (inc / "pkg" / "pkg" / "x.h").write_text("/* nested */\n")
    (inc / "pkg" / "x.h").write_text("/* nested */\n")
    assert includes.flatten_includes(inc, tmp_path / "same").files == 1
    (inc / "pkg" / "x.h").write_text("/* another */\n")
    with pytest.raises(VerifyError, match=r"two different headers flatten to .*/x\.h"):
        includes.flatten_includes(inc, tmp_path / "other")


def test_a_build_waits_out_the_second_of_the_last_install() -> None:
    """CMake's install treats files whose times share a second as up to date: a build that starts
    within the second the last one ended waits for the next second, and never otherwise."""
    from uros_build.steps.colcon_run import next_second_wait

    assert next_second_wait(100.2, 100.5) == pytest.approx(0.52)
    assert next_second_wait(100.99, 100.995) == pytest.approx(0.025)
    assert next_second_wait(100.2, 101.5) == 0.0
    assert next_second_wait(100.2, 250.0) == 0.0
