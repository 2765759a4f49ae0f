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


def _write(out: Path, files: dict[str, str]) -> list[Path]:
    for name, text in files.items():
        (out / name).write_text(text, encoding="utf-8")
    return [out / name for name in files]


def write_cmake_package(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, cmake_package_files(info.target, info.flags.cpu))


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
