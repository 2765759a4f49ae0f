"""`uros build --rtos freertos`: micro-ROS compiled against FreeRTOS's headers, through the real
CLI, colcon, CMake and arm-none-eabi-gcc (docs/rtos.md).

CI has no FreeRTOS-Kernel, so the kernel is a stand-in the test writes (tests/fixture_rtos.py:
FreeRTOS.h, semphr.h and the port's portmacro.h in FreeRTOS-Kernel's layout, a line each), and the
package compiled against it is the test's own: its C source includes FreeRTOS.h and semphr.h and
names a function after a FreeRTOSConfig.h value. Proven here: the kernel's, the port's and the
config's folders and PLATFORM_NAME_FREERTOS reach the micro-ROS compile and not the firmware's
toolchain file; a changed FreeRTOSConfig.h rebuilds (the library's symbols show the new value);
build-info.json and `uros info` say what was used; the exported CMake package refuses a firmware
without FreeRTOS at configure time, in one line, and hands one with it the define; bad input is one
line naming the flag. test_real_humble_multithread_on_freertos builds real Humble against a real
FreeRTOS-Kernel (UROS_FREERTOS, UROS_HUMBLE_WS) and reads the multithread code's calls from the
library's bytes.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from fixture_rtos import FREERTOS_CONFIG_H, make_standin_kernel, write_config
from fixture_ws import add_plain_package
from uros_helpers import need, once_then_restored, run_uros, run_uros_here

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

PORT = "GCC/ARM_CM7/r0p1"  # the table's port for cortex-m7 (meta/rtos/freertos.yaml)

FX_RTOS_C = """\
#include "FreeRTOS.h"
#include "semphr.h"
#if !defined(PLATFORM_NAME_FREERTOS)
#error "PLATFORM_NAME_FREERTOS did not reach the micro-ROS compile"
#endif
#if !defined(FX_PORT_GCC_ARM_CM7_R0P1)
#error "the Cortex-M7 port's portmacro.h was not found"
#endif
#define CAT(a, b) a##b
#define NAME(v) CAT(fx_rtos_tick_, v)
SemaphoreHandle_t fx_rtos_mutex;
int NAME(configTICK_RATE_HZ)(void) { return 1; }
"""


def _setup(tmp: Path) -> tuple[Path, Path, Path]:
    """(workspace, kernel, config folder): a one-package colcon workspace whose package compiles
    against FreeRTOS, the stand-in kernel, a FreeRTOSConfig.h with configTICK_RATE_HZ 1000."""
    ws = tmp / "ws"
    add_plain_package(ws / "mcu_ws" / "src" / "fx_rtos", "fx_rtos", FX_RTOS_C)
    kernel = make_standin_kernel(tmp / "FreeRTOS-Kernel", PORT)
    config = write_config(tmp / "app" / "Core" / "Inc")
    return ws, kernel, config


def _symbols(lib: Path) -> str:
    return subprocess.run(
        ["arm-none-eabi-nm", "-g", str(lib)], check=True, capture_output=True, text=True,
        env={**os.environ, "LC_ALL": "C"},
    ).stdout  # fmt: skip


def _firmware(
    tmp: Path, out: Path, kernel: Path, config: Path, rtos: str
) -> subprocess.CompletedProcess[str]:
    """A firmware project configured (and built) against the output's toolchain file and CMake
    package: FreeRTOS as an INTERFACE target freertos_kernel (what docs/rtos.md tells a firmware
    whose FreeRTOS is plain sources) declared ``before`` or ``after`` find_package, or ``none``."""
    src = tmp / f"fw-{rtos}"
    src.mkdir()
    target = (
        "add_library(freertos_kernel INTERFACE)\n"
        f'target_include_directories(freertos_kernel INTERFACE "{kernel}/include" "{kernel}/portable/{PORT}" "{config}")\n'
    )
    (src / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(fw C)\n" + (target if rtos == "before" else "")
        + "find_package(microros CONFIG REQUIRED)\nadd_library(app STATIC app.c)\n"
        "target_link_libraries(app PRIVATE microros::microros)\n" + (target if rtos == "after" else "")
    )  # fmt: skip
    (src / "app.c").write_text(
        '#include "FreeRTOS.h"\n#ifndef PLATFORM_NAME_FREERTOS\n#error "the package gave no define"\n#endif\n'
        "int app_tick(void) { return configTICK_RATE_HZ; }\n"
    )
    build = src / "build"
    configure = subprocess.run(
        ["cmake", "-S", str(src), "-B", str(build), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={out}"],
        capture_output=True, text=True,
    )  # fmt: skip
    if configure.returncode != 0:
        return configure
    return subprocess.run(["cmake", "--build", str(build)], capture_output=True, text=True)


def _rtos_build(ws: Path, kernel: Path, config: Path) -> list[str]:
    return ["build", "--toolchain", "cortex-m7", "-w", str(ws), "--rtos", "freertos",
            "--rtos-dir", str(kernel), "--rtos-config", str(config)]  # fmt: skip


@pytest.fixture(scope="module")
def _built_once(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    need("arm-none-eabi-gcc", "cmake", "ninja")
    root = tmp_path_factory.mktemp("rtos")
    ws, kernel, config = _setup(root / "live")
    done = run_uros(*_rtos_build(ws, kernel, config))
    shutil.copytree(root / "live", root / "snapshot", symlinks=True)
    return root, done.stderr


@pytest.fixture
def built_once(_built_once: tuple[Path, str]) -> tuple[Path, str]:
    """The _setup workspace built with the flags of an RTOS build, once for this module, restored
    for this test at the path it was built in (it changes the config): (that folder, the first
    build's stderr)."""
    root, stderr = _built_once
    return once_then_restored(root / "snapshot", root / "live"), stderr


def test_freertos_headers_reach_the_micro_ros_compile_only(
    built_once: tuple[Path, str], tmp_path: Path
) -> None:
    live, first_stderr = built_once  # the first build: the module's, done the same way
    ws, kernel, config = live / "ws", live / "FreeRTOS-Kernel", live / "app" / "Core" / "Inc"
    build = _rtos_build(ws, kernel, config)
    assert f"RTOS freertos: kernel {kernel}, port {PORT}, config {config}" in first_stderr
    out = ws / "build" / "cortex-m7"
    assert "T fx_rtos_tick_1000" in _symbols(out / "libmicroros.a")

    info = json.loads((out / "build-info.json").read_text())
    first = info["rtos"]
    assert {k: v for k, v in first.items() if k != "headers_sha256"} == {
        "name": "freertos", "kernel": str(kernel), "port": PORT, "config": str(config),
    }  # fmt: skip
    assert len(first["headers_sha256"]) == 64
    # the folders are micro-ROS's alone: the firmware's toolchain file has none of them
    assert str(kernel) in (ws / ".uros" / "targets" / "cortex-m7" / "toolchain.cmake").read_text()
    firmware_toolchain = (out / "toolchain.cmake").read_text()
    assert str(kernel) not in firmware_toolchain and "PLATFORM_NAME_FREERTOS" not in firmware_toolchain

    shown = run_uros("info", str(out)).stdout
    assert f"rtos       freertos: kernel {kernel}, port {PORT}, config {config}" in shown
    assert json.loads(run_uros("info", "--json", str(out)).stdout)["rtos"] == first

    assert "up to date" in run_uros(*build).stderr
    # a changed FreeRTOSConfig.h is a changed input: rebuilt, and the library says the new value
    write_config(config, "#define configTICK_RATE_HZ 500\n")
    again = run_uros(*build)
    assert "changed since the last build: RTOS" in again.stderr
    symbols = _symbols(out / "libmicroros.a")
    assert "T fx_rtos_tick_500" in symbols and "fx_rtos_tick_1000" not in symbols
    assert (
        json.loads((out / "build-info.json").read_text())["rtos"]["headers_sha256"] != first["headers_sha256"]
    )

    # the CMake package: a firmware without FreeRTOS stops at configure, in one line naming the fix
    bare = _firmware(tmp_path, out, kernel, config, "none")
    assert bare.returncode != 0
    lines = [line for line in bare.stderr.splitlines() if "microros:" in line]
    assert len(lines) == 1, bare.stderr
    assert (
        "built for FreeRTOS" in lines[0]
        and "freertos_kernel" in lines[0]
        and "MICROROS_FREERTOS_TARGET" in lines[0]
    )
    # with FreeRTOS, before or after find_package (CMake >= 3.19), the firmware's compile gets
    # FreeRTOS's folders and the library's define
    for where in ("before", "after"):
        with_rtos = _firmware(tmp_path, out, kernel, config, where)
        assert with_rtos.returncode == 0, with_rtos.stdout + with_rtos.stderr
    text = (out / "microros.cmake").read_text()
    assert 'set(MICROROS_RTOS "freertos")' in text


def test_uros_yaml_names_the_rtos(built_once: tuple[Path, str]) -> None:
    """The same keys in uros.yaml, folders relative to the workspace (built here after the module's
    build with the flags: uros.yaml is a changed input, so built again from it)."""
    live, _ = built_once
    ws, kernel, config = live / "ws", live / "FreeRTOS-Kernel", live / "app" / "Core" / "Inc"
    (ws / "uros.yaml").write_text(
        "target: cortex-m7\nrtos: freertos\nrtos_dir: ../FreeRTOS-Kernel\nrtos_config: ../app/Core/Inc\n"
    )
    again = run_uros("build", "-w", str(ws))
    assert "changed since the last build:" in again.stderr and "workspace settings" in again.stderr
    out = ws / "build" / "cortex-m7"
    rtos = json.loads((out / "build-info.json").read_text())["rtos"]
    assert (rtos["kernel"], rtos["config"]) == (str(kernel), str(config))
    assert "T fx_rtos_tick_1000" in _symbols(out / "libmicroros.a")


def test_a_bare_metal_library_says_no_rtos(m7_build: Path) -> None:
    # the fixture built for cortex-m7 without --rtos (restored, not built again: only read here)
    out = m7_build / "build" / "cortex-m7"
    assert json.loads((out / "build-info.json").read_text())["rtos"] is None
    assert "rtos       none (bare metal)" in run_uros("info", str(out)).stdout
    assert 'set(MICROROS_RTOS "")' in (out / "microros.cmake").read_text()


@pytest.mark.parametrize(
    ("case", "flag", "fix"),
    [
        ("no FreeRTOS.h", "--rtos-dir", "include/FreeRTOS.h"),
        ("the include folder", "--rtos-dir", "the folder above include/"),
        ("no FreeRTOSConfig.h", "--rtos-config", "FreeRTOSConfig.h"),
        ("no port folder", "--rtos-port", "--rtos-port"),
        ("no port for the core", "--rtos freertos", "--rtos-port"),
        ("no kernel given", "--rtos freertos", "--rtos-dir KERNEL"),
        ("a folder without --rtos", "--rtos-dir", "--rtos freertos"),
        ("multithread without an RTOS", "UCLIENT_PROFILE_MULTITHREAD=ON", "--rtos freertos"),
        ("uros.yaml's folder", "uros.yaml: rtos_dir", "include/FreeRTOS.h"),
    ],
)
def test_bad_rtos_input_is_one_line_naming_the_flag(tmp_path: Path, case: str, flag: str, fix: str) -> None:
    """Answered before anything runs (run_uros_here refuses to start a process)."""
    ws, kernel, config = _setup(tmp_path)
    target = ["--toolchain", "cortex-m7"]
    rtos = ["--rtos", "freertos", "--rtos-dir", str(kernel), "--rtos-config", str(config)]
    if case == "no FreeRTOS.h":
        rtos[3] = str(tmp_path / "app")
    elif case == "the include folder":
        rtos[3] = str(kernel / "include")
    elif case == "no FreeRTOSConfig.h":
        rtos[5] = str(kernel)
    elif case == "no port folder":
        rtos += ["--rtos-port", "GCC/ARM_CM4F"]
    elif case == "no port for the core":
        target = ["--toolchain", "esp8266"]  # Xtensa lx106: FreeRTOS-Kernel has no GCC port for it
    elif case == "no kernel given":
        rtos = rtos[:2] + rtos[4:]
    elif case == "a folder without --rtos":
        rtos = rtos[2:4]
    elif case == "multithread without an RTOS":
        rtos = ["--set", "microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD=ON"]
    elif case == "uros.yaml's folder":
        (ws / "uros.yaml").write_text("rtos: freertos\nrtos_dir: ../app\nrtos_config: ../app/Core/Inc\n")
        rtos = []
    done = run_uros_here("build", *target, "-w", str(ws), *rtos, check=False)
    assert done.returncode == 2, done.stdout + done.stderr
    error = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(error) == 1 and flag in error[0], done.stderr
    assert fix in done.stderr
    assert not (ws / "build").exists()


# A real FreeRTOS-Kernel under real Humble: the multithread profile's code, read from the library's bytes.
FREERTOS = os.environ.get("UROS_FREERTOS")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")


@pytest.mark.skipif(
    not (FREERTOS and HUMBLE_WS and os.environ.get("UROS_MIRROR")),
    reason="set UROS_MIRROR, UROS_FREERTOS (a FreeRTOS-Kernel V11 checkout) and UROS_HUMBLE_WS (a built Humble workspace)",
)
def test_real_humble_multithread_on_freertos(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake", "ninja")
    assert FREERTOS and HUMBLE_WS
    ws = tmp_path / "ws"
    subprocess.run(["cp", "-a", HUMBLE_WS, str(ws)], check=True)  # a copy: never build in the shared one
    config = write_config(tmp_path / "config", FREERTOS_CONFIG_H)
    run_uros(
        # the core, std_msgs and the workspace's extra packages (not every package it holds)
        "build", "--toolchain", "cortex-m7", "-w", str(ws), "-j", "2", "--packages", "std_msgs",
        "--rtos", "freertos", "--rtos-dir", FREERTOS, "--rtos-config", str(config),
        "--set", "microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD=ON",
    )  # fmt: skip
    out = ws / "build" / "cortex-m7"
    lib = out / "libmicroros.a"
    members = subprocess.run(
        ["arm-none-eabi-nm", "-A", str(lib)], check=True, capture_output=True, text=True,
        env={**os.environ, "LC_ALL": "C"},
    ).stdout  # fmt: skip
    mt = [line for line in members.splitlines() if "multithread.c.obj" in line]
    defined = {line.split()[-1] for line in mt if " T " in line}
    called = {line.split()[-1] for line in mt if " U " in line}
    assert {"uxr_init_lock", "uxr_lock", "uxr_unlock"} <= defined, mt
    assert {"xQueueCreateMutexStatic", "xQueueTakeMutexRecursive", "xQueueGiveMutexRecursive"} <= called, mt
    # the session takes its lock: uxr_lock is called from the session code
    assert any(" U uxr_lock" in line and "session.c.obj" in line for line in members.splitlines())
    config_h = (out / "include" / "uxr" / "client" / "config.h").read_text()
    assert "#define UCLIENT_PROFILE_MULTITHREAD" in config_h
    info = json.loads((out / "build-info.json").read_text())
    assert info["rtos"]["name"] == "freertos" and info["rtos"]["port"] == PORT
    shutil.rmtree(ws / ".uros", ignore_errors=True)
