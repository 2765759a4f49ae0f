"""Values that reach CMake and the build tool arrive intact (issue 8, items 7, 9 and 10), through the
real CLI, colcon, CMake, Ninja or make, and arm-none-eabi-gcc."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest
import yaml
from fixture_ws import add_board_package, add_plain_package, fixture_build_args, make_fixture_workspace
from uros_helpers import REPO, need, run_uros, run_uros_here

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

# Every way a '$' was lost before: ninja/make variables ($5, $x, ${HOME}), a shell command
# substitution, and the characters make and the shell treat specially.
BOARD = "[cost $5 $x ${HOME} $$ $(echo hi) `echo hi` #1 %p 'q' \"dq\" a;b]"


def _profile(tmp_path: Path, base: str, **changes: object) -> Path:
    """A profile of the user's: a shipped one named 'board', with ``changes``."""
    data = yaml.safe_load((REPO / "toolchains" / f"{base}.yaml").read_text())
    data.update(name="board", **changes)
    path = tmp_path / "board.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


@pytest.mark.parametrize("generator", ["Ninja", "Unix Makefiles"])
def test_dollar_in_cflags_reaches_the_compiler(tmp_path: Path, generator: str) -> None:
    need("arm-none-eabi-gcc", "cmake", "ninja" if generator == "Ninja" else "make")
    # The workspace's path holds what colcon, CMake and the shell do carry: uros's -include of the
    # clock_gettime header and -ffile-prefix-map put it into every compile.
    ws = make_fixture_workspace(tmp_path / "fw 'q' #h (1)")
    add_board_package(ws)
    env = {**os.environ, "CMAKE_GENERATOR": generator}  # CMake's own choice, which uros follows
    args = fixture_build_args(ws)
    run_uros(*args, "--cflags", f"-DBOARD_NAME={_c_string(BOARD)}", env=env)
    out = ws / "build" / "cortex-m7-custom"
    assert BOARD.encode() + b"\x00" in (out / "libmicroros.a").read_bytes()
    build = ws / ".uros" / "targets" / "cortex-m7-custom" / "build" / "fx_board"
    assert (build / ("build.ninja" if generator == "Ninja" else "Makefile")).is_file()
    info = json.loads((out / "build-info.json").read_text())
    assert info["abi_check"]["result"] == "pass"
    assert len(info["packages"]) == 6  # the five fixture packages (fx_time needs -include) + fx_board


@pytest.mark.parametrize("generator", ["Ninja", "Unix Makefiles"])
def test_micro_ros_toolchain_in_a_dollar_folder_includes_its_header(tmp_path: Path, generator: str) -> None:
    """`uros toolchain render --for micro-ros -o F` force-includes the clock_gettime header beside
    F by absolute path: a '$' in that path must survive CMake, ninja/make and the shell."""
    need("arm-none-eabi-gcc", "cmake", "ninja" if generator == "Ninja" else "make")
    folder = tmp_path / "tc $x $5 'q'"
    folder.mkdir()
    tc = folder / "micro-ros.cmake"
    run_uros("toolchain", "render", "cortex-m7", "--for", "micro-ros", "-o", str(tc))
    project = tmp_path / "lib"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(lib C)\n"
        "add_library(lib STATIC now.c)\ntarget_compile_options(lib PRIVATE -Werror=implicit-function-declaration)\n"
    )
    (project / "now.c").write_text(
        "#include <time.h>\n"
        "long now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec; }\n"
    )
    build = tmp_path / "b"
    subprocess.run(
        ["cmake", "-S", str(project), "-B", str(build), "-G", generator, f"-DCMAKE_TOOLCHAIN_FILE={tc}"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    done = subprocess.run(["cmake", "--build", str(build)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (build / "liblib.a").is_file()


def test_makefiles_refuse_a_dollar_flag_that_reaches_the_link_line(tmp_path: Path) -> None:
    """The firmware toolchain file (executables) with '--specs=/a$b/x.specs': CMake passes compile
    flags to Makefile link lines without make, so no escaping fits both: the file says so."""
    need("arm-none-eabi-gcc", "cmake", "make")
    tc = tmp_path / "firmware.cmake"
    run_uros("toolchain", "render", "cortex-m4", "-o", str(tc))
    text = tc.read_text()
    profile = _profile(tmp_path, "cortex-m4", c_flags=["--specs=/a$b/x.specs"])
    run_uros("toolchain", "render", str(profile), "-o", str(tc))
    project = tmp_path / "app"
    project.mkdir()
    (project / "CMakeLists.txt").write_text("cmake_minimum_required(VERSION 3.16)\nproject(app C)\n")
    done = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "b"), "-G", "Unix Makefiles",
         f"-DCMAKE_TOOLCHAIN_FILE={tc}"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode != 0
    message = " ".join(done.stderr.split())  # CMake wraps its messages
    assert "also reach link lines" in message and "-G Ninja" in message
    assert "CMAKE_GENERATOR" not in text  # a plain profile's file has no guard


def _hostile_compiler_dir(root: Path) -> Path:
    """arm-none-eabi-* linked into a folder whose name is CMake, shell and ninja syntax."""
    bindir = root / "tools $x $5 (1) 'q' #h" / "bin"
    bindir.mkdir(parents=True)
    for tool in ("gcc", "g++", "ar", "ranlib", "nm", "objcopy", "size"):
        real = shutil.which(f"arm-none-eabi-{tool}")
        assert real
        (bindir / f"arm-none-eabi-{tool}").symlink_to(real)
    return bindir


def test_hostile_compiler_path_and_profile_values_configure_and_run_nothing(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path / "ws")
    bindir = _hostile_compiler_dir(tmp_path)
    pwned = tmp_path / "pwned"
    hostile = f'x") execute_process(COMMAND touch {pwned}) set(Y "'
    profile = _profile(tmp_path, "cortex-m7", description=hostile)
    run_uros(
        "build", "--profile", str(profile), "--compiler-prefix", f"{bindir}/arm-none-eabi-",
        "--workspace", str(ws), "--packages-up-to", "fx_flat",
    )  # fmt: skip
    assert not pwned.exists()
    out = ws / "build" / "board-custom"
    info = json.loads((out / "build-info.json").read_text())
    assert info["compiler"]["path"] == f"{bindir}/arm-none-eabi-gcc"
    assert info["abi_check"]["result"] == "pass"
    # the firmware's toolchain file, exported next to the library, configures too
    project = tmp_path / "app"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(app C)\n"
        'if(NOT CMAKE_C_COMPILER STREQUAL "${UROS_EXPECTED}")\n  message(FATAL_ERROR "${CMAKE_C_COMPILER}")\nendif()\n'
    )
    subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "b"), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}", f"-DUROS_EXPECTED={bindir}/arm-none-eabi-gcc"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    assert not pwned.exists()


@pytest.mark.parametrize(
    ("where", "value", "expected"),
    [
        ("--compiler-prefix", '/opt/a"b/arm-none-eabi-', "which CMake cannot use in a tool path"),
        ("--compiler-prefix", "/opt/${HOME}/arm-none-eabi-", "which CMake cannot use in a tool path"),
        ("--profile", {"system_processor": 'arm") execute_process(COMMAND id'}, "is not a word like 'arm'"),
        ("--workspace", "fw$x", "colcon and CMake cannot build in a folder whose path holds '$'"),
        ("--workspace", "fw`id`", "colcon and CMake cannot build in a folder whose path holds '`'"),
        ("--workspace", "fw;2", "colcon and CMake cannot build in a folder whose path holds ';'"),
    ],
)
def test_what_cmake_or_colcon_cannot_carry_is_refused_in_one_line(
    tmp_path: Path, where: str, value: Any, expected: str
) -> None:
    """CMake writes these values unescaped into files it runs (CMakeSystem.cmake,
    CMake<LANG>Compiler.cmake), colcon into shell scripts: uros says so before anything runs."""
    ws = make_fixture_workspace(tmp_path / (value if where == "--workspace" else "ws"))
    args = ["build", "--workspace", str(ws)]
    if where == "--profile":
        args += ["--profile", str(_profile(tmp_path, "cortex-m7", **value))]
    else:
        args += ["--toolchain", "cortex-m7"]
    if where == "--compiler-prefix":
        args += ["--compiler-prefix", value]
    proc = run_uros_here(*args, check=False)  # in this process: it refuses any process started
    assert proc.returncode == 2, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and expected in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr and not (ws / ".uros" / "targets").exists()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_two_checkouts_in_different_folders_give_the_same_library(tmp_path: Path) -> None:
    """rcutils' logging macros put __FILE__ into the library: with -ffile-prefix-map the
    workspace's folder does not reach it, so two checkouts build byte-identical libraries."""
    need("arm-none-eabi-gcc", "cmake")
    libs = []
    for where in ("a", "b/deeper/checkout"):
        ws = make_fixture_workspace(tmp_path / where)
        pkg = ws / "mcu_ws" / "src" / "fx_where"
        (pkg / "src").mkdir(parents=True)
        xml = (ws / "mcu_ws" / "src" / "fx_util" / "package.xml").read_text()
        (pkg / "package.xml").write_text(xml.replace("fx_util", "fx_where"))
        (pkg / "CMakeLists.txt").write_text(
            "cmake_minimum_required(VERSION 3.16)\nproject(fx_where C)\nfind_package(fx_core REQUIRED)\n"
            "add_library(fx_where STATIC src/where.c)\ntarget_link_libraries(fx_where PUBLIC fx_core::fx_core)\n"
            "install(TARGETS fx_where ARCHIVE DESTINATION lib)\n"
        )
        # __FILE__ of a source and of an installed header (the install tree is in the workspace too)
        (ws / "mcu_ws/src/fx_core/include/fx_core/where.h").write_text(
            "static inline const char *fx_core_header_file(void) { return __FILE__; }\n"
        )
        (pkg / "src" / "where.c").write_text(
            "#include <fx_core/where.h>\n"
            "const char *fx_where_file(void) { return __FILE__; }\n"
            "const char *fx_where_header(void) { return fx_core_header_file(); }\n"
        )
        run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(ws), "--packages-up-to", "fx_where")
        lib = ws / "build" / "cortex-m7" / "libmicroros.a"
        data = lib.read_bytes()
        assert str(ws).encode() not in data
        assert b"./mcu_ws/src/fx_where/src/where.c\x00" in data
        libs.append(lib)
    assert _sha(libs[0]) == _sha(libs[1])
    infos = [json.loads((lib.parent / "build-info.json").read_text()) for lib in libs]
    assert infos[0]["flags"]["micro_ros_only"][-2:] == [
        "-ffile-prefix-map=<workspace>=.",
        "-ffile-prefix-map=../../../../../=./",  # the same names under ccache's base_dir
    ]
    assert infos[0]["library"] == infos[1]["library"]


def test_a_crafted_target_in_build_info_runs_nothing_in_the_exported_package(
    m7_build: Path, tmp_path: Path
) -> None:
    """`uros export cmake` renders the target named in build-info.json into microros.cmake, which
    every firmware project includes: a crafted name stays a value there."""
    pwned = tmp_path / "pwned"
    hostile = f'x") execute_process(COMMAND touch {pwned}) message(STATUS "'
    out = tmp_path / "out"
    shutil.copytree(m7_build / "build" / "cortex-m7", out)
    info = json.loads((out / "build-info.json").read_text())
    info["target"] = hostile + "\n# ${HOME}"
    (out / "build-info.json").write_text(json.dumps(info))
    run_uros("export", "cmake", "--output", str(out))
    project = tmp_path / "app"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(app C)\nfind_package(microros CONFIG REQUIRED)\n"
        'message(STATUS "target=[${MICROROS_TARGET}]")\n'
    )
    done = subprocess.run(
        ["cmake", "-S", str(project), "-B", str(tmp_path / "b"), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={out}"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert not pwned.exists()
    assert f"target=[{hostile}\n# ${{HOME}}]" in done.stdout


def test_a_star_in_the_workspace_path_builds_only_that_workspace(tmp_path: Path) -> None:
    """Issue 34, item 7: colcon expands `*` in --base-paths as a glob, so a workspace at `fw*`
    also built the packages of a sibling folder `fw-other/` into its library. uros escapes the
    glob characters of the paths it gives colcon."""
    need("arm-none-eabi-gcc", "cmake", "arm-none-eabi-nm")
    ws = make_fixture_workspace(tmp_path / "fw*")
    sibling = tmp_path / "fw-other" / "mcu_ws" / "src" / "fx_sibling"
    add_plain_package(sibling, "fx_sibling", "int fx_sibling_only(void) { return 7; }\n")
    run_uros("build", "--toolchain", "cortex-m7", "-w", str(ws), "--meta", str(ws / "fixture.meta"))
    out = ws / "build" / "cortex-m7"
    symbols = subprocess.run(
        ["arm-none-eabi-nm", str(out / "libmicroros.a")], capture_output=True, text=True, check=True
    ).stdout
    assert "fx_core_add" in symbols and "fx_sibling_only" not in symbols
    info = json.loads((out / "build-info.json").read_text())
    assert "fx_sibling" not in json.dumps(info)
