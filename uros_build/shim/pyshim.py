"""The ``uros-python`` shim: the Python of a target's CMake builds (issue 19, item 1).

Each target's CMake configures and builds run Python through a small shell script
(shimfile.py writes it) that sends three kinds of call to uros and everything else to the real
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

# The shim imports this module on every call it sends to uros: only what a call needs, here and in
# the caches' modules (gencache.py says why).
import os
import sys

from uros_build.shim import callcache, gencache

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Sequence
    from pathlib import Path

RUNS = "gen-runs.log"  # in the target's folder: one line per generator run or configure call of its build

# CMake's FindPython asks the interpreter for its library folders once per build folder, that is
# once per package, with ``from distutils import sysconfig`` first
# (https://gitlab.kitware.com/cmake/cmake/-/blob/v3.25.1/Modules/FindPython/Support.cmake#L1963).
# In an environment with setuptools that import goes through setuptools' distutils shim and costs
# about 0.3 s (measured: 0.35 s vs 0.035 s, the same four folders printed); the standard library's
# own distutils answers the same question at once. Python 3.12 has no distutils of its own, so
# there the probe is left as it is.
FINDPYTHON_PROBE = "from distutils import sysconfig"
FINDPYTHON_FOLDERS = (  # the whole program, verbatim
    "import sys\ntry:\n   from distutils import sysconfig\n   sys.stdout.write(';'.join(["
    "sysconfig.get_python_lib(plat_specific=False,standard_lib=True),"
    "sysconfig.get_python_lib(plat_specific=True,standard_lib=True),"
    "sysconfig.get_python_lib(plat_specific=False,standard_lib=False),"
    "sysconfig.get_python_lib(plat_specific=True,standard_lib=False)]))\n"
    "except Exception:\n   import sysconfig\n   sys.stdout.write(';'.join(["
    "sysconfig.get_path('stdlib'),sysconfig.get_path('platstdlib'),"
    "sysconfig.get_path('purelib'),sysconfig.get_path('platlib')]))"
)
VERSION_FLAG = "-V"  # ``python -V``, which FindPython also runs once per configure (#L1932)

# FindPython also asks the interpreter the same questions on every find_package(Python3): eleven
# runs of it in each configure of an interface package at ~17 ms each (measured: std_msgs, CMake
# 3.25.1, 0.2 s of its 1.0 s configure). Their answers are the interpreter's alone, so uros asks it
# once per build (:func:`print_answers`) and the shim answers with that text; any other program,
# or these under another CMake that spells them otherwise, runs as asked. Verbatim from
# https://gitlab.kitware.com/cmake/cmake/-/blob/v3.25.1/Modules/FindPython/Support.cmake#L1847
# (and #L1894, #L1948; the folders: #L1963, answered only with the standard library's distutils,
# as the shim gives it).
FINDPYTHON_QUESTIONS = (
    "import sys; sys.stdout.write('.'.join([str(x) for x in sys.version_info[:3]]))",
    "import sys; sys.stdout.write(sys.abiflags)",
    "import sys; sys.stdout.write(sys.copyright)",
    FINDPYTHON_FOLDERS,
)
STDLIB_DISTUTILS = {"SETUPTOOLS_USE_DISTUTILS": "stdlib"}  # setuptools' switch to the stdlib's own


def print_answers() -> None:
    """Print, as JSON, what each of FINDPYTHON_QUESTIONS writes when this interpreter runs it (the
    folders only when it has a distutils of its own, before 3.12, and runs with STDLIB_DISTUTILS),
    what ``-V`` prints, and whether it has distutils. Run by uros once per build with the shim's
    interpreter."""
    import io

    has_distutils = sys.version_info < (3, 12)
    # -V prints the version as Py_GetVersion() spells it, up to its first space (sys.version is that)
    answers: dict[str, object] = {
        "distutils": has_distutils,
        VERSION_FLAG: f"Python {sys.version.split(' ')[0]}\n",
    }
    stdlib = all(os.environ.get(k) == v for k, v in STDLIB_DISTUTILS.items())
    for code in FINDPYTHON_QUESTIONS:
        if code == FINDPYTHON_FOLDERS and not (has_distutils and stdlib):
            continue
        saved, sys.stdout = sys.stdout, io.StringIO()
        try:
            exec(code, {})  # the constant programs above, as ``python -c`` runs them
            answers[code] = sys.stdout.getvalue()
        finally:
            sys.stdout = saved
    import json

    print(json.dumps(answers, sort_keys=True))


def answers_argv(python: str, code_dir: Path) -> list[str]:
    """The command line that runs :func:`print_answers` with ``python``."""
    entry = (
        f"import sys; sys.path.append({str(code_dir)!r}); "
        "from uros_build.shim.pyshim import print_answers; print_answers()"
    )
    return [python, "-c", entry]


def parse_answers(text: str) -> tuple[dict[str, str], bool]:
    """:func:`print_answers`' output: the answers, and whether the interpreter has distutils."""
    import json

    data = json.loads(text)
    if not isinstance(data, dict) or not isinstance(data.get("distutils"), bool):
        raise ValueError(f"not an answer: {text[:80]!r}")
    known = (*FINDPYTHON_QUESTIONS, VERSION_FLAG)
    answers = {code: data[code] for code in known if isinstance(data.get(code), str)}
    return answers, data["distutils"]


def drop_unloadable(folder: str) -> int:
    """Remove each compiled module under ``folder`` (the pycache prefix of uros's calls) that does
    not load: cut short, or not one at all. Returns how many were removed (0: none was the cause
    of a failed call)."""
    import marshal

    dropped = 0
    for top, _dirs, files in os.walk(folder):
        for name in files:
            if not name.endswith(".pyc"):
                continue
            path = os.path.join(top, name)
            try:
                with open(path, "rb") as f:
                    data = f.read()
                if len(data) < 16:  # magic, flags and the source's stamp come first
                    raise EOFError("no header")
                marshal.loads(data[16:])
            except OSError:
                continue
            except Exception:  # EOFError "marshal data too short", ValueError "bad marshal data"
                try:
                    os.unlink(path)
                    dropped += 1
                except OSError:
                    pass
    if dropped:
        print(f"uros: removed {dropped} cut compiled module(s) from {folder}: running again", file=sys.stderr)
    return dropped


def main(args: Sequence[str]) -> int:
    """``CACHE_DIR TARGET_DIR WORKSPACE MODULES ARGV...`` (MODULES: module versions as JSON; ARGV:
    the call without the interpreter)."""
    cache, target, workspace = args[:3]
    modules, *argv = args[3:]
    if gencache.is_generator_run(argv):
        result = gencache.generate(argv, cache, target, modules, workspace)
        line = f"{result} {os.path.basename(argv[0])} {argv[2]}"
    else:
        result = callcache.run(argv, os.path.join(cache, "calls"), target, workspace)
        shown = argv[:4] if argv[:1] == ["-m"] else argv[:2]  # -m rosidl_adapter --package-name NAME
        line = f"call-{result} {' '.join(shown)}"
    try:  # one short line with O_APPEND: parallel runs do not mix their lines
        with open(os.path.join(target, RUNS), "a", encoding="utf-8") as f:
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
