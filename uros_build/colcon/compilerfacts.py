"""CMake's compiler facts, found once per target (issue 19, item 1): one tiny project configured
with the target's toolchain file tells what CMake finds out about its compilers, and which LTO
plugin the archiver should be named."""

from __future__ import annotations

import re
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import UrosError
from uros_build.proc import Runner

SEED_LANGUAGES = ("C", "CXX")


@dataclass(frozen=True)
class CompilerFacts:
    """What CMake found about a target's compilers in one tiny project."""

    languages: Mapping[str, str]  # language -> the text of CMakeFiles/<version>/CMake<LANG>Compiler.cmake
    executable_format: str  # CMAKE_EXECUTABLE_FORMAT, which identification caches ("" when it did not)
    archive_plugin: str = ""  # GCC's LTO plugin, for GNU ar (:func:`archive_plugin`); "": none


# The probe project also asks the C compiler where its LTO plugin is and the archiver what it is
# (for :func:`archive_plugin`); CMake writes both answers to this file.
_PROBE_ARCHIVER = "uros-archiver.txt"
_PROBE_PROJECT = """cmake_minimum_required(VERSION 3.12)
project(uros_compiler_facts C CXX)
execute_process(COMMAND "${CMAKE_C_COMPILER}" -print-file-name=liblto_plugin.so
  OUTPUT_VARIABLE plugin ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
execute_process(COMMAND "${CMAKE_AR}" --version OUTPUT_VARIABLE ar_version ERROR_QUIET)
file(WRITE "${CMAKE_BINARY_DIR}/"""
_PROBE_PROJECT += _PROBE_ARCHIVER + '" "${plugin}\\n${ar_version}")\n'

_PLAIN_PATH = re.compile(r"/[A-Za-z0-9_./+-]+")


def archive_plugin(probe: str) -> str:
    """The LTO plugin to name to the archiver, from the probe's answers (the C compiler's
    ``-print-file-name=liblto_plugin.so``, then ``ar --version``): GCC's plugin when the archiver
    is GNU ar and the compiler gave an absolute path of plain characters (it goes into a command
    line unquoted); "" otherwise (the archive rules stay CMake's own).

    Why: GNU ar, indexing an archive, loads every plugin in the bfd-plugins folder unless one is
    named; where LLVM's linker tools are installed that is LLVMgold, which loads libLLVM (measured
    here: ranlib 33-39 ms an archive, 7 ms with GCC's plugin named; a micro-ROS target makes 110).
    https://sourceware.org/binutils/docs/binutils/ar-cmdline.html (--plugin)"""
    plugin, _, version = probe.partition("\n")
    plugin = plugin.strip()
    first = version.strip().splitlines()[0] if version.strip() else ""
    if not first.startswith("GNU ar ") or not _PLAIN_PATH.fullmatch(plugin):
        return ""
    return plugin


def cmake_compiler_facts(
    runner: Runner,
    cmake: str,
    toolchain_file: Path,
    scratch: Path,
    generator: str | None,
    env: Mapping[str, str],
) -> CompilerFacts | None:
    """What CMake finds out about the target's compilers (identification, ABI, implicit folders,
    compile features: its ``CMakeFiles/<version>/CMake<LANG>Compiler.cmake``), from one tiny
    project configured with the toolchain file; None (the build then goes without) when CMake
    could not make them, for instance a target without a C++ compiler."""
    shutil.rmtree(scratch, ignore_errors=True)
    source = scratch / "src"
    source.mkdir(parents=True)
    (source / "CMakeLists.txt").write_text(_PROBE_PROJECT, encoding="utf-8")
    argv = [cmake, "-S", str(source), "-B", str(scratch / "build")]
    argv.append(f"-DCMAKE_TOOLCHAIN_FILE={toolchain_file}")
    if generator:
        argv.append(f"-G{generator}")
    try:
        runner.query(argv, step="find the target compilers' facts (once per target)", env=env)
    except UrosError:
        return None
    found = {}
    for lang in SEED_LANGUAGES:
        files = sorted((scratch / "build" / "CMakeFiles").glob(f"*/CMake{lang}Compiler.cmake"))
        if len(files) != 1:
            return None
        found[lang] = files[0].read_text(encoding="utf-8")
    try:
        cache = (scratch / "build" / "CMakeCache.txt").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    fmt = re.search(r"^CMAKE_EXECUTABLE_FORMAT:INTERNAL=(.*)$", cache, re.MULTILINE)
    try:
        plugin = archive_plugin((scratch / "build" / _PROBE_ARCHIVER).read_text(encoding="utf-8"))
    except OSError:
        plugin = ""
    if plugin and not Path(plugin).is_file():
        plugin = ""
    shutil.rmtree(scratch, ignore_errors=True)
    return CompilerFacts(found, fmt[1] if fmt else "", plugin)
