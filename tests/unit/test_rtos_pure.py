"""target/rtos.py's pure parts: the port table (meta/rtos/freertos.yaml) against the shipped
profiles, the headers' digest, the portable form of the folders."""

from __future__ import annotations

from pathlib import Path

import pytest
from fixture_rtos import make_standin_kernel, write_config

from uros_build.errors import ConfigError
from uros_build.target import rtos
from uros_build.target.profiles import find_profile


@pytest.mark.parametrize(
    ("target", "port"),
    [
        ("cortex-m0plus", ("GCC/ARM_CM0",)),
        ("rp2040", ("GCC/ARM_CM0",)),
        ("cortex-m3", ("GCC/ARM_CM3",)),
        ("cortex-m4", ("GCC/ARM_CM3",)),  # no FPU: the CM3 port
        ("cortex-m4f", ("GCC/ARM_CM4F",)),
        ("cortex-m7", ("GCC/ARM_CM7/r0p1",)),
        ("cortex-m7-sp", ("GCC/ARM_CM7/r0p1",)),
        ("cortex-m33", ("GCC/ARM_CM33_NTZ/non_secure",)),
        ("rv32imc", ("GCC/RISC-V", "GCC/RISC-V/chip_specific_extensions/RISCV_MTIME_CLINT_no_extensions")),
        ("esp8266", None),  # Xtensa: no FreeRTOS-Kernel GCC port (ESP-IDF brings its own FreeRTOS)
    ],
)
def test_the_port_table_names_each_core_s_port(target: str, port: tuple[str, ...] | None) -> None:
    assert rtos.port_for(find_profile(target)) == port


def test_the_port_table_refuses_a_rule_without_a_core() -> None:
    with pytest.raises(ConfigError, match=r"ports\[0\]: needs mcpu or march"):
        rtos.parse_ports({"ports": [{"port": ["GCC/X"]}]}, "t.yaml")


def test_headers_digest_is_the_content_not_the_place(tmp_path: Path) -> None:
    m7 = find_profile("cortex-m7")
    one = rtos.read_freertos(
        make_standin_kernel(tmp_path / "a" / "k"), write_config(tmp_path / "a" / "c"), None, m7
    )
    two = rtos.read_freertos(
        make_standin_kernel(tmp_path / "b" / "kernel"), write_config(tmp_path / "b" / "cfg"), None, m7
    )
    assert one.headers_sha256 == two.headers_sha256 and one.kernel != two.kernel
    assert one.portable() == two.portable()
    assert one.portable().include_dirs == (
        "/rtos/kernel/include", "/rtos/kernel/portable/GCC/ARM_CM7/r0p1", "/rtos/config",
    )  # fmt: skip
    write_config(tmp_path / "b" / "cfg", "#define configTICK_RATE_HZ 500\n")
    three = rtos.read_freertos(tmp_path / "b" / "kernel", tmp_path / "b" / "cfg", None, m7)
    assert three.headers_sha256 != two.headers_sha256
    # another header in the config folder is not FreeRTOS's: the compiler's dependency output follows it
    (tmp_path / "b" / "cfg" / "main.h").write_text("#define X 1\n")
    assert rtos.read_freertos(tmp_path / "b" / "kernel", tmp_path / "b" / "cfg", None, m7) == three


def test_an_absolute_port_folder(tmp_path: Path) -> None:
    kernel = make_standin_kernel(tmp_path / "k")
    own = tmp_path / "my_port"
    own.mkdir()
    (own / "portmacro.h").write_text("#define MINE 1\n")
    found = rtos.read_freertos(kernel, write_config(tmp_path / "c"), str(own), find_profile("cortex-m4f"))
    assert found.port == (str(own),) and str(own) in found.include_dirs
    assert found.record()["port"] == str(own)
