"""target/ipstack.py's pure parts: the shipped lwIP facts, the checks, the headers' digest, the
portable form, and what reaches the micro-ROS toolchain text (target/toolchain.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from fixture_lwip import make_standin_freertos_tcp, make_standin_lwip, write_lwip_config, write_tcp_config
from fixture_rtos import make_standin_kernel, write_config

from uros_build.errors import ConfigError
from uros_build.target import ipstack
from uros_build.target.profiles import find_profile
from uros_build.target.rtos import read_freertos
from uros_build.target.toolchain import ToolchainRequest, microros_flags, render_toolchain


def _stack(tmp: Path, name: str = "a", mem_size: int = 1600) -> ipstack.IpStackHeaders:
    profile = find_profile("cortex-m7")
    kernel = make_standin_kernel(tmp / name / "kernel")
    rtos = read_freertos(kernel, write_config(tmp / name / "cfg"), None, profile)
    lwip = make_standin_lwip(tmp / name / "lwip")
    return ipstack.read_ip_stack(
        "lwip", lwip, write_lwip_config(tmp / name / "lwipcfg", mem_size), rtos, "udp", "cortex-m7"
    )


def test_the_shipped_lwip_facts_name_the_client_s_platform() -> None:
    facts = ipstack.stack_facts("lwip")
    assert facts.platform == "LwIP" and "src/include/compat/posix" in facts.include
    assert facts.rtos["freertos"] == "contrib/ports/freertos/include"
    assert facts.config == ("lwipopts.h", "arch/cc.h")


def test_headers_digest_is_the_content_not_the_place(tmp_path: Path) -> None:
    a, b = _stack(tmp_path, "a"), _stack(tmp_path, "b")
    assert a.headers_sha256 == b.headers_sha256
    assert _stack(tmp_path, "b", 4096).headers_sha256 != a.headers_sha256


def test_the_portable_form_has_no_folder_of_this_machine(tmp_path: Path) -> None:
    stack = _stack(tmp_path)
    portable = stack.portable()
    assert str(tmp_path) not in repr(portable)
    assert portable.include_dirs == (
        "/ipstack/dir/src/include",
        "/ipstack/dir/src/include/compat/posix",
        "/ipstack/dir/contrib/ports/freertos/include",
        "/ipstack/config",
    )


def test_the_folders_and_platform_reach_the_micro_ros_toolchain_only(tmp_path: Path) -> None:
    stack = _stack(tmp_path)
    profile = find_profile("cortex-m7")
    mine = ToolchainRequest(profile, micro_ros=True, transport="udp", ip_stack=stack)
    assert f"-I{stack.dir}/src/include/compat/posix" in microros_flags(mine)
    assert 'set(PLATFORM_NAME "LwIP")' in render_toolchain(mine)
    firmware = render_toolchain(ToolchainRequest(profile, micro_ros=False, transport="udp", ip_stack=stack))
    assert "PLATFORM_NAME" not in firmware and stack.dir not in firmware
    # the custom transport needs no socket platform
    assert "PLATFORM_NAME" not in render_toolchain(ToolchainRequest(profile, micro_ros=True, ip_stack=stack))


def test_no_rtos_is_one_line_naming_the_fix(tmp_path: Path) -> None:
    lwip = make_standin_lwip(tmp_path / "lwip")
    with pytest.raises(ConfigError, match="without an RTOS") as err:
        ipstack.read_ip_stack("lwip", lwip, write_lwip_config(tmp_path / "c"), None, "udp", "cortex-m7")
    assert "--rtos freertos" in (err.value.hint or "")


def test_a_platform_that_is_no_word_is_refused() -> None:
    data = {"platform": "Lw IP", "marker": "m", "include": [], "config": [], "rtos": {}, "hashed": []}
    with pytest.raises(ConfigError, match="is not a word"):
        ipstack.parse_facts("x", data, "x.yaml")


@pytest.mark.skipif(
    not (os.environ.get("UROS_LWIP") and os.environ.get("UROS_FREERTOS")),
    reason="set UROS_LWIP (an lwIP STABLE-2_2_1 tree) and UROS_FREERTOS (a FreeRTOS-Kernel V11 checkout)",
)
def test_a_real_lwip_tree_is_accepted(tmp_path: Path) -> None:
    profile = find_profile("cortex-m3")
    rtos = read_freertos(Path(os.environ["UROS_FREERTOS"]), write_config(tmp_path / "cfg"), None, profile)
    stack = ipstack.read_ip_stack(
        "lwip",
        Path(os.environ["UROS_LWIP"]),
        write_lwip_config(tmp_path / "lwipcfg"),
        rtos,
        "udp",
        "cortex-m3",
    )
    assert all(Path(d).is_dir() for d in stack.include_dirs)


def test_freertos_plus_tcp_is_the_second_stack(tmp_path: Path) -> None:
    profile = find_profile("cortex-m7")
    rtos = read_freertos(make_standin_kernel(tmp_path / "k"), write_config(tmp_path / "cfg"), None, profile)
    tree = make_standin_freertos_tcp(tmp_path / "tcp")
    stack = ipstack.read_ip_stack(
        "freertos-tcp", tree, write_tcp_config(tmp_path / "ipcfg"), rtos, "udp", "cortex-m7"
    )
    assert stack.platform == "FreeRTOS_Plus_TCP"
    assert stack.include_dirs == (
        f"{tree}/source/include",
        f"{tree}/source/portable/Compiler/GCC",
        str(tmp_path / "ipcfg"),
    )
    other = ipstack.read_ip_stack(
        "freertos-tcp", tree, write_tcp_config(tmp_path / "ipcfg2", 1400), rtos, "udp", "cortex-m7"
    )
    assert other.headers_sha256 != stack.headers_sha256
    with pytest.raises(ConfigError, match=r"no FreeRTOSIPConfig\.h"):
        ipstack.read_ip_stack("freertos-tcp", tree, tmp_path / "k", rtos, "udp", "cortex-m7")
