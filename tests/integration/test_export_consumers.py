"""`uros export make`, `pkg-config` and `meson` (issue 20, items 3 and 4), each consumed by the real
tool: a Make firmware, pkg-config's answer fed to the cross compiler, and a Meson cross build with
dependency('microros') -- every one links against the fixture library and calls into it."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from fixture_ws import UP_TO_CORE, fixture_build_args
from uros_helpers import need, run_uros, run_uros_here

pytestmark = pytest.mark.integration

_MAIN = '#include "fx_core/core.h"\nint main(void) { return fx_core_add(1, 2) == 3 ? 0 : 1; }\n'


def _calls_the_library(elf: Path) -> None:
    nm = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    assert " T fx_core_add" in nm, nm


@pytest.fixture(scope="module")
def m7_output(fixture_builds: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the cortex-m7 output of the built fixture (conftest's m7 variant), made once for
    this module: the tests that only read it (they export from it, or link against it)."""
    source = fixture_builds.snapshot("m7") / "build" / "cortex-m7"
    return Path(shutil.copytree(source, tmp_path_factory.mktemp("m7-output") / "cortex-m7", symlinks=True))


@pytest.fixture(scope="module")
def exported(m7_output: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The make, pkg-config and meson exports of it in one folder, made once for this module (its
    tests only read them and build beside them)."""
    # a space: the paths must survive make, pkg-config and meson
    out = tmp_path_factory.mktemp("exported") / "micro ros"
    for kind in ("make", "pkg-config", "meson"):
        run_uros("export", kind, "--from", str(m7_output), "--output", str(out))
    return out


def _make_firmware(app: Path, folder: str) -> None:
    """The README's Makefile, including ``folder``/microros.mk, builds app.elf calling the library."""
    (app / "Makefile").write_text(
        f"include {folder}/microros.mk\n"
        "CC = arm-none-eabi-gcc\n"
        "CFLAGS += $(MICROROS_CPU_FLAGS) $(MICROROS_CFLAGS)\n"
        "LDFLAGS += $(MICROROS_CPU_FLAGS) --specs=nosys.specs\n"
        "app.elf: main.o\n\t$(CC) $(LDFLAGS) -o $@ $^ $(MICROROS_LIBS)\n"
    )
    proc = subprocess.run(["make", "-C", str(app)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    _calls_the_library(app / "app.elf")


def test_a_make_firmware_links(exported: Path, tmp_path: Path) -> None:
    need("make", "arm-none-eabi-gcc")
    app = tmp_path / "app"
    app.mkdir()
    (app / "main.c").write_text(_MAIN)
    # make cannot include a path with a space: the firmware links the export in, as users copy it
    (app / "microros").symlink_to(exported)
    _make_firmware(app, "microros")
    text = (exported / "microros.mk").read_text()
    assert "MICROROS_TARGET := cortex-m7\n" in text and "-mfloat-abi=hard" in text


def _pkg_config(folder: Path, *args: str) -> list[str]:
    env = {**os.environ, "PKG_CONFIG_PATH": str(folder)}
    out = subprocess.run(
        ["pkg-config", *args, "microros"], capture_output=True, text=True, env=env, check=True
    )
    return shlex.split(out.stdout)


_M7 = ["-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard"]
_M4F = ["-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"]


def test_pkg_config_answers_what_links(exported: Path, tmp_path: Path) -> None:
    """Issue 34, item 6: `$(pkg-config --cflags --libs microros)` alone links (the CPU flags were only
    in a variable, and the link failed "uses VFP register arguments")."""
    need("pkg-config", "arm-none-eabi-gcc")
    cflags, libs = _pkg_config(exported, "--cflags"), _pkg_config(exported, "--libs")
    assert cflags == [*_M7, f"-I{exported}/include"] and libs == [*_M7, f"{exported}/libmicroros.a"]
    assert _pkg_config(exported, "--variable=cpu_flags") == _M7
    (tmp_path / "main.c").write_text(_MAIN)
    elf = tmp_path / "app.elf"
    both = _pkg_config(exported, "--cflags", "--libs")
    argv = ["arm-none-eabi-gcc", str(tmp_path / "main.c"), *both, "--specs=nosys.specs", "-o", str(elf)]
    subprocess.run(argv, check=True)
    _calls_the_library(elf)
    assert run_uros("check", str(elf), "--toolchain", "cortex-m7").returncode == 0


def test_uros_check_catches_a_firmware_for_another_core(exported: Path, tmp_path: Path) -> None:
    """Issue 34, item 6: an M4F firmware compiled with its own flags links the M7 library without a
    word from GNU ld; `uros check app.elf --toolchain cortex-m4f` is the guard (exit 5)."""
    need("arm-none-eabi-gcc")
    (tmp_path / "main.c").write_text(_MAIN)
    elf = tmp_path / "m4f.elf"
    include, library = f"-I{exported}/include", str(exported / "libmicroros.a")
    argv = ["arm-none-eabi-gcc", *_M4F, include, str(tmp_path / "main.c"), library, "--specs=nosys.specs"]
    subprocess.run([*argv, "-o", str(elf)], check=True)  # links: ld says nothing
    proc = run_uros("check", str(elf), "--toolchain", "cortex-m4f", check=False)
    assert proc.returncode == 5, proc.stderr
    assert "Tag_FP_arch is FPv5/FP-D16 for ARMv8, cortex-m4f expects VFPv4-D16" in proc.stderr
    assert "hint: it holds code built for another core than cortex-m4f" in proc.stderr  # not "the library"


_FIRMWARE_TOOLCHAIN = """set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_C_FLAGS_INIT "{flags}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nosys.specs")
"""


@pytest.mark.parametrize("how", ["toolchain", "add_compile_options"])
def test_the_cmake_package_refuses_a_firmware_for_another_core(
    m7_output: Path, tmp_path: Path, how: str
) -> None:
    """Issue 34, item 6: find_package(microros) of the M7 library in an M4F firmware stops at
    configure time with one line naming the flag (it linked silently); the M7 firmware links."""
    need("cmake", "ninja", "arm-none-eabi-gcc")
    out = m7_output
    for core, flags in (("m4f", _M4F), ("m7", _M7)):
        proj = tmp_path / core
        proj.mkdir()
        (proj / "main.c").write_text(_MAIN)
        in_toolchain, options = (" ".join(flags), "") if how == "toolchain" else ("-mthumb", " ".join(flags))
        (proj / "tc.cmake").write_text(_FIRMWARE_TOOLCHAIN.format(flags=in_toolchain))
        (proj / "CMakeLists.txt").write_text(
            "cmake_minimum_required(VERSION 3.16)\nproject(app C)\n"
            + (f"add_compile_options({options})\n" if options else "")
            + "find_package(microros CONFIG REQUIRED)\n"
            "add_executable(app main.c)\ntarget_link_libraries(app PRIVATE microros::microros)\n"
            + (f"target_link_options(app PRIVATE {options})\n" if options else "")
        )
        configure = subprocess.run(
            ["cmake", "-S", str(proj), "-B", str(proj / "b"), "-G", "Ninja",
             f"-DCMAKE_TOOLCHAIN_FILE={proj / 'tc.cmake'}", f"-DCMAKE_PREFIX_PATH={out}"],
            capture_output=True, text=True,
        )  # fmt: skip
        if core == "m4f":
            assert configure.returncode != 0
            assert (
                f"microros: {out}/libmicroros.a is built for cortex-m7 (-mcpu=cortex-m7), this firmware "
                "compiles C with -mcpu=cortex-m4: build micro-ROS for this core"
                in " ".join(configure.stderr.split())
            ), configure.stderr  # CMake wraps the one message line
        else:
            assert configure.returncode == 0, configure.stderr
            subprocess.run(["cmake", "--build", str(proj / "b")], check=True, capture_output=True)
            _calls_the_library(proj / "b" / "app")


def test_a_meson_cross_build_finds_the_dependency(exported: Path, tmp_path: Path) -> None:
    need("meson", "ninja", "pkg-config", "arm-none-eabi-gcc")
    app = tmp_path / "app"
    app.mkdir()
    (app / "main.c").write_text(_MAIN)
    (app / "meson.build").write_text(
        "project('app', 'c')\n"
        "executable('app.elf', 'main.c', dependencies: dependency('microros'), link_args: ['--specs=nosys.specs'])\n"
    )
    build = tmp_path / "build"
    env = {k: v for k, v in os.environ.items() if k != "PKG_CONFIG_PATH"}
    setup = subprocess.run(
        ["meson", "setup", str(build), str(app), "--cross-file", str(exported / "microros-cross.ini")],
        capture_output=True, text=True, env=env,
    )  # fmt: skip
    assert setup.returncode == 0, setup.stdout + setup.stderr
    assert "Run-time dependency microros found: YES" in setup.stdout
    subprocess.run(["ninja", "-C", str(build)], check=True, capture_output=True, env=env)
    _calls_the_library(build / "app.elf")


def test_exports_name_their_files_in_the_output_marker(exported: Path) -> None:
    marker = (exported / ".uros-output").read_text()
    for name in ("microros.mk", "microros.pc", "microros-cross.ini"):
        assert name in marker


def test_one_arduino_library_for_two_boards(built: Callable[[str], Path], tmp_path: Path) -> None:
    """Issue 20, item 2: the archive of each target where Arduino's builder looks for it
    (src/{build.mcu}/{fpu}-{float-abi}), one include tree, library.properties precompiled=true."""
    need("arm-none-eabi-gcc", "cmake")
    ws = built("core")  # fx_core for cortex-m7; the same for cortex-m4f (a cold first build) here
    run_uros(*fixture_build_args(ws, *UP_TO_CORE, toolchain="cortex-m4f"))
    lib = tmp_path / "micro_ros_uros"
    m7, m4f = ws / "build" / "cortex-m7", ws / "build" / "cortex-m4f"
    run_uros("export", "arduino", "--from", str(m7), "--from", str(m4f), "--output", str(lib))
    props = (lib / "library.properties").read_text()
    assert "precompiled=true\n" in props and "ldflags=-lmicroros\n" in props
    # issue 34, item 5: the M7 (fpv5-d16) library where Teensy 4 looks, the M4F one where STM32duino
    # does, each also in src/<mcu>/ (PlatformIO's and arduino-cli >= #3199's fallback)
    assert "architectures=avr,stm32\n" in props
    for folder, output in (
        ("imxrt1062/fpv5-d16-hard", m7),
        ("imxrt1062", m7),
        ("cortex-m4/fpv4-sp-d16-hard", m4f),
        ("cortex-m4", m4f),
    ):
        assert (lib / "src" / folder / "libmicroros.a").read_bytes() == (
            output / "libmicroros.a"
        ).read_bytes()
    assert not (lib / "src/cortex-m7").exists()  # STM32duino's M7 boards compile fpv5-sp-d16
    assert (lib / "src/fx_core/core.h").is_file() and (lib / "src/micro_ros_uros.h").is_file()
    # two include trees that differ cannot make one library
    other = tmp_path / "other"
    shutil.copytree(m4f, other)
    (other / "include/fx_core/core.h").write_text("/* edited */\n")
    proc = run_uros(
        "export",
        "arduino",
        "--from",
        str(m7),
        "--from",
        str(other),
        "--output",
        str(tmp_path / "x"),
        check=False,
    )
    assert (
        proc.returncode == 2
        and "its headers differ" in proc.stderr
        and "include/fx_core/core.h" in proc.stderr
    )
    assert not (tmp_path / "x").exists()


def test_platformio_reads_the_library_manifest(m7_output: Path, tmp_path: Path) -> None:
    """Issue 20, item 1: library.json validated by PlatformIO's own manifest schema (platformio from
    pyproject's test extra; test_platformio.py builds the export with `pio run`)."""
    need("pio")
    out = tmp_path / "pio-lib"
    run_uros("export", "platformio", "--from", str(m7_output), "--output", str(out))
    venv_bin = Path(shutil.which("pio") or "pio").resolve().parent
    check = (
        "import json, sys\n"
        "from platformio.package.manifest.parser import ManifestParserFactory\n"
        "from platformio.package.manifest.schema import ManifestSchema\n"
        "# the SPDX list is downloaded from GitHub, which this machine cannot reach: the one id we use\n"
        "ManifestSchema.load_spdx_licenses = staticmethod(lambda: {'licenses': [{'licenseId': 'Apache-2.0'}]})\n"
        "parser = ManifestParserFactory.new_from_dir(sys.argv[1])\n"
        "ManifestSchema().load_manifest(parser.as_dict())  # raises on an invalid manifest\n"
        "print(json.dumps(parser.as_dict(), sort_keys=True))\n"
    )
    done = subprocess.run([str(venv_bin / "python"), "-c", check, str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["name"] == "micro_ros_uros" and data["build"]["includeDir"] == "include"
    assert data["build"]["flags"] == ["-L.", "-lmicroros"] and (out / "libmicroros.a").is_file()
    # and a firmware links with those flags, as PlatformIO passes them from the library's folder
    (tmp_path / "main.c").write_text(_MAIN)
    elf = tmp_path / "app.elf"
    subprocess.run(
        ["arm-none-eabi-gcc", "-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard",
         f"-I{out / data['build']['includeDir']}", str(tmp_path / "main.c"), *data["build"]["flags"],
         "--specs=nosys.specs", "-o", str(elf)],
        cwd=out, check=True,
    )  # fmt: skip
    _calls_the_library(elf)


def test_the_zephyr_module_is_written_beside_the_library(m7_output: Path, tmp_path: Path) -> None:
    out = tmp_path / "zephyr-module"
    run_uros("export", "zephyr", "--from", str(m7_output), "--output", str(out))
    assert (out / "zephyr/module.yml").is_file() and (out / "Kconfig").is_file()
    assert (out / "CMakeLists.txt").is_file() and (out / "libmicroros.a").is_file()
    owned = json.loads((out / ".uros-output").read_text())["files"]
    assert {"zephyr", "Kconfig", "CMakeLists.txt"} <= set(owned)


def test_exports_beside_the_library_survive_the_next_build(built: Callable[[str], Path]) -> None:
    """Issue 34, item 7: the README's flow exports beside the library (`--output build/cortex-m7`);
    the next `uros build` deleted microros.mk, .pc and .ini even when nothing changed. They are
    written again for the new library (the same bytes here), and the build after is up to date."""
    ws = built("core")  # fx_core built for cortex-m7: the package this test edits
    build = fixture_build_args(ws, *UP_TO_CORE)
    out = ws / "build" / "cortex-m7"
    (out / "notes.txt").write_text("mine\n")  # the user's own file beside them
    for kind in ("make", "pkg-config", "meson"):
        run_uros("export", kind, "--output", str(out))
    names = ("microros.mk", "microros.pc", "microros-cross.ini", "notes.txt")
    before = {name: (out / name).read_bytes() for name in names}
    (ws / "mcu_ws/src/fx_core/src/core.c").write_text(
        (ws / "mcu_ws/src/fx_core/src/core.c").read_text() + "\nint fx_core_extra(void) { return 7; }\n"
    )  # a changed library: the exports are rewritten beside it, not dropped
    run_uros(*build)
    assert {name: (out / name).read_bytes() for name in names} == before
    owned = json.loads((out / ".uros-output").read_text())["files"]
    assert {"microros.mk", "microros.pc", "microros-cross.ini"} <= set(owned) and "notes.txt" not in owned
    assert "up to date" in run_uros(*build).stderr


def _consume(kind: str, folder: Path, work: Path) -> None:
    """The real consumer of an export in ``folder`` compiles and links a firmware against it."""
    work.mkdir()
    (work / "main.c").write_text(_MAIN)
    if kind == "cmake":
        (work / "CMakeLists.txt").write_text(
            "cmake_minimum_required(VERSION 3.16)\nproject(p C)\nfind_package(microros CONFIG REQUIRED)\n"
            "add_executable(app main.c)\ntarget_link_libraries(app PRIVATE microros::microros)\n"
        )
        argv = ["cmake", "-S", str(work), "-B", str(work / "b"), "-G", "Ninja", f"-Dmicroros_DIR={folder}"]
        toolchain = _FIRMWARE_TOOLCHAIN.format(flags=" ".join(_M7))
        (work / "tc.cmake").write_text(toolchain)
        subprocess.run(
            [*argv, f"-DCMAKE_TOOLCHAIN_FILE={work / 'tc.cmake'}"], check=True, capture_output=True
        )
        subprocess.run(["cmake", "--build", str(work / "b")], check=True, capture_output=True)
        _calls_the_library(work / "b" / "app")
    elif kind == "pkg-config":  # its answer is for a shell to read, as a Makefile's recipe does
        line = 'eval "arm-none-eabi-gcc main.c $(pkg-config --cflags --libs microros) --specs=nosys.specs -o app.elf"'
        env = {**os.environ, "PKG_CONFIG_PATH": str(folder)}
        subprocess.run(["sh", "-c", line], cwd=work, env=env, check=True)
        _calls_the_library(work / "app.elf")
    elif kind == "make":  # included by its own path (no space in these)
        _make_firmware(work, str(folder))
    else:
        raise AssertionError(f"{kind}: accepted a folder this test expects refused")


@pytest.mark.parametrize("char", ["$", "'", '"', "(", ";", "\\", "é"])
def test_export_folders_with_special_characters_work_or_are_refused(
    m7_output: Path, tmp_path: Path, char: str
) -> None:
    """Issue 34, item 7: an export folder holding one of these was accepted, and pkg-config, Meson or
    CMake then failed on it. Each format's export either works in its real consumer or is refused
    before anything is written, with one line naming the character and the format."""
    need("cmake", "ninja", "make", "pkg-config", "meson", "arm-none-eabi-gcc")
    source = m7_output
    refuses = {
        # '"': CMake's Makefiles generator writes it unescaped (a Ninja build works; one rule for both)
        "cmake": char in ';\\"',
        "pkg-config": char != "é",
        "make": char != "é",
        "meson": True,
    }
    for kind, refused in refuses.items():
        folder = tmp_path / kind / f"micro{char}ros"
        run = run_uros_here if refused else run_uros  # a refusal starts no process: in process
        proc = run("export", kind, "--from", str(source), "--output", str(folder), check=False)
        if refused:
            fmt = {"meson": "Meson", "cmake": "CMake"}.get(kind, kind)
            assert proc.returncode == 2, (kind, proc.stderr)
            first = proc.stderr.splitlines()[0]
            assert first.startswith(f"error: --output {folder}: holds {char!r}, which {fmt} cannot use"), (
                first
            )
            assert not folder.exists()
        else:
            assert proc.returncode == 0, (kind, proc.stderr)
            _consume(kind, folder, tmp_path / f"{kind}-app")


# Zephyr's link rules, as its cmake/modules/extensions.cmake and top-level CMakeLists.txt define
# them (written here from those rules, not copied): libraries on the global ZEPHYR_LIBS list
# (zephyr_library_named, zephyr_library_import) are linked --whole-archive; zephyr_link_libraries,
# zephyr_include_directories and zephyr_ld_options go on the zephyr_interface INTERFACE library.
_ZEPHYR_LIKE = """cmake_minimum_required(VERSION 3.16)
project(zephyr_like C)
add_library(zephyr_interface INTERFACE)
function(zephyr_include_directories)
  target_include_directories(zephyr_interface INTERFACE ${ARGV})
endfunction()
function(zephyr_link_libraries)
  target_link_libraries(zephyr_interface INTERFACE ${ARGV})
endfunction()
function(zephyr_ld_options)
  target_link_options(zephyr_interface INTERFACE ${ARGV})
endfunction()
function(zephyr_library_import name path)
  add_library(${name} STATIC IMPORTED GLOBAL)
  set_target_properties(${name} PROPERTIES IMPORTED_LOCATION ${path})
  set_property(GLOBAL APPEND PROPERTY ZEPHYR_LIBS ${name})
endfunction()
macro(zephyr_library_named name)
  add_library(${name} STATIC "")
  target_link_libraries(${name} PUBLIC zephyr_interface)
  set_property(GLOBAL APPEND PROPERTY ZEPHYR_LIBS ${name})
  set(ZEPHYR_CURRENT_LIBRARY ${name})
endmacro()
function(zephyr_library_sources)
  target_sources(${ZEPHYR_CURRENT_LIBRARY} PRIVATE ${ARGV})
endfunction()
include_directories(${CMAKE_CURRENT_SOURCE_DIR}/kernel_include)
set(CONFIG_MICRO_ROS_UROS y)
add_subdirectory(${MODULE} module)
zephyr_library_named(app)
zephyr_library_sources(${CMAKE_CURRENT_SOURCE_DIR}/main.c)
get_property(zephyr_libs GLOBAL PROPERTY ZEPHYR_LIBS)
add_executable(zephyr.elf ${CMAKE_CURRENT_SOURCE_DIR}/kernel.c)
target_link_libraries(zephyr.elf PRIVATE -Wl,--whole-archive ${zephyr_libs} -Wl,--no-whole-archive zephyr_interface)
"""
_ZEPHYR_KERNEL = """#include <errno.h>
#include <time.h>
#include <zephyr/kernel.h>
int64_t k_uptime_ticks(void) { return 12345; }
uint64_t k_ticks_to_ns_floor64(uint64_t t) { return t * 100000U; }
/* Zephyr's POSIX clock: CLOCK_MONOTONIC is 4, clock 0 is EINVAL */
int clock_gettime(clockid_t id, struct timespec *tp) {
  if (id != 4) { errno = EINVAL; return -1; }
  tp->tv_sec = 0; tp->tv_nsec = 0; return 0;
}
"""


def test_the_zephyr_module_links_only_what_the_firmware_uses(m7_output: Path, tmp_path: Path) -> None:
    """Issue 34, item 4: by Zephyr's link rules (above), the module's library is an ordinary archive
    (zephyr_library_import made it whole-archive: every member in every firmware), and micro-ROS's
    clock_gettime(0, ...) reaches the module's clock shim, not Zephyr's clock (EINVAL for 0)."""
    need("cmake", "ninja", "arm-none-eabi-gcc")
    module = tmp_path / "zephyr-module"
    run_uros("export", "zephyr", "--from", str(m7_output), "--output", str(module))
    app = tmp_path / "app"
    (app / "kernel_include/zephyr").mkdir(parents=True)
    (app / "kernel_include/zephyr/kernel.h").write_text(
        "#include <stdint.h>\nint64_t k_uptime_ticks(void);\nuint64_t k_ticks_to_ns_floor64(uint64_t t);\n"
    )
    (app / "kernel.c").write_text(_ZEPHYR_KERNEL)
    (app / "main.c").write_text(
        '#include "fx_time/time_now.h"\n#include "fx_core/core.h"\n'
        "int main(void) { return fx_core_add(1, 2) + (int)fx_time_now_ns(); }\n"
    )
    (app / "CMakeLists.txt").write_text(_ZEPHYR_LIKE)
    (app / "tc.cmake").write_text(
        _FIRMWARE_TOOLCHAIN.format(flags=" ".join(_M7)).replace(
            "--specs=nosys.specs", "--specs=nosys.specs -Wl,--gc-sections -Wl,-Map=zephyr.map"
        )
    )
    build = tmp_path / "b"
    subprocess.run(
        ["cmake", "-S", str(app), "-B", str(build), "-G", "Ninja", f"-DMODULE={module}",
         f"-DCMAKE_TOOLCHAIN_FILE={app / 'tc.cmake'}"],
        check=True, capture_output=True,
    )  # fmt: skip
    done = subprocess.run(["cmake", "--build", str(build)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    elf = build / "zephyr.elf"
    nm = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    assert " T fx_core_add" in nm and " T fx_time_now_ns" in nm
    # members the firmware does not use are not even loaded (whole-archive loaded every one: what
    # --gc-sections cannot drop of them, constructors and what they reach, stayed in the firmware)
    linked = (build / "zephyr.map").read_text()
    assert "libfx_core__core.c.obj" in linked
    for unused in ("libfx_flat__flat.c.obj", "common.c.obj", "libfx_util__scale.c.obj"):
        assert unused not in linked, unused
    # the library's clock_gettime(0, ...) goes to the module's shim
    dump = subprocess.run(
        ["arm-none-eabi-objdump", "-d", str(elf)], capture_output=True, text=True, check=True
    ).stdout
    body = dump.split("<fx_time_now_ns>:", 1)[1].split("\n\n", 1)[0]
    assert "<__wrap_clock_gettime>" in body, body
    assert " T __wrap_clock_gettime" in nm


@pytest.mark.parametrize("flag", ["-DBOARD=$HOME", "-DNOTE=a#b", "-DF=(x)"])
def test_pkg_config_refuses_flags_it_cannot_pass_on(m7_output: Path, tmp_path: Path, flag: str) -> None:
    """Issue 34, item 7: pkgconf prints '$' and '(' bare into the compile line a shell reads, and
    '#' in a variable's line is a comment (measured: --cflags printed nothing); the '$$' escape
    uros wrote stayed two. A CPU flag pkg-config cannot carry is refused, one line naming it."""
    need("pkg-config")
    src = tmp_path / "out"
    shutil.copytree(m7_output, src)
    info = json.loads((src / "build-info.json").read_text())
    info["flags"]["cpu"].append(flag)
    (src / "build-info.json").write_text(json.dumps(info))
    proc = run_uros_here(  # refused before any process starts
        "export", "pkg-config", "--from", str(src), "--output", str(tmp_path / "pc"), check=False
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines()[0].startswith(f"error: flag {flag!r}: holds "), proc.stderr
    assert "which pkg-config cannot pass on" in proc.stderr
    assert not (tmp_path / "pc").exists()  # refused before the output was copied
