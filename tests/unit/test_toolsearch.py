"""Finding ESP-IDF's compilers in fake tools folders laid out as each IDF version installs them."""

from __future__ import annotations

import json
from pathlib import Path

from uros_build.target.profiles import find_profile
from uros_build.target.toolsearch import search_compiler, searched_places, version_key


def _tool(root: Path, relative: str, executable: bool = True) -> Path:
    path = root / relative
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#!/bin/sh\n")
    path.chmod(0o755 if executable else 0o644)
    return path.parent


def test_idf_5_2_unified_xtensa_folder_newest_gcc_wins(tmp_path: Path) -> None:
    tools = tmp_path / ".espressif" / "tools"
    _tool(tools, "xtensa-esp-elf/esp-13.2.0_20230928/xtensa-esp-elf/bin/xtensa-esp32s3-elf-gcc")
    newest = _tool(tools, "xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin/xtensa-esp32s3-elf-gcc")
    # a per-chip folder of IDF 5.1 as well: the unified layout is searched first
    _tool(tools, "xtensa-esp32s3-elf/esp-12.2.0_20230208/xtensa-esp32s3-elf/bin/xtensa-esp32s3-elf-gcc")
    assert search_compiler(find_profile("esp32s3"), {}, home=tmp_path) == newest


def test_idf_4_4_and_5_0_per_chip_folders(tmp_path: Path) -> None:
    tools = tmp_path / "idf-tools" / "tools"
    _tool(tools, "xtensa-esp32s3-elf/esp-2021r2-patch5-8.4.0/xtensa-esp32s3-elf/bin/xtensa-esp32s3-elf-gcc")
    gcc11 = _tool(tools, "xtensa-esp32s3-elf/esp-2022r1-11.2.0/xtensa-esp32s3-elf/bin/xtensa-esp32s3-elf-gcc")
    env = {"IDF_TOOLS_PATH": str(tmp_path / "idf-tools")}
    assert search_compiler(find_profile("esp32s3"), env, home=tmp_path / "nohome") == gcc11


def test_the_idf_checkout_pins_its_version(tmp_path: Path) -> None:
    tools = tmp_path / ".espressif" / "tools"
    pinned = _tool(tools, "xtensa-esp-elf/esp-13.2.0_20240530/xtensa-esp-elf/bin/xtensa-esp32-elf-gcc")
    _tool(tools, "xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin/xtensa-esp32-elf-gcc")
    idf = tmp_path / "esp-idf"
    (idf / "tools").mkdir(parents=True)
    (idf / "tools" / "tools.json").write_text(
        json.dumps({"tools": [{"name": "xtensa-esp-elf", "versions": [{"name": "esp-13.2.0_20240530"}]}]})
    )
    assert search_compiler(find_profile("esp32"), {"IDF_PATH": str(idf)}, home=tmp_path) == pinned


def test_riscv_c3_and_misses(tmp_path: Path) -> None:
    tools = tmp_path / ".espressif" / "tools"
    c3 = _tool(tools, "riscv32-esp-elf/esp-14.2.0_20241119/riscv32-esp-elf/bin/riscv32-esp-elf-gcc")
    assert search_compiler(find_profile("esp32c3"), {}, home=tmp_path) == c3
    # another chip's wrapper, a file that is not executable, a profile without a search: no match
    _tool(
        tools,
        "xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin/xtensa-esp32s2-elf-gcc",
        executable=False,
    )
    assert search_compiler(find_profile("esp32s2"), {}, home=tmp_path) is None
    assert search_compiler(find_profile("esp32s3"), {}, home=tmp_path) is None
    assert search_compiler(find_profile("cortex-m7"), {}, home=tmp_path) is None


def test_searched_places_for_the_message(tmp_path: Path) -> None:
    places = searched_places(find_profile("esp32s3"), {"IDF_TOOLS_PATH": "/opt/esp"}, home=tmp_path)
    assert places == [
        "/opt/esp/tools/xtensa-esp-elf/*/xtensa-esp-elf/bin",
        "/opt/esp/tools/xtensa-esp32s3-elf/*/xtensa-esp32s3-elf/bin",
    ]


def test_version_order() -> None:
    names = ["esp-14.2.0_20241119", "esp-2021r2-patch5-8.4.0", "esp-12.2.0_20230208", "esp-2022r1-11.2.0"]
    assert sorted(names, key=version_key) == [
        "esp-2021r2-patch5-8.4.0",
        "esp-2022r1-11.2.0",
        "esp-12.2.0_20230208",
        "esp-14.2.0_20241119",
    ]
