"""The ESP-IDF build-folder reader (uros_build/target/espidf.py) on build folders generated here: a small
project_description.json, CMakeCache.txt, config/sdkconfig.h and IDF tree with the shapes IDF 5.3
and 5.5 write (no IDF file is copied)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from fake_idf import make_idf_build

from uros_build.errors import ConfigError
from uros_build.target import espidf

_build = make_idf_build


def test_idf53_build_folder(tmp_path: Path) -> None:
    build = _build(tmp_path)
    proj = espidf.read_idf_build(build, "esp32s3", "esp32s3")
    idf = tmp_path / "esp idf" / "components"
    assert proj.version == (5, 3, 1) and proj.version_text == "5.3.1" and proj.c_standard == 17
    assert proj.target == "esp32s3" and proj.components == 4
    assert proj.include_dirs == (
        str(idf / "freertos" / "config" / "include"),
        str(idf / "freertos" / "FreeRTOS-Kernel" / "include"),  # trailing '/' dropped
        str(idf / "lwip" / "include"),
        str(idf / "soc" / "esp32s3" / "include"),  # soc's own public folder, listed once
        str(build / "config"),
    )
    assert proj.c_flags == ("-mlongcalls", "-fno-builtin-memcpy", "-fno-builtin-memset", "-fno-builtin-bzero")
    assert proj.cxx_flags == proj.c_flags
    assert proj.sdkconfig_h == str(build / "config" / "sdkconfig.h")
    assert len(proj.sdkconfig_sha256) == 64


def test_private_include_dirs_are_not_passed(tmp_path: Path) -> None:
    proj = espidf.read_idf_build(_build(tmp_path), "esp32s3", "esp32s3")
    assert not any(d.endswith("private") for d in proj.include_dirs)


def test_soc_include_comes_last_when_soc_is_not_a_build_component(tmp_path: Path) -> None:
    build = _build(tmp_path)
    data = json.loads((build / espidf.DESCRIPTION).read_text(encoding="utf-8"))
    data["build_components"].remove("soc")
    (build / espidf.DESCRIPTION).write_text(json.dumps(data), encoding="utf-8")
    proj = espidf.read_idf_build(build, "esp32s3", "esp32s3")
    assert proj.include_dirs[-2:] == (
        str(build / "config"),
        str(tmp_path / "esp idf" / "components" / "soc" / "esp32s3" / "include"),
    )


def test_sdkconfig_change_changes_the_hash(tmp_path: Path) -> None:
    build = _build(tmp_path)
    before = espidf.read_idf_build(build, "esp32s3", "esp32s3").sdkconfig_sha256
    with (build / "config" / "sdkconfig.h").open("a", encoding="utf-8") as handle:
        handle.write("#define CONFIG_LWIP_IPV6 1\n")
    assert espidf.read_idf_build(build, "esp32s3", "esp32s3").sdkconfig_sha256 != before


def test_idf55_response_file_is_read_and_split_as_gcc_does(tmp_path: Path) -> None:
    build = _build(tmp_path, c_flags='@"{build}/toolchain/cflags"', version=(5, 5, 4))
    cache = (build / espidf.CACHE).read_text(encoding="utf-8").replace("{build}", str(build))
    (build / espidf.CACHE).write_text(cache, encoding="utf-8")
    (build / "toolchain").mkdir()
    (build / "toolchain" / "cflags").write_text(
        "-mlongcalls\n-fno-builtin-memcpy\n"
        '-fmacro-prefix-map="/home/me/my proj"=.\n'
        "-DNAME='a b'\n-DPATH=C:\\\\x\n\n",
        encoding="utf-8",
    )
    proj = espidf.read_idf_build(build, "esp32s3", "esp32s3")
    assert proj.version == (5, 5, 4)
    assert proj.c_flags == (
        "-mlongcalls",
        "-fno-builtin-memcpy",
        "-fmacro-prefix-map=/home/me/my proj=.",
        "-DNAME=a b",
        "-DPATH=C:\\x",
    )


def test_missing_response_file_is_an_error(tmp_path: Path) -> None:
    build = _build(tmp_path, c_flags=f"@{tmp_path}/nowhere/cflags")
    with pytest.raises(ConfigError, match=r"response file in CMAKE_C_FLAGS, .*nowhere/cflags does not exist"):
        espidf.read_idf_build(build, "esp32s3", "esp32s3")


@pytest.mark.parametrize(
    ("text", "args"),
    [
        ("-a -b\n-c", ["-a", "-b", "-c"]),
        ('"-DX=a b" -Y', ["-DX=a b", "-Y"]),
        ("'-DX=\"q\"'", ['-DX="q"']),
        ("-DA=x\\ y", ["-DA=x y"]),
        ("'a\\'b'", ["a'b"]),  # libiberty: a backslash escapes inside single quotes too
        ('"" x', ["", "x"]),
        ("  \n\t ", []),
        ('-I"C:/Program Files/x"/inc', ["-IC:/Program Files/x/inc"]),
    ],
)
def test_split_response_file(text: str, args: list[str]) -> None:
    assert espidf.split_response_file(text) == args


def test_nested_and_relative_response_files() -> None:
    files = {Path("/b/toolchain/cflags"): "-x @more\n", Path("/b/toolchain/more"): "'-y z'"}
    out = espidf.expand_response_files(["@toolchain/cflags", "-w", "@"], files.__getitem__, Path("/b"), "t")
    assert out == ["-x", "-y z", "-w", "@"]


def test_self_including_response_file_stops() -> None:
    with pytest.raises(ConfigError, match="nest deeper"):
        espidf.expand_response_files(["@/a"], lambda p: "@/a", Path("/"), "t")


def test_response_file_text_is_never_substituted_into_a_string() -> None:
    # a '$' or ';' in a flag of the file stays a character of one flag
    assert espidf.split_response_file("-DX=$(rm) -DY=a;b") == ["-DX=$(rm)", "-DY=a;b"]


def test_cmake_cache_parser() -> None:
    entries = espidf.parse_cmake_cache(
        "// comment\n# comment\nCMAKE_C_FLAGS:STRING=-a  -b\nNOTYPE=1\n"
        '"WITH:COLON":STRING=v\nEMPTY:STRING=\nCMAKE_X-ADVANCED:INTERNAL=1\n'
    )
    assert entries == {
        "CMAKE_C_FLAGS": "-a  -b",
        "NOTYPE": "1",
        "WITH:COLON": "v",
        "EMPTY": "",
        "CMAKE_X-ADVANCED": "1",
    }


@pytest.mark.parametrize(
    ("text", "version"),
    [
        ("v5.3.1", (5, 3, 1)),
        ("v5.3.1-dirty", (5, 3, 1)),
        ("v5.4-dev-1234-gabcdef0", (5, 4, 0)),
        ("4.4.8", (4, 4, 8)),
        ("HEAD-HASH-NOTFOUND", None),
        ("", None),
    ],
)
def test_version_from_git_revision(text: str, version: tuple[int, int, int] | None) -> None:
    assert espidf.version_from_text(text) == version


def test_version_falls_back_to_git_revision_then_sdkconfig_header(tmp_path: Path) -> None:
    assert espidf.read_idf_build(
        _build(tmp_path / "a", version=None, git_revision="v5.2.3"), "esp32s3", "esp32s3"
    ).version == (5, 2, 3)
    assert espidf.read_idf_build(_build(tmp_path / "b", version=None), "esp32s3", "esp32s3").version == (
        5,
        3,
        1,
    )


def test_idf4_means_c11(tmp_path: Path) -> None:
    proj = espidf.read_idf_build(_build(tmp_path, version=(4, 4, 8)), "esp32s3", "esp32s3")
    assert proj.c_standard == 11


def test_unknown_version_is_an_error(tmp_path: Path) -> None:
    build = _build(tmp_path, version=None)
    (build / "config" / "sdkconfig.h").write_text("#pragma once\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="cannot tell the ESP-IDF version") as info:
        espidf.read_idf_build(build, "esp32s3", "esp32s3")
    assert "\n" not in info.value.message


def test_idf3_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"ESP-IDF 3\.3\.0 is too old"):
        espidf.read_idf_build(_build(tmp_path, version=(3, 3, 0)), "esp32s3", "esp32s3")


def test_target_mismatch(tmp_path: Path) -> None:
    with pytest.raises(
        ConfigError, match="the project builds for IDF_TARGET esp32, uros builds for esp32s3"
    ) as e:
        espidf.read_idf_build(_build(tmp_path, target="esp32"), "esp32s3", "esp32s3")
    assert e.value.hint is not None and "--toolchain esp32" in e.value.hint


def test_not_an_esp_idf_target(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="target cortex-m7 is not an ESP-IDF target"):
        espidf.read_idf_build(_build(tmp_path), "", "cortex-m7")


def test_not_a_build_folder(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such folder"):
        espidf.read_idf_build(tmp_path / "nope", "esp32s3", "esp32s3")
    with pytest.raises(
        ConfigError, match=r"no project_description\.json, so it is not an ESP-IDF build folder"
    ):
        espidf.read_idf_build(tmp_path, "esp32s3", "esp32s3")


@pytest.mark.parametrize("missing", ["CMakeCache.txt", "config/sdkconfig.h"])
def test_missing_files(tmp_path: Path, missing: str) -> None:
    build = _build(tmp_path)
    (build / missing).unlink()
    with pytest.raises(ConfigError, match=f"{missing} does not exist"):
        espidf.read_idf_build(build, "esp32s3", "esp32s3")


def test_missing_include_folder_means_a_stale_build(tmp_path: Path) -> None:
    build = _build(tmp_path)
    (tmp_path / "esp idf" / "components" / "lwip" / "include").rmdir()
    with pytest.raises(ConfigError, match="lwip/include does not exist"):
        espidf.read_idf_build(build, "esp32s3", "esp32s3")


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"build_components": "main"}, "build_components: must be a list of strings"),
        ({"build_component_info": {}}, "build_component_info.freertos: missing"),
        ({"target": 5}, "target: must be a non-empty string"),
    ],
)
def test_malformed_description(tmp_path: Path, change: dict[str, Any], expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        espidf.read_idf_build(_build(tmp_path, description=change), "esp32s3", "esp32s3")


def test_a_uros_exported_component_is_left_out(tmp_path: Path) -> None:
    build = _build(tmp_path)
    comp = tmp_path / "proj" / "components" / "micro_ros"
    (comp / "include").mkdir(parents=True)
    (comp / "build-info.json").write_text('{"generated_by": "uros 0.1"}', encoding="utf-8")
    data = json.loads((build / espidf.DESCRIPTION).read_text(encoding="utf-8"))
    data["build_components"].append("micro_ros")
    data["build_component_info"]["micro_ros"] = {"dir": str(comp), "include_dirs": ["include"]}
    (build / espidf.DESCRIPTION).write_text(json.dumps(data), encoding="utf-8")
    proj = espidf.read_idf_build(build, "esp32s3", "esp32s3")
    assert str(comp / "include") not in proj.include_dirs and proj.components == 4


def test_unbalanced_quote_in_cache_flags(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot split"):
        espidf.read_idf_build(_build(tmp_path, c_flags='-DX="a'), "esp32s3", "esp32s3")
