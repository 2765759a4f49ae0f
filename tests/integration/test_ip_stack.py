"""`uros build --transport udp --ip-stack lwip`: micro-ROS's UDP transport compiled against an IP
stack, through the real CLI, colcon, CMake and arm-none-eabi-gcc (docs/network.md).

CI has no lwIP, so the stack is a stand-in the test writes (tests/fixture_lwip.py: lwip/sockets.h,
compat/posix/sys/socket.h and the FreeRTOS port's arch/sys_arch.h in lwIP's layout, a line each),
and the FreeRTOS kernel too (tests/fixture_rtos.py). The package compiled against them is the
test's own: its C source includes <sys/socket.h> (as the XRCE-DDS client's udp_transport_posix_nopoll.c
does) and names a function after lwipopts.h's MEM_SIZE and after the CMake PLATFORM_NAME the
toolchain file sets. Proven here: the stack's folders and PLATFORM_NAME reach the micro-ROS compile
and not the firmware's toolchain file; a changed lwipopts.h rebuilds (the library's symbols show the
new value); build-info.json and `uros info` say what was used; bad input is one line naming the
flag (no RTOS, no udp, no stack folder, no lwipopts.h).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_lwip import make_standin_freertos_tcp, make_standin_lwip, write_lwip_config, write_tcp_config
from fixture_rtos import make_standin_kernel, write_config
from fixture_ws import UP_TO_CORE, add_plain_package, fixture_build_args
from uros_helpers import need, once_then_restored, run_uros, run_uros_here

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

FX_NET_C = """\
#include <sys/socket.h>
#if !defined(FX_LWIP_SOCKETS) || !defined(FX_SYS_ARCH) || !defined(FX_CC_H)
#error "lwIP's folders did not reach the micro-ROS compile"
#endif
#define CAT(a, b) a##b
#define NAME(p, v) CAT(p, v)
int NAME(fx_net_mem_, MEM_SIZE)(void) { return 1; }
int NAME(fx_net_platform_, FX_PLATFORM)(void) { return 1; }
"""


def _setup(tmp: Path) -> tuple[Path, list[str]]:
    """(workspace, the flags of an lwIP build): a one-package workspace whose package compiles
    against the stack and says the CMake PLATFORM_NAME it was configured with."""
    ws = tmp / "ws"
    pkg = add_plain_package(ws / "mcu_ws" / "src" / "fx_net", "fx_net", FX_NET_C)
    cmake = (pkg / "CMakeLists.txt").read_text()
    (pkg / "CMakeLists.txt").write_text(
        cmake.replace(
            "add_library(", 'add_compile_definitions("FX_PLATFORM=${PLATFORM_NAME}")\nadd_library(', 1
        )
    )
    kernel = make_standin_kernel(tmp / "FreeRTOS-Kernel")
    config = write_config(tmp / "app" / "Core" / "Inc")
    lwip = make_standin_lwip(tmp / "lwip")
    lwip_config = write_lwip_config(tmp / "app" / "lwip")
    flags = [
        "--transport", "udp",
        "--rtos", "freertos", "--rtos-dir", str(kernel), "--rtos-config", str(config),
        "--ip-stack", "lwip", "--ip-stack-dir", str(lwip), "--ip-stack-config", str(lwip_config),
    ]  # fmt: skip
    return ws, flags


def _symbols(lib: Path) -> str:
    return subprocess.run(
        ["arm-none-eabi-nm", "-g", str(lib)], check=True, capture_output=True, text=True,
        env={**os.environ, "LC_ALL": "C"},
    ).stdout  # fmt: skip


@pytest.fixture(scope="module")
def _built_once(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str], str]:
    need("arm-none-eabi-gcc", "cmake", "ninja")
    root = tmp_path_factory.mktemp("lwip")
    ws, flags = _setup(root / "live")
    done = run_uros("build", "--toolchain", "cortex-m7", "-w", str(ws), *flags)
    shutil.copytree(root / "live", root / "snapshot", symlinks=True)
    return root, flags, done.stderr


@pytest.fixture
def built_once(_built_once: tuple[Path, list[str], str]) -> tuple[Path, list[str], str]:
    """The _setup workspace built with the flags of an lwIP build, once for this module, restored
    for this test at the path it was built in (it changes lwipopts.h): (that folder, the flags, the
    first build's stderr)."""
    root, flags, stderr = _built_once
    return once_then_restored(root / "snapshot", root / "live"), flags, stderr


def test_lwip_headers_and_platform_reach_the_micro_ros_compile_only(
    built_once: tuple[Path, list[str], str],
) -> None:
    live, flags, first_stderr = built_once  # the first build: the module's, done the same way
    ws = live / "ws"
    lwip, lwip_config = live / "lwip", live / "app" / "lwip"
    build = ["build", "--toolchain", "cortex-m7", "-w", str(ws), *flags]
    assert f"IP stack lwip (PLATFORM_NAME LwIP): {lwip}, config {lwip_config}" in first_stderr
    out = ws / "build" / "cortex-m7"
    symbols = _symbols(out / "libmicroros.a")
    assert "T fx_net_mem_1600" in symbols and "T fx_net_platform_LwIP" in symbols

    info = json.loads((out / "build-info.json").read_text())
    first = info["ip_stack"]
    assert {k: v for k, v in first.items() if k != "headers_sha256"} == {
        "name": "lwip", "dir": str(lwip), "config": str(lwip_config), "platform": "LwIP",
    }  # fmt: skip
    assert len(first["headers_sha256"]) == 64 and info["transport"] == "udp"
    # micro-ROS's alone: the firmware's toolchain file has neither the folders nor PLATFORM_NAME
    own = (ws / ".uros" / "targets" / "cortex-m7" / "toolchain.cmake").read_text()
    assert f"{lwip}/src/include/compat/posix" in own and 'set(PLATFORM_NAME "LwIP")' in own
    firmware_toolchain = (out / "toolchain.cmake").read_text()
    assert str(lwip) not in firmware_toolchain and "PLATFORM_NAME" not in firmware_toolchain

    shown = run_uros("info", str(out)).stdout
    assert f"ip stack   lwip (PLATFORM_NAME LwIP): {lwip}, config {lwip_config}" in shown
    assert json.loads(run_uros("info", "--json", str(out)).stdout)["ip_stack"] == first

    assert "up to date" in run_uros(*build).stderr
    # a changed lwipopts.h is a changed input: rebuilt, and the library says the new value
    write_lwip_config(lwip_config, 4096)
    again = run_uros(*build)
    assert "changed since the last build: IP stack" in again.stderr
    symbols = _symbols(out / "libmicroros.a")
    assert "T fx_net_mem_4096" in symbols and "fx_net_mem_1600" not in symbols
    assert (
        json.loads((out / "build-info.json").read_text())["ip_stack"]["headers_sha256"]
        != first["headers_sha256"]
    )


def test_uros_yaml_names_the_ip_stack(built_once: tuple[Path, list[str], str]) -> None:
    """The same keys in uros.yaml, folders relative to the workspace (built here after the module's
    build with the flags: uros.yaml is a changed input, so built again from it)."""
    live, _, _ = built_once
    ws = live / "ws"
    (ws / "uros.yaml").write_text(
        "target: cortex-m7\ntransport: udp\nrtos: freertos\nrtos_dir: ../FreeRTOS-Kernel\n"
        "rtos_config: ../app/Core/Inc\nip_stack: lwip\nip_stack_dir: ../lwip\nip_stack_config: ../app/lwip\n"
    )
    again = run_uros("build", "-w", str(ws))
    assert "changed since the last build:" in again.stderr and "workspace settings" in again.stderr
    out = ws / "build" / "cortex-m7"
    stack = json.loads((out / "build-info.json").read_text())["ip_stack"]
    assert (stack["dir"], stack["config"]) == (str(live / "lwip"), str(live / "app" / "lwip"))
    assert "T fx_net_platform_LwIP" in _symbols(out / "libmicroros.a")


@pytest.mark.parametrize(
    ("case", "flag", "fix"),
    [
        ("no RTOS", "--ip-stack lwip", "--rtos freertos"),
        ("not udp", "--ip-stack lwip", "--transport udp"),
        ("no stack folder", "--ip-stack-dir", "src/include/lwip/sockets.h"),
        ("the include folder", "--ip-stack-dir", "the stack's root"),
        ("no lwipopts.h", "--ip-stack-config", "lwipopts.h"),
        ("no arch/cc.h", "--ip-stack-config", "arch/cc.h"),
        ("no stack given", "--ip-stack lwip", "--ip-stack-dir DIR"),
        ("a folder without --ip-stack", "--ip-stack-dir", "--ip-stack lwip"),
        ("uros.yaml's folder", "uros.yaml: ip_stack_dir", "src/include/lwip/sockets.h"),
        ("the UDP profile off", "UCLIENT_PROFILE_UDP=OFF", "leave the option out"),
        (
            "a 5-digit agent port",
            "RMW_UXRCE_DEFAULT_UDP_PORT must be 9999 or less, got 53055",
            "uros meta options",
        ),
    ],
)
def test_bad_ip_stack_input_is_one_line_naming_the_flag(
    tmp_path: Path, case: str, flag: str, fix: str
) -> None:
    """Answered before anything runs (run_uros_here refuses to start a process)."""
    ws, flags = _setup(tmp_path)
    target = ["--toolchain", "cortex-m7"]
    lwip, lwip_config = tmp_path / "lwip", tmp_path / "app" / "lwip"
    if case == "no RTOS":
        flags = flags[:2] + flags[8:]
    elif case == "not udp":
        flags = flags[2:]
    elif case == "no stack folder":
        flags[11] = str(tmp_path / "app")
    elif case == "the include folder":
        flags[11] = str(lwip / "src" / "include")
    elif case == "no lwipopts.h":
        (lwip_config / "lwipopts.h").unlink()
    elif case == "no arch/cc.h":
        (lwip_config / "arch" / "cc.h").unlink()
    elif case == "no stack given":
        flags = flags[:10] + flags[12:]
    elif case == "a folder without --ip-stack":
        flags = flags[:8] + flags[10:12]
    elif case == "a 5-digit agent port":  # rmw_microxrcedds would keep "5305" (MAX_PORT_LEN 5, NUL included)
        flags += ["--set", "rmw_microxrcedds.RMW_UXRCE_DEFAULT_UDP_PORT=53055"]
    elif case == "the UDP profile off":
        flags += ["--set", "microxrcedds_client.UCLIENT_PROFILE_UDP=OFF"]
    elif case == "uros.yaml's folder":
        (ws / "uros.yaml").write_text(
            "transport: udp\nrtos: freertos\nrtos_dir: ../FreeRTOS-Kernel\nrtos_config: ../app/Core/Inc\n"
            "ip_stack: lwip\nip_stack_dir: ../app\nip_stack_config: ../app/lwip\n"
        )
        flags = []
    done = run_uros_here("build", *target, "-w", str(ws), *flags, check=False)
    assert done.returncode == 2, done.stdout + done.stderr
    error = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(error) == 1 and flag in error[0], done.stderr
    assert fix in done.stderr
    assert not (ws / "build").exists()


def test_udp_on_bare_metal_without_a_stack_is_warned(built: Callable[[str], Path]) -> None:
    """--transport udp on a Cortex-M without --ip-stack: the client would have no socket code; said
    before the build (a warning: a firmware may bring its own PLATFORM_NAME in a toolchain file).
    The restored fixture built with fx_core alone, built again with the transport (no socket code in it)."""
    need("ninja")
    done = run_uros(*fixture_build_args(built("core"), *UP_TO_CORE, "--transport", "udp"))
    assert "transport udp on cortex-m7 without an IP stack" in done.stderr, done.stderr


FX_TCP_C = """\
#include "FreeRTOS_Sockets.h"
#define CAT(a, b) a##b
#define NAME(p, v) CAT(p, v)
int NAME(fx_net_mtu_, ipconfigNETWORK_MTU)(void) { return 1; }
int NAME(fx_net_platform_, FX_PLATFORM)(void) { return 1; }
"""


def test_freertos_plus_tcp_is_the_second_stack(tmp_path: Path) -> None:
    """--ip-stack freertos-tcp: its headers, FreeRTOSIPConfig.h and PLATFORM_NAME FreeRTOS_Plus_TCP."""
    need("arm-none-eabi-gcc", "cmake", "ninja")
    ws, flags = _setup(tmp_path)
    (ws / "mcu_ws" / "src" / "fx_net" / "fx_net.c").write_text(FX_TCP_C)
    tree = make_standin_freertos_tcp(tmp_path / "FreeRTOS-Plus-TCP")
    config = write_tcp_config(tmp_path / "app" / "tcp", 1400)
    flags = [
        *flags[:8],
        "--ip-stack",
        "freertos-tcp",
        "--ip-stack-dir",
        str(tree),
        "--ip-stack-config",
        str(config),
    ]
    run_uros("build", "--toolchain", "cortex-m7", "-w", str(ws), *flags)
    out = ws / "build" / "cortex-m7"
    symbols = _symbols(out / "libmicroros.a")
    assert "T fx_net_mtu_1400" in symbols and "T fx_net_platform_FreeRTOS_Plus_TCP" in symbols
    stack = json.loads((out / "build-info.json").read_text())["ip_stack"]
    assert (stack["name"], stack["platform"], stack["dir"]) == (
        "freertos-tcp",
        "FreeRTOS_Plus_TCP",
        str(tree),
    )
