"""The uros-python shim a target's CMake builds run Python through (shim/shimfile.py), run by a
real shell with this interpreter: CMake's FindPython probe gets the standard library's distutils and
prints the same folders as the interpreter itself does; its questions about the interpreter get the
interpreter's own answers; every other call is the interpreter,
unchanged (arguments, exit status, environment)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import need, run_uros

from uros_build.shim import pyshim, shimfile

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

PROBE = pyshim.FINDPYTHON_FOLDERS  # CMake 3.25's probe, as FindPython/Support.cmake runs it
ENV = "import os, sys; print(os.environ.get('SETUPTOOLS_USE_DISTUTILS', '-')); sys.exit(3)"


def _shim(tmp_path: Path) -> Path:
    shim = tmp_path / "uros-python"
    asked = subprocess.run(
        pyshim.answers_argv(sys.executable, Path(__file__).parents[2]),
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, **pyshim.STDLIB_DISTUTILS},
    )
    answers, has_distutils = pyshim.parse_answers(asked.stdout)
    assert has_distutils == (sys.version_info < (3, 12))
    shim.write_text(
        shimfile.shim_text(
            shimfile.Shim(
                sys.executable,
                tmp_path / "cache",
                tmp_path / "target",
                tmp_path,
                Path(__file__).parents[2],
                "test",
                {"empy": "-"},
                stdlib_distutils=has_distutils,
                answers=answers,
            )
        )
    )
    shim.chmod(0o755)
    return shim


def test_the_findpython_probe_answers_the_same_and_nothing_else_changes(tmp_path: Path) -> None:
    shim = _shim(tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "SETUPTOOLS_USE_DISTUTILS"}
    real = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, check=True)
    through = subprocess.run([str(shim), "-c", PROBE], capture_output=True, text=True, env=env, check=True)
    assert through.stdout == real.stdout and real.stdout.count(";") == 3

    other = subprocess.run([str(shim), "-c", ENV], capture_output=True, text=True, env=env)
    assert (other.returncode, other.stdout) == (3, "-\n")  # the interpreter as it is, its exit status

    args = subprocess.run(
        [str(shim), "-c", "import json, sys; print(json.dumps(sys.argv[1:]))", "a b", "$HOME", "--x"],
        capture_output=True, text=True, env=env, check=True,
    )  # fmt: skip
    assert json.loads(args.stdout) == ["a b", "$HOME", "--x"]


def test_findpythons_questions_get_the_interpreters_own_answers_without_running_it(tmp_path: Path) -> None:
    shim = _shim(tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "SETUPTOOLS_USE_DISTUTILS"}
    for args in [*(["-c", code] for code in pyshim.FINDPYTHON_QUESTIONS), ["-V"]]:
        real = subprocess.run([sys.executable, *args], capture_output=True, check=True, env=env)
        through = subprocess.run([str(shim), *args], capture_output=True, check=True, env=env)
        assert through.stdout == real.stdout and through.stderr == b""
    text = shim.read_text()
    assert "sys.copyright" in text and "printf %s 'Python " in text  # answered by the shell
    assert ("get_python_lib" in text) == (sys.version_info < (3, 12))
    # the same program with one more argument, or one character more, is run as asked
    extra = subprocess.run(
        [str(shim), "-c", pyshim.FINDPYTHON_QUESTIONS[0], "x"], capture_output=True, check=True
    )
    assert (
        extra.stdout
        == subprocess.run([sys.executable, "-c", pyshim.FINDPYTHON_QUESTIONS[0]], capture_output=True).stdout
    )
    other = subprocess.run(
        [str(shim), "-c", pyshim.FINDPYTHON_QUESTIONS[1] + ";print(7)"], capture_output=True, text=True
    )
    assert other.stdout.endswith("7\n")


PY_CMAKE = """\
cmake_minimum_required(VERSION 3.16)
project(fx_py C)
find_package(Python3 REQUIRED COMPONENTS Interpreter)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/py.c "const char *fx_py = \\"python ${Python3_VERSION}\\";\\n")
add_library(fx_py STATIC ${CMAKE_CURRENT_BINARY_DIR}/py.c)
install(TARGETS fx_py ARCHIVE DESTINATION lib)
"""


def _cmake_package(ws: Path, name: str, cmake: str, files: dict[str, str] | None = None) -> Path:
    """A colcon cmake package ``name`` in the workspace's mcu_ws/src with ``cmake`` as its
    CMakeLists.txt and ``files`` (relative name -> text) beside it."""
    pkg = ws / "mcu_ws" / "src" / name
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(
        f'<?xml version="1.0"?><package format="3"><name>{name}</name><version>0.1.0</version>'
        "<description>d</description><maintainer email='d@example.com'>t</maintainer>"
        "<license>Apache-2.0</license><export><build_type>cmake</build_type></export></package>\n"
    )
    (pkg / "CMakeLists.txt").write_text(cmake)
    for rel, text in (files or {}).items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(text)
    return pkg


@pytest.fixture(scope="module")
def built_once(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One build this module's tests read (each of them built its own before, the same way): the
    fixture with fx_py (FindPython), fx_templates (an ament templates call) and fx_gen (a generator
    and a templates call), those three alone, for cortex-m7, in ws/, with its own generation cache,
    gen-cache/, and PYTHONDONTWRITEBYTECODE=1 (set on some CI images). The folder holding both."""
    need("arm-none-eabi-gcc", "cmake", "arm-none-eabi-strings")
    root = tmp_path_factory.mktemp("built-once")
    ws = _gen_workspace(root / "ws")
    _cmake_package(ws, "fx_py", PY_CMAKE)
    _cmake_package(
        ws, "fx_templates", TEMPLATES_CMAKE, {"package_templates/templates_2_cmake.py": TEMPLATES_PY}
    )
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1", "UROS_GEN_CACHE_DIR": str(root / "gen-cache")}
    # the three packages that call Python alone (the fixture's own five make no such call)
    chosen = ("--packages-up-to", "fx_py", "--packages-up-to", "fx_templates")
    run_uros(*_gen_build(ws), *chosen, env=env)
    assert {"Int32", "Word1"} <= set(_strings(ws).split())
    return root


def test_a_build_writes_the_interpreters_answers_into_its_shim_and_cmake_takes_them(built_once: Path) -> None:
    ws = built_once / "ws"
    shim = ws / ".uros" / "targets" / "cortex-m7" / "uros-python"
    text = shim.read_text()
    python = text.rstrip().splitlines()[-1].split()[1]  # exec PYTHON "$@": the interpreter it stands for
    assert "sys.copyright" in text and "printf %s 'Python " in text  # the build wrote the answers
    for args in [*(["-c", code] for code in pyshim.FINDPYTHON_QUESTIONS), ["-V"]]:
        env = {k: v for k, v in os.environ.items() if k != "SETUPTOOLS_USE_DISTUTILS"}
        real = subprocess.run([python, *args], capture_output=True, check=True, env=env)
        assert (
            subprocess.run([str(shim), *args], capture_output=True, check=True, env=env).stdout == real.stdout
        )
    # CMake's FindPython took the shim's answer: the interpreter's version reached the library
    version = subprocess.run(
        [python, "-c", pyshim.FINDPYTHON_QUESTIONS[0]], capture_output=True, text=True
    ).stdout
    strings = subprocess.run(
        ["arm-none-eabi-strings", "-a", str(ws / "build" / "cortex-m7" / "libmicroros.a")],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert f"python {version}" in strings


# A package whose configure makes one of the calls uros-python sends to uros's caches (an ament
# templates call, recognised by its script's path), as every ament package's configure does.
TEMPLATES_CALL = """\
execute_process(
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/package_templates/templates_2_cmake.py
    ${CMAKE_CURRENT_BINARY_DIR}/templates.cmake
  RESULT_VARIABLE result)
if(NOT result EQUAL 0 OR NOT EXISTS ${CMAKE_CURRENT_BINARY_DIR}/templates.cmake)
  message(FATAL_ERROR "the templates call failed: ${result}")
endif()
"""
TEMPLATES_CMAKE = f"""\
cmake_minimum_required(VERSION 3.16)
project(fx_templates NONE)
{TEMPLATES_CALL}install(FILES ${{CMAKE_CURRENT_BINARY_DIR}}/templates.cmake DESTINATION share/fx_templates)
"""
TEMPLATES_PY = """\
import sys
with open(sys.argv[1], "w") as f:
    f.write("set(FX_TEMPLATES 1)\\n")
"""


def test_uros_calls_keep_compiled_modules_in_the_cache_even_without_bytecode_writing(
    built_once: Path,
) -> None:
    """PYTHONDONTWRITEBYTECODE (set on some CI images) made every call through uros's caches compile
    uros's modules again; they are kept in the generation cache's pycache folder, not beside any
    sources (the module's build ran with it set)."""
    ws, cache = built_once / "ws", built_once / "gen-cache"
    pkg = ws / "mcu_ws" / "src" / "fx_templates"
    runs = (ws / ".uros" / "targets" / "cortex-m7" / pyshim.RUNS).read_text()
    assert "templates_2_cmake.py" in runs  # the call went through uros
    compiled = {p.name.split(".")[0] for p in (cache / "pycache").rglob("*.pyc")}
    assert {"pyshim", "callcache", "gencache"} <= compiled, sorted(compiled)
    assert not list(pkg.rglob("__pycache__"))


# A package whose build runs a generator as rosidl runs its generators (SCRIPT
# --generator-arguments-file FILE: the generation cache) and whose configure makes an ament
# templates call (the configure call cache); what each writes reaches the library as a string.
GEN_CMAKE = (
    """\
cmake_minimum_required(VERSION 3.16)
project(fx_gen C)
"""
    + TEMPLATES_CALL
    + """\
include(${CMAKE_CURRENT_BINARY_DIR}/templates.cmake)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/word.c "const char *fx_word = \\"${FX_WORD}\\";\\n")
set(args ${CMAKE_CURRENT_BINARY_DIR}/args.json)
file(WRITE ${args} "{\\"output_dir\\": \\"${CMAKE_CURRENT_BINARY_DIR}/gen\\", \\"idl_tuples\\": [\\"${CMAKE_CURRENT_SOURCE_DIR}:types.idl\\"], \\"target_dependencies\\": [\\"${CMAKE_CURRENT_SOURCE_DIR}/gen.py\\"]}")
add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/gen/types.c
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/gen.py --generator-arguments-file ${args}
  DEPENDS gen.py types.idl)
add_library(fx_gen STATIC ${CMAKE_CURRENT_BINARY_DIR}/gen/types.c ${CMAKE_CURRENT_BINARY_DIR}/word.c)
install(TARGETS fx_gen ARCHIVE DESTINATION lib)
"""
)
GEN_PY = """\
import json, os, sys
args = json.load(open(sys.argv[2]))
base, _, rel = args["idl_tuples"][0].rpartition(":")
text = open(os.path.join(base, rel)).read().strip()
os.makedirs(args["output_dir"], exist_ok=True)
with open(os.path.join(args["output_dir"], "types.c"), "w") as f:
    f.write('const char *fx_type = "%s";\\n' % text)
"""
WORD_PY = """\
import sys
with open(sys.argv[1], "w") as f:
    f.write('set(FX_WORD "Word1")\\n')
"""


def _gen_workspace(where: Path) -> Path:
    ws = make_fixture_workspace(where)
    files = {"gen.py": GEN_PY, "types.idl": "Int32\n", "package_templates/templates_2_cmake.py": WORD_PY}
    _cmake_package(ws, "fx_gen", GEN_CMAKE, files)
    return ws


def _gen_build(ws: Path) -> list[str]:
    """`uros build` of fx_gen alone (the package whose configure and build go through the caches; the
    fixture's own packages make no such call)."""
    return ["build", "--toolchain", "cortex-m7", "-w", str(ws), "--meta", str(ws / "fixture.meta"),
            "--packages-up-to", "fx_gen"]  # fmt: skip


def _strings(ws: Path) -> str:
    return subprocess.run(
        ["arm-none-eabi-strings", "-a", str(ws / "build" / "cortex-m7" / "libmicroros.a")],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip


def _built_with_gen_cache(built_once: Path, tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """A copy of the generation cache the module's build filled (built_once: the fx_gen workspace
    built with it), this test's own: (the cache, the env a build with it runs in)."""
    cache = Path(shutil.copytree(built_once / "gen-cache", tmp_path / "gen-cache", symlinks=True))
    return cache, {**os.environ, "UROS_GEN_CACHE_DIR": str(cache)}


def test_a_byte_changed_in_a_cached_file_never_reaches_the_library(built_once: Path, tmp_path: Path) -> None:
    """A same-size change in a generation-cache entry ("Int32" -> "Int3X") ended up in
    libmicroros.a with exit 0, as did one in a configure call's entry: every cached file carries
    its sha256, a mismatch is a miss, and the entry is written again."""
    cache, env = _built_with_gen_cache(built_once, tmp_path)
    changed = []
    for entry in cache.rglob("*.entry"):
        data = entry.read_bytes()
        for good, bad in ((b'"Int32"', b'"Int3X"'), (b'"Word1"', b'"Word9"')):
            if good in data:
                entry.write_bytes(data.replace(good, bad))
                changed.append((entry, data))
    assert len(changed) == 2, changed
    two = _gen_workspace(tmp_path / "two")  # another checkout: the same keys (built cold: the subject)
    run_uros(*_gen_build(two), env=env)
    words = set(_strings(two).split())
    assert {"Int32", "Word1"} <= words and not {"Int3X", "Word9"} & words
    runs = (two / ".uros" / "targets" / "cortex-m7" / pyshim.RUNS).read_text()
    assert "miss gen.py" in runs and "call-miss" in runs, runs
    for entry, data in changed:
        assert entry.read_bytes() == data  # written again whole


def test_a_compiled_module_cut_by_a_full_disk_is_dropped_and_the_build_goes_on(
    built_once: Path, tmp_path: Path
) -> None:
    """A full generation-cache disk left cut .pyc files in its pycache folder (Python does not
    check the write), and every later build failed in the first configure that called uros
    ("marshal data too short") even after space returned. A call that fails has the folder checked,
    what does not load dropped, and runs once more."""
    cache, env = _built_with_gen_cache(built_once, tmp_path)
    compiled = sorted((cache / "pycache").rglob("*.pyc"))
    assert {"pyshim", "callcache", "gencache"} <= {p.name.split(".")[0] for p in compiled}
    for pyc in compiled:  # as a full disk leaves them: the header whole, the code cut
        data = pyc.read_bytes()
        pyc.write_bytes(data[: 16 + (len(data) - 16) // 2])
    two = _gen_workspace(tmp_path / "two")
    done = run_uros(*_gen_build(two), env=env, check=False)
    assert done.returncode == 0, done.stderr
    assert {"Int32", "Word1"} <= set(_strings(two).split())
    runs = (two / ".uros" / "targets" / "cortex-m7" / pyshim.RUNS).read_text()
    assert "gen.py" in runs and "call-" in runs, runs
    import marshal

    for pyc in (cache / "pycache").rglob("*.pyc"):  # written again whole
        marshal.loads(pyc.read_bytes()[16:])
