"""A generated stand-in for an ESP-IDF project's build folder after `idf.py reconfigure`: the files
uros reads (project_description.json, CMakeCache.txt, config/sdkconfig.h), in the shapes IDF 5.3
and 5.5 write them, and an IDF tree of empty include folders. No file of ESP-IDF is copied."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

IDF53_FLAGS = "-mlongcalls  -fno-builtin-memcpy -fno-builtin-memset -fno-builtin-bzero"


def make_idf_tree(
    tmp: Path, version: tuple[int, int, int] | None = (5, 3, 1), target: str = "esp32s3"
) -> Path:
    idf = tmp / "esp idf"  # a space: every path must stay one word
    (idf / "components" / "soc" / target / "include").mkdir(parents=True)
    for comp, incs in {
        "freertos": ["config/include", "FreeRTOS-Kernel/include"],
        "lwip": ["include"],
    }.items():
        for inc in incs:
            (idf / "components" / comp / inc).mkdir(parents=True)
    if version is not None:
        (idf / "tools" / "cmake").mkdir(parents=True)
        (idf / "tools" / "cmake" / "version.cmake").write_text(
            "set(IDF_VERSION_MAJOR {})\nset(IDF_VERSION_MINOR {})\nset(IDF_VERSION_PATCH {})\n\n"
            'set(ENV{{IDF_VERSION}} "${{IDF_VERSION_MAJOR}}")\n'.format(*version),
            encoding="utf-8",
        )
    return idf


def make_idf_build(
    tmp: Path,
    *,
    target: str = "esp32s3",
    c_flags: str = IDF53_FLAGS,
    cxx_flags: str | None = None,
    version: tuple[int, int, int] | None = (5, 3, 1),
    git_revision: str = "HEAD-HASH-NOTFOUND",
    description: dict[str, Any] | None = None,
    sdkconfig: str = "",
    soc: str = "esp32s3",
) -> Path:
    """<tmp>/proj/build, configured for ``target``, with components freertos, lwip, main and soc
    of an IDF tree in <tmp>/esp idf; ``sdkconfig``: more lines of sdkconfig.h; ``soc``: the chip
    whose soc/<chip>/include the tree has (and CMakeCache.txt's IDF_TARGET, sdkconfig.h's target)."""
    idf = make_idf_tree(tmp, version, soc)
    proj = tmp / "proj"
    (proj / "main").mkdir(parents=True)
    build = proj / "build"
    (build / "config").mkdir(parents=True)
    comps = {
        "freertos": (idf / "components" / "freertos", ["config/include", "FreeRTOS-Kernel/include/"]),
        "lwip": (idf / "components" / "lwip", ["include"]),
        "main": (proj / "main", []),
        "soc": (idf / "components" / "soc", [f"{soc}/include"]),
    }
    data: dict[str, Any] = {
        "version": "1.1",
        "idf_path": str(idf),
        "build_dir": str(build),
        "config_file": str(proj / "sdkconfig"),
        "git_revision": git_revision,
        "target": target,
        "build_components": [*comps, ""],  # IDF 5.3 writes a trailing ""
        "build_component_info": {
            name: {"dir": str(d), "include_dirs": incs, "priv_include_dirs": ["private"]}
            for name, (d, incs) in comps.items()
        },
    }
    data.update(description or {})
    (build / "project_description.json").write_text(json.dumps(data), encoding="utf-8")
    (build / "CMakeCache.txt").write_text(
        "# This is the CMakeCache file.\n//C Compiler Base Flags\n"
        f"CMAKE_C_FLAGS:STRING={c_flags}\n"
        f"CMAKE_CXX_FLAGS:STRING={c_flags if cxx_flags is None else cxx_flags}\n"
        f"IDF_TARGET:STRING={soc}\n",
        encoding="utf-8",
    )
    (build / "config" / "sdkconfig.h").write_text(
        "/*\n * Automatically generated file. DO NOT EDIT.\n"
        " * Espressif IoT Development Framework (ESP-IDF) 5.3.1 Configuration Header\n */\n"
        f'#pragma once\n#define CONFIG_IDF_TARGET "{soc}"\n' + sdkconfig,
        encoding="utf-8",
    )
    return build


def xrce_client_stand_in(root: Path) -> Path:
    """<root>/mcu_ws/src/microxrcedds_client with its package.xml: a stand-in for the XRCE-DDS client
    (its name gets the client's colcon.meta entries and PLATFORM_NAME); the caller writes its sources."""
    pkg = root / "mcu_ws" / "src" / "microxrcedds_client"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(
        '<?xml version="1.0"?>\n<package format="3">\n'
        "  <name>microxrcedds_client</name><version>0.1.0</version><description>uros test</description>\n"
        '  <maintainer email="dev@example.com">uros tests</maintainer><license>Apache-2.0</license>\n'
        "  <export><build_type>cmake</build_type></export>\n</package>\n",
        encoding="utf-8",
    )
    return pkg
