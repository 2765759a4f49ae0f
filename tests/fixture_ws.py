"""Generate small micro-ROS-shaped colcon workspaces for the integration tests.

The packages are plain CMake packages (colcon's `cmake` build type) with package.xml
dependencies, ROS-2-style nested include trees (include/<pkg>/<pkg>/...), and the archive traps
the merge must survive: the same source file name in two packages, and two same-named objects in
one library (src/a/common.c and src/b/common.c).
"""

from __future__ import annotations

import textwrap
from pathlib import Path


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")


def _package_xml(name: str, deps: list[str]) -> str:
    dep_lines = "\n".join(f"  <depend>{d}</depend>" for d in deps)
    return f"""\
<?xml version="1.0"?>
<package format="3">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>uros test fixture {name}</description>
  <maintainer email="dev@example.com">uros tests</maintainer>
  <license>Apache-2.0</license>
{dep_lines}
  <export>
    <build_type>cmake</build_type>
  </export>
</package>
"""


def _cmake(name: str, sources: list[str], deps: list[str], nested: bool = True, extra: str = "") -> str:
    finds = "\n".join(f"find_package({d} REQUIRED)" for d in deps)
    links = " ".join(f"{d}::{d}" for d in deps)
    inc_dest = f"include/{name}" if nested else "include"
    return f"""\
cmake_minimum_required(VERSION 3.16)
project({name} C)
{finds}
{extra}
add_library({name} STATIC {" ".join(sources)})
target_include_directories({name} PUBLIC
  $<BUILD_INTERFACE:${{CMAKE_CURRENT_SOURCE_DIR}}/include>
  $<INSTALL_INTERFACE:{inc_dest}>)
{f"target_link_libraries({name} PUBLIC {links})" if deps else ""}
install(TARGETS {name} EXPORT {name}Targets ARCHIVE DESTINATION lib)
install(DIRECTORY include/ DESTINATION {inc_dest})
install(EXPORT {name}Targets NAMESPACE {name}:: DESTINATION share/{name}/cmake)
file(WRITE ${{CMAKE_CURRENT_BINARY_DIR}}/{name}Config.cmake
  "include(CMakeFindDependencyMacro)\\n{"".join(f"find_dependency({d})" + chr(92) + "n" for d in deps)}include(\\${{CMAKE_CURRENT_LIST_DIR}}/cmake/{name}Targets.cmake)\\n")
install(FILES ${{CMAKE_CURRENT_BINARY_DIR}}/{name}Config.cmake DESTINATION share/{name})
"""


def make_fixture_workspace(root: Path) -> Path:
    """Create <root>/mcu_ws with five packages; return root."""
    src = root / "mcu_ws" / "src"

    # fx_core: nested headers, a util.c (the same file name as fx_util's)
    core = src / "fx_core"
    _write(core / "package.xml", _package_xml("fx_core", []))
    _write(
        core / "CMakeLists.txt",
        _cmake(
            "fx_core",
            ["src/core.c", "src/util.c"],
            [],
            # FX_SLOW: a configure step that takes long enough to interrupt (tests of Ctrl-C).
            # FX_SLEEP=<seconds>: the same through `sleep`, a process a test can find by its unique argument.
            extra='option(FX_SLOW "" OFF)\nif(FX_SLOW)\n  execute_process(COMMAND ${CMAKE_COMMAND} -E sleep 60)\nendif()\n'
            "if(FX_SLEEP)\n  execute_process(COMMAND sleep ${FX_SLEEP})\nendif()",
        ),
    )
    _write(
        core / "include/fx_core/core.h",
        """
        #ifndef FX_CORE_CORE_H
        #define FX_CORE_CORE_H
        int fx_core_add(int a, int b);
        int fx_core_util(void);
        #endif
    """,
    )
    _write(core / "include/fx_core/detail/version.h", "#define FX_CORE_VERSION 1\n")
    _write(
        core / "src/core.c", '#include "fx_core/core.h"\nint fx_core_add(int a, int b) { return a + b; }\n'
    )
    _write(core / "src/util.c", '#include "fx_core/core.h"\nint fx_core_util(void) { return 1; }\n')

    # fx_util: depends on fx_core, has its own util.c -> util.c.obj in two archives
    util = src / "fx_util"
    _write(util / "package.xml", _package_xml("fx_util", ["fx_core"]))
    _write(util / "CMakeLists.txt", _cmake("fx_util", ["src/util.c", "src/scale.c"], ["fx_core"]))
    _write(util / "include/fx_util/util.h", "int fx_util_twice(int x);\ndouble fx_util_scale(double x);\n")
    _write(
        util / "src/util.c",
        """
        #include <fx_core/core.h>
        #include "fx_util/util.h"
        int fx_util_twice(int x) { return fx_core_add(x, x); }
    """,
    )
    _write(
        util / "src/scale.c",
        '#include "fx_util/util.h"\ndouble fx_util_scale(double x) { return x * 1.5; }\n',
    )

    # fx_dup: two same-named objects (common.c.obj) inside one archive
    dup = src / "fx_dup"
    _write(dup / "package.xml", _package_xml("fx_dup", []))
    _write(dup / "CMakeLists.txt", _cmake("fx_dup", ["src/a/common.c", "src/b/common.c"], []))
    _write(dup / "include/fx_dup/dup.h", "int fx_dup_a(void);\nint fx_dup_b(void);\n")
    _write(dup / "src/a/common.c", "int fx_dup_a(void) { return 'a'; }\n")
    _write(dup / "src/b/common.c", "int fx_dup_b(void) { return 'b'; }\n")

    # fx_time: what rcutils does on newlib: needs CLOCK_MONOTONIC defined and clock_gettime
    # declared (implicit declarations are errors here, as in GCC >= 14), and a meta option.
    tm = src / "fx_time"
    _write(tm / "package.xml", _package_xml("fx_time", ["fx_core"]))
    _write(
        tm / "CMakeLists.txt",
        _cmake(
            "fx_time",
            ["src/time.c"],
            ["fx_core"],
            extra=textwrap.dedent("""
            option(FX_TIME_ENABLE "set by colcon.meta" OFF)
            if(NOT FX_TIME_ENABLE)
              message(FATAL_ERROR "FX_TIME_ENABLE is OFF: the colcon.meta did not reach fx_time")
            endif()
            add_compile_options(-Werror=implicit-function-declaration)
        """),
        ),
    )
    _write(tm / "include/fx_time/time_now.h", "long long fx_time_now_ns(void);\n")
    _write(
        tm / "src/time.c",
        """
        #include <time.h>
        #include "fx_time/time_now.h"
        #ifndef CLOCK_MONOTONIC
        #error "CLOCK_MONOTONIC is not defined: the micro-ROS-only flags did not reach this package"
        #endif
        long long fx_time_now_ns(void) {
          struct timespec ts;
          clock_gettime(CLOCK_MONOTONIC, &ts);
          return (long long)ts.tv_sec * 1000000000LL + ts.tv_nsec;
        }
    """,
    )

    # fx_flat: a flat include layout (like Micro-CDR's include/ucdr/)
    flat = src / "fx_flat"
    _write(flat / "package.xml", _package_xml("fx_flat", ["fx_util", "fx_dup"]))
    _write(flat / "CMakeLists.txt", _cmake("fx_flat", ["src/flat.c"], ["fx_util", "fx_dup"], nested=False))
    _write(flat / "include/fxflat/flat.h", "int fx_flat_sum(void);\n")
    _write(
        flat / "src/flat.c",
        """
        #include <fx_util/util.h>
        #include <fx_dup/dup.h>
        #include "fxflat/flat.h"
        int fx_flat_sum(void) { return fx_util_twice(fx_dup_a()) + fx_dup_b(); }
    """,
    )

    # fx_skip_cpp: matched by --packages-ignore-regex=.*_cpp; it would fail if built.
    skip = src / "fx_skip_cpp"
    _write(skip / "package.xml", _package_xml("fx_skip_cpp", []))
    _write(
        skip / "CMakeLists.txt",
        "cmake_minimum_required(VERSION 3.16)\nproject(fx_skip_cpp C)\n"
        'message(FATAL_ERROR "packages ending in _cpp must be ignored")\n',
    )

    # fx_host_py: a pure-Python package nothing compiled needs (like ros2trace): uros skips it;
    # building it fails.
    hostpy = src / "fx_host_py"
    _write(
        hostpy / "package.xml",
        _package_xml("fx_host_py", []).replace("<build_type>cmake<", "<build_type>ament_python<"),
    )
    _write(hostpy / "resource" / "fx_host_py", "")
    _write(
        hostpy / "setup.py",
        """
        import sys

        from setuptools import setup

        if {"egg_info", "build", "install", "develop"} & set(sys.argv[1:]):
            raise SystemExit("fx_host_py must not be built: it puts nothing into libmicroros.a")
        setup(name="fx_host_py", version="0.1.0", packages=[])
        """,
    )

    _write(
        root / "fixture.meta",
        """
        {"names": {"fx_time": {"cmake-args": ["-DFX_TIME_ENABLE=ON"]}}}
    """,
    )
    return root


def fixture_build_args(
    ws: Path, *more: str, meta: Path | None = None, toolchain: str = "cortex-m7"
) -> list[str]:
    """`uros build` of the whole fixture workspace for cortex-m7 (its fixture.meta turns every
    package on), then ``more``."""
    return [
        "build",
        "--toolchain",
        toolchain,
        "--workspace",
        str(ws),
        "--meta",
        str(meta or ws / "fixture.meta"),
        *more,
    ]


# `uros build` of fx_core alone (and what it needs: nothing), the quickest real build
UP_TO_CORE = ("--packages-up-to", "fx_core")
# `uros build` of fx_time and fx_core (the C library's micro-ROS-only flags reach fx_time's
# clock_gettime): the quickest build that needs those flags; its library's members
UP_TO_TIME = ("--packages-up-to", "fx_time")
TIME_MEMBERS = 3  # core.c, util.c | time.c

# The built fixture variants of the integration tests (their conftest's `built`), by the arguments
# of build_fixture that build them: each is made and built once per worker, by the first test that
# asks, then every test that asks gets a copy restored at the path it was built in (nothing
# relocates: test_build_fixture checks that the same command finds it up to date).
VARIANTS: dict[str, tuple[str, ...]] = {
    "m7": (),  # the whole fixture for cortex-m7 with its fixture.meta
    "core": UP_TO_CORE,  # fx_core alone
}


# Expected facts of the fixture build
FIXTURE_SKIPPED_PYTHON = ["fx_host_py"]
FIXTURE_LIBRARIES = ("libfx_core.a", "libfx_dup.a", "libfx_flat.a", "libfx_time.a", "libfx_util.a")
FIXTURE_MEMBERS = 8  # core.c, util.c | common.c x2 | flat.c | time.c | util.c, scale.c
FIXTURE_SYMBOLS = (
    "fx_core_add",
    "fx_core_util",
    "fx_dup_a",
    "fx_dup_b",
    "fx_flat_sum",
    "fx_time_now_ns",
    "fx_util_twice",
    "fx_util_scale",
)


def add_board_package(root: Path) -> None:
    """fx_board: compiles only when BOARD_NAME arrives as one intact define (tests of --cflags)."""
    board = root / "mcu_ws" / "src" / "fx_board"
    _write(board / "package.xml", _package_xml("fx_board", []))
    _write(board / "CMakeLists.txt", _cmake("fx_board", ["src/board.c"], []))
    _write(board / "include/fx_board/board.h", "extern const char fx_board_name[];\n")
    _write(
        board / "src/board.c",
        """
        #include "fx_board/board.h"
        #ifndef BOARD_NAME
        #error "BOARD_NAME is not defined: --cflags did not reach the compiler"
        #endif
        const char fx_board_name[] = BOARD_NAME;
    """,
    )


def add_vendor_package(root: Path) -> None:
    """fx_vendor: a vendor package as libyaml_vendor is, an ExternalProject_Add of an upstream CMake
    project (here a folder beside it, no network) configured in a build tree of its own, nested in the
    package's (with a CMakeCache.txt of its own), and installed from a staging folder."""
    vendor = root / "mcu_ws" / "src" / "fx_vendor"
    _write(vendor / "package.xml", _package_xml("fx_vendor", []))
    _write(
        vendor / "CMakeLists.txt",
        """
        cmake_minimum_required(VERSION 3.16)
        project(fx_vendor NONE)
        include(ExternalProject)
        ExternalProject_Add(fx_upstream
          SOURCE_DIR ${CMAKE_CURRENT_SOURCE_DIR}/upstream
          CMAKE_ARGS
            -DCMAKE_TOOLCHAIN_FILE=${CMAKE_TOOLCHAIN_FILE}
            -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE}
            -DCMAKE_INSTALL_PREFIX=${CMAKE_CURRENT_BINARY_DIR}/upstream_install)
        install(DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}/upstream_install/ DESTINATION ${CMAKE_INSTALL_PREFIX})
        """,
    )
    _write(
        vendor / "upstream" / "CMakeLists.txt",
        """
        cmake_minimum_required(VERSION 3.16)
        project(fx_upstream C)
        add_library(fx_upstream STATIC upstream.c)
        install(TARGETS fx_upstream ARCHIVE DESTINATION lib)
        install(FILES upstream.h DESTINATION include/fx_upstream)
        """,
    )
    _write(vendor / "upstream" / "upstream.h", "int fx_upstream_value(void);\n")
    _write(
        vendor / "upstream" / "upstream.c",
        '#include "upstream.h"\nconst char *fx_upstream_file(void) { return __FILE__; }\n'
        "int fx_upstream_value(void) { return 7; }\n",
    )


def add_plain_package(folder: Path, name: str, c_text: str) -> Path:
    """A one-file colcon cmake package ``name`` in ``folder`` (made), compiling ``c_text``."""
    _write(folder / "package.xml", _package_xml(name, []))
    _write(
        folder / "CMakeLists.txt",
        f"cmake_minimum_required(VERSION 3.16)\nproject({name} C)\nadd_library({name} STATIC {name}.c)\n"
        f"install(TARGETS {name} ARCHIVE DESTINATION lib)\n",
    )
    (folder / f"{name}.c").write_text(c_text, encoding="utf-8")
    return folder


def add_twin_packages(root: Path) -> None:
    """fx_twin_a and fx_twin_b: two packages whose objects define one global function, as std_msgs'
    and example_interfaces' introspection code once did (micro_ros_arduino#910): a normal link takes
    one member and never notices, a --whole-archive link fails with "multiple definition". Each also
    defines a weak hook, which collides with nothing."""
    for side in ("a", "b"):
        name = f"fx_twin_{side}"
        add_plain_package(
            root / "mcu_ws" / "src" / name,
            name,
            f'const char *fx_twin_type_support(void) {{ return "{side}"; }}\n'
            f"__attribute__((weak)) int fx_twin_hook(void) {{ return '{side}'; }}\n"
            f"int {name}_only(void) {{ return 1; }}\n",
        )


def add_message_package(root: Path) -> None:
    """fx_msgs: message headers in rosidl_generator_c's shape (``include/fx_msgs/msg/<type>.h`` and
    ``detail/<type>__struct.h``, bounds as its ``__MAX_SIZE`` enums), written here rather than
    generated (no rosidl in the fixture), and one object so that it installs a library.
    Small (4 bytes), Big (800: more than one 512-byte MTU), Huge (4,096: more than 512 x 4),
    Bounded (a bounded sequence of 10 Big: 8,004) and Text (an unbounded string)."""
    folder = root / "mcu_ws" / "src" / "fx_msgs"
    add_plain_package(folder, "fx_msgs", "int fx_msgs_present(void) { return 1; }\n")
    with (folder / "CMakeLists.txt").open("a", encoding="utf-8") as cmake:
        cmake.write("install(DIRECTORY include/ DESTINATION include)\n")
    structs = {
        "small": "int32_t value;",
        "big": "double samples[100];",
        "huge": "uint8_t data[4096];",
        "bounded": "fx_msgs__msg__Big__Sequence items;",
        "text": "rosidl_runtime_c__String text;",
    }
    for stem, body in structs.items():
        name = f"fx_msgs__msg__{stem.capitalize()}"
        bound = f"enum\n{{\n  {name}__items__MAX_SIZE = 10\n}};\n" if stem == "bounded" else ""
        _write(
            folder / "include" / "fx_msgs" / "msg" / f"{stem}.h",
            f'#include "fx_msgs/msg/detail/{stem}__struct.h"\n',
        )
        _write(
            folder / "include" / "fx_msgs" / "msg" / "detail" / f"{stem}__struct.h",
            f"{bound}typedef struct {name}\n{{\n  {body}\n}} {name};\n\n"
            f"typedef struct {name}__Sequence\n{{\n  {name} * data;\n  size_t size;\n  size_t capacity;\n}} {name}__Sequence;\n",
        )
