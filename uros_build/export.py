"""Packages a firmware project consumes: a CMake config package (and, per target, ESP-IDF's)."""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from uros_build import __version__, templating
from uros_build.errors import ConfigError

BUILD_INFO = "build-info.json"
CMAKE_FILES = ("microrosConfig.cmake", "microrosConfigVersion.cmake", "microros.cmake")


def dump_json(data: Mapping[str, Any]) -> str:
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def read_build_info(out: Path, flag: str = "--from") -> dict[str, Any]:
    path = out / BUILD_INFO
    if not path.is_file():
        raise ConfigError(
            f"{flag} {out}: no {BUILD_INFO} there, so it is not a uros build output",
            "point at the output folder of `uros build` (default <workspace>/build/<target>)",
        )
    data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return data


def cmake_package_files(target: str, cpu_flags: list[str]) -> dict[str, str]:
    """File name -> text of the CMake package (pure)."""
    ctx = {"version": __version__, "target": target, "cpu_flags": cpu_flags, "package_version": __version__}
    return {name: templating.render(f"{name}.j2", **ctx) for name in CMAKE_FILES}


def write_cmake_package(out: Path, info: Mapping[str, Any]) -> list[Path]:
    files = cmake_package_files(str(info["target"]), list(info.get("flags", {}).get("cpu", [])))
    written = []
    for name, text in files.items():
        (out / name).write_text(text, encoding="utf-8")
        written.append(out / name)
    return written


ESP_IDF_COMPONENT_FILE = "CMakeLists.txt"


def esp_idf_component_files(info: Mapping[str, Any]) -> dict[str, str]:
    """File name -> text of the ESP-IDF component around a build output (pure)."""
    transport = info.get("transport")
    # XRCE-DDS' UDP transport on FreeRTOS calls lwIP's sockets; custom transports need nothing.
    requires = ["lwip"] if transport in ("udp", "tcp") else []
    text = templating.render(
        "esp-idf-component.cmake.j2",
        version=__version__,
        target=str(info["target"]),
        idf_target=str(info["idf_target"]),
        transport=transport or "custom",
        requires=requires,
    )
    return {ESP_IDF_COMPONENT_FILE: text}


def write_esp_idf_component(out: Path, info: Mapping[str, Any]) -> list[Path]:
    written = []
    for name, text in esp_idf_component_files(info).items():
        (out / name).write_text(text, encoding="utf-8")
        written.append(out / name)
    return written


def copy_build_output(src: Path, dst: Path) -> None:
    """Copy library, headers and build-info from one output folder to another."""
    dst.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src / "libmicroros.a", dst / "libmicroros.a")
    if (dst / "include").exists():
        shutil.rmtree(dst / "include")
    shutil.copytree(src / "include", dst / "include")
    for name in (BUILD_INFO, "toolchain.cmake"):
        if (src / name).is_file():
            shutil.copy2(src / name, dst / name)
