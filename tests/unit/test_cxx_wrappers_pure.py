"""Compilers without C++ standard headers (Debian's riscv64-unknown-elf and xtensa-lx106-elf): a
profile's micro_ros.cxx_wrapper_headers hands micro-ROS's few C++ sources wrappers of the C headers,
and picolibc's libc.a is found through its specs file (issue 32, item 3: the RISC-V probe)."""

from __future__ import annotations

from dataclasses import replace

from uros_build.target.compilers import specs_library_dirs
from uros_build.target.profiles import shipped_profiles
from uros_build.target.toolchain import CXX_WRAPPERS, ToolchainRequest, cxx_wrapper_text, microros_flags

# the link rule of Debian's picolibc 1.8 specs for riscv64-unknown-elf, shortened
SPECS = (
    "*link:\n-L%{-picolibc-prefix=*:%*/lib/picolibc/riscv64-unknown-elf/lib/%M; "
    "-picolibc-buildtype=*:/usr/lib/picolibc/riscv64-unknown-elf/lib/%*/%M; "
    ":/usr/lib/picolibc/riscv64-unknown-elf/lib/%M} --gc-sections\n"
)


def test_the_specs_library_folder_for_the_multilib() -> None:
    assert specs_library_dirs(SPECS, "rv32im/ilp32") == [
        "/usr/lib/picolibc/riscv64-unknown-elf/lib/rv32im/ilp32"
    ]
    assert specs_library_dirs("*link:\n--gc-sections\n", "rv32im/ilp32") == []


def test_the_wrappers_reach_the_micro_ros_compile_only_where_the_profile_asks() -> None:
    rv = shipped_profiles()["rv32imc"]
    assert rv.micro_ros.cxx_wrapper_headers
    flags = microros_flags(ToolchainRequest(rv, micro_ros=True, cxx_wrappers="/ws/.uros/targets/rv32imc/cxx"))
    assert flags[flags.index("-isystem") + 1] == "/ws/.uros/targets/rv32imc/cxx"
    m7 = shipped_profiles()["cortex-m7"]
    assert not m7.micro_ros.cxx_wrapper_headers
    assert "-isystem" not in microros_flags(ToolchainRequest(m7, micro_ros=True, cxx_wrappers="/x"))
    off = replace(rv, micro_ros=replace(rv.micro_ros, cxx_wrapper_headers=False))
    assert "-isystem" not in microros_flags(ToolchainRequest(off, micro_ros=True, cxx_wrappers="/x"))


def test_each_wrapper_includes_its_c_header() -> None:
    # what rosidl_typesupport_c's dispatch and the generated type supports include (humble)
    assert {"cstddef", "cstdio", "cstring"} <= set(CXX_WRAPPERS)
    assert "#include <string.h>" in cxx_wrapper_text(CXX_WRAPPERS["cstring"])
