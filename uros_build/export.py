"""Packages a firmware project consumes: a CMake config package (and, per target, ESP-IDF's).

Text is rendered by pure functions; the writers put it next to a build output.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from uros_build import __version__, templating
from uros_build.buildinfo import BUILD_INFO, BuildInfo

CMAKE_FILES = ("microrosConfig.cmake", "microrosConfigVersion.cmake", "microros.cmake")
ESP_IDF_COMPONENT_FILE = "CMakeLists.txt"


def cmake_package_files(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """File name -> text of the CMake package (pure)."""
    ctx = {
        "version": __version__,
        "target": target,
        "cpu_flags": list(cpu_flags),
        "package_version": __version__,
    }
    return {name: templating.render(f"{name}.j2", **ctx) for name in CMAKE_FILES}


def esp_idf_component_files(target: str, idf_target: str, transport: str | None) -> dict[str, str]:
    """File name -> text of the ESP-IDF component around a build output (pure)."""
    # XRCE-DDS' UDP transport on FreeRTOS calls lwIP's sockets; custom transports need nothing.
    requires = ["lwip"] if transport in ("udp", "tcp") else []
    text = templating.render(
        "esp-idf-component.cmake.j2",
        version=__version__,
        target=target,
        idf_target=idf_target,
        transport=transport or "custom",
        requires=requires,
    )
    return {ESP_IDF_COMPONENT_FILE: text}


MAKE_FILE = "microros.mk"
PC_FILE = "microros.pc"
MESON_FILE = "microros-cross.ini"


def make_fragment(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.mk: MICROROS_CFLAGS / MICROROS_LIBS / MICROROS_CPU_FLAGS for a Make firmware (pure)."""
    text = templating.render(f"{MAKE_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {MAKE_FILE: text}


def pkg_config_file(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.pc, relocatable (${pcfiledir}) (pure)."""
    text = templating.render(f"{PC_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {PC_FILE: text}


def tool_prefix(compiler: str) -> str:
    """``/usr/bin/arm-none-eabi-gcc`` -> ``/usr/bin/arm-none-eabi-`` (pure)."""
    folder, _, name = compiler.rpartition("/")
    stem = name[: -len("gcc")] if name.endswith("gcc") else name
    return f"{folder}/{stem}" if folder else stem


def meson_cpu_family(prefix: str) -> str:
    """Meson's cpu_family for a GCC triplet (https://mesonbuild.com/Reference-tables.html#cpu-families)."""
    name = prefix.rpartition("/")[2]
    for start, family in (
        ("arm", "arm"),
        ("xtensa", "xtensa"),
        ("riscv32", "riscv32"),
        ("riscv64", "riscv64"),
    ):
        if name.startswith(start):
            return family
    return name.split("-", 1)[0] or "arm"


def meson_cross_file(target: str, compiler: str, cpu_flags: tuple[str, ...], folder: str) -> dict[str, str]:
    """microros-cross.ini beside microros.pc: the compiler, the CPU flags and pkg-config's folder (pure)."""
    prefix = tool_prefix(compiler)
    text = templating.render(
        f"{MESON_FILE}.j2",
        version=__version__,
        target=target,
        prefix=prefix,
        cpu_flags=list(cpu_flags),
        link_flags=list(cpu_flags),
        cpu_family=meson_cpu_family(prefix),
        cpu=target,
        folder=folder,
    )
    return {MESON_FILE: text, **pkg_config_file(target, cpu_flags)}


def _write(out: Path, files: dict[str, str]) -> list[Path]:
    for name, text in files.items():
        (out / name).write_text(text, encoding="utf-8")
    return [out / name for name in files]


def write_cmake_package(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, cmake_package_files(info.target, info.flags.cpu))


def write_make_fragment(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, make_fragment(info.target, info.flags.cpu))


def write_pkg_config(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, pkg_config_file(info.target, info.flags.cpu))


def write_meson_cross(out: Path, info: BuildInfo) -> list[Path]:
    compiler = info.compiler.path if info.compiler else ""
    return _write(out, meson_cross_file(info.target, compiler, info.flags.cpu, str(out)))


def write_esp_idf_component(out: Path, info: BuildInfo) -> list[Path]:
    assert info.idf_target, "callers check that the build is for an ESP-IDF target"
    return _write(out, esp_idf_component_files(info.target, info.idf_target, info.transport))


def copy_build_output(src: Path, dst: Path) -> list[str]:
    """Copy library, headers and build-info from one output folder to another; returns the names
    copied."""
    dst.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src / "libmicroros.a", dst / "libmicroros.a")
    if (dst / "include").exists():
        shutil.rmtree(dst / "include")
    shutil.copytree(src / "include", dst / "include")
    copied = ["libmicroros.a", "include"]
    for name in (BUILD_INFO, "toolchain.cmake"):
        if (src / name).is_file():
            shutil.copy2(src / name, dst / name)
            copied.append(name)
    return copied
