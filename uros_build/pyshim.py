"""The ``uros-python`` shim: the Python of a target's CMake builds (issue 19, item 1).

Each target's CMake configures and builds run Python through a small shell script
(:func:`shim_text`) that sends three kinds of call to uros and everything else to the real
interpreter, unchanged:

- rosidl generator runs (``SCRIPT --generator-arguments-file FILE``): the generation cache
  (gencache.py);
- the Python calls of a package's configure (ament's templates and package.xml, rosidl_adapter):
  the configure call cache (callcache.py);
- CMake's FindPython probe, which gets the standard library's distutils (below).

Both caches are the user's (``~/.cache/uros/gen``, or ``$UROS_GEN_CACHE_DIR``), shared by every
target of every workspace: their keys and entries hold neither the target's folder nor the
workspace's. Each run
adds one line to the target's run log (:data:`RUNS`), which the build counts (:func:`count_runs`).
"""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from uros_build import callcache, gencache

RUNS = "gen-runs.log"  # in the target's folder: one line per generator run or configure call of its build

# CMake's FindPython asks the interpreter for its library folders once per build folder, that is
# once per package, with ``from distutils import sysconfig`` first
# (https://gitlab.kitware.com/cmake/cmake/-/blob/v3.25.1/Modules/FindPython/Support.cmake#L1963).
# In an environment with setuptools that import goes through setuptools' distutils shim and costs
# about 0.3 s (measured: 0.35 s vs 0.035 s, the same four folders printed); the standard library's
# own distutils answers the same question at once. Python 3.12 has no distutils of its own, so
# there the probe is left as it is.
FINDPYTHON_PROBE = "from distutils import sysconfig"


def shim_text(
    python: str,
    cache_dir: Path,
    target_dir: Path,
    workspace: Path,
    code_dir: Path,
    written_by: str,
    modules: Mapping[str, str],
    stdlib_distutils: bool,
) -> str:
    """The ``Python3_EXECUTABLE`` of a target's CMake builds. ``code_dir``: the folder holding
    uros_build (appended to the path: the calls' own imports resolve as before). ``modules``:
    :func:`gencache.module_versions` of ``python``, found once by uros rather than on every run.
    ``stdlib_distutils``: ``python`` has a distutils of its own (before 3.12)."""
    q = shlex.quote
    entry = (
        f"import sys; sys.path.append({str(code_dir)!r}); "
        "from uros_build.pyshim import main; sys.exit(main(sys.argv[1:]))"
    )
    versions = json.dumps(dict(modules), sort_keys=True)
    folders = " ".join(q(str(p)) for p in (cache_dir, target_dir, workspace))
    to_uros = f'exec {q(python)} -c {q(entry)} {folders} {q(versions)} "$@"'
    probe = (
        [
            f'if [ "$1" = -c ]; then case "$2" in *{q(FINDPYTHON_PROBE)}*)',
            "  SETUPTOOLS_USE_DISTUTILS=stdlib; export SETUPTOOLS_USE_DISTUTILS;; esac; fi",
        ]
        if stdlib_distutils
        else []
    )
    return "\n".join(
        [
            "#!/bin/sh",
            f"# Written by {written_by}: the Python of this target's CMake builds. rosidl generator",
            "# runs and ament's and rosidl_adapter's configure calls go through uros's caches",
            "# (uros_build/pyshim.py); all else is the real Python.",
            f'if [ "$2" = {gencache.ARGUMENTS_FLAG} ] && [ -n "$3" ]; then',
            f"  {to_uros}",
            "fi",
            'case "$1" in */package_templates/templates_2_cmake.py|*/core/package_xml_2_cmake.py)',
            f"  {to_uros};;",
            "esac",
            'if [ "$1" = -m ] && [ "$2" = rosidl_adapter ]; then',
            f"  {to_uros}",
            "fi",
            *probe,
            f'exec {q(python)} "$@"',
            "",
        ]
    )


def main(args: Sequence[str]) -> int:
    """``CACHE_DIR TARGET_DIR WORKSPACE MODULES ARGV...`` (MODULES: module versions as JSON; ARGV:
    the call without the interpreter)."""
    cache, target, workspace = (Path(a) for a in args[:3])
    modules, *argv = args[3:]
    if gencache.is_generator_run(argv):
        result = gencache.generate(argv, cache, target, json.loads(modules), workspace)
        line = f"{result} {Path(argv[0]).name} {argv[2]}"
    else:
        result = callcache.run(argv, cache / "calls", target, workspace)
        shown = argv[:4] if argv[:1] == ["-m"] else argv[:2]  # -m rosidl_adapter --package-name NAME
        line = f"call-{result} {' '.join(shown)}"
    try:  # one short line with O_APPEND: parallel runs do not mix their lines
        with (target / RUNS).open("a", encoding="utf-8") as f:
            f.write(line + "\n")
    except OSError:
        pass
    return 0


def count_runs(text: str) -> dict[str, int]:
    """hit/miss/bypass counts of a run log's generator runs, and of its configure calls
    (``call-hit`` ...)."""
    out = {"hit": 0, "miss": 0, "bypass": 0, "call-hit": 0, "call-miss": 0, "call-bypass": 0}
    for line in text.splitlines():
        word = line.partition(" ")[0]
        if word in out:
            out[word] += 1
    return out


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
