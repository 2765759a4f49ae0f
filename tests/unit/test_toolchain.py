from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from golden import check_golden

from uros_build.target.espidf import IdfProject
from uros_build.target.profiles import find_profile
from uros_build.target.toolchain import (
    ToolchainRequest,
    microros_flags,
    render_toolchain,
    seed_module_text,
    seeded_toolchain_text,
)
from uros_build.templating import cmake_flags


def test_cortex_m7_micro_ros_toolchain_golden() -> None:
    req = ToolchainRequest(find_profile("cortex-m7"), micro_ros=True, gcc_major=12, clock_header="/ws/h.h")
    check_golden("cortex-m7.micro-ros.cmake", render_toolchain(req))


def test_cortex_m7_firmware_toolchain_golden() -> None:
    text = render_toolchain(ToolchainRequest(find_profile("cortex-m7"), micro_ros=False))
    check_golden("cortex-m7.firmware.cmake", text)
    # the firmware's toolchain never carries micro-ROS-only flags
    assert "CLOCK_MONOTONIC" not in text
    assert "__attribute__" not in text
    assert "uros_clock_gettime" not in text


def test_attribute_stripping_only_for_old_gcc() -> None:
    profile = find_profile("cortex-m7")
    assert "-D__attribute__(x)=" not in microros_flags(ToolchainRequest(profile, True, gcc_major=12))
    assert "-D__attribute__(x)=" in microros_flags(ToolchainRequest(profile, True, gcc_major=5))
    assert "-D__attribute__(x)=" not in microros_flags(ToolchainRequest(profile, True, gcc_major=None))


def test_profile_optimisation_is_the_one_that_applies() -> None:
    profile = replace(find_profile("cortex-m7"), optimization="-O2")
    text = render_toolchain(ToolchainRequest(profile, micro_ros=True))
    assert 'CMAKE_${_uros_lang}_FLAGS_RELEASE "-O2 -DNDEBUG"' in text
    assert "-O3" not in text.replace("appends -O3", "")


def test_flags_with_spaces_quotes_and_semicolons_stay_one_word() -> None:
    assert cmake_flags(["-DA=1", "-include", "/a b/h.h"]) == "-DA=1 -include '/a b/h.h'"
    assert cmake_flags(['-DNAME="x;y"']) == "'-DNAME=\\\"x;y\\\"'"
    assert cmake_flags(["-DP=$HOME"]) == "'-DP=\\$\\$HOME'"  # CMake, then ninja/make


def test_esp32s3_micro_ros_toolchain_golden() -> None:
    # Rendered only: Espressif's compiler is not packaged (the integration test builds where it is
    # on PATH). The tool folder is what the ESP-IDF search found.
    req = ToolchainRequest(
        find_profile("esp32s3"),
        micro_ros=True,
        gcc_major=14,
        tool_dir="/home/me/.espressif/tools/xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin",
    )
    text = render_toolchain(req)
    check_golden("esp32s3.micro-ros.cmake", text)
    assert "-DESP_PLATFORM -DLWIP_IPV4 -DLWIP_IPV6 -DPLATFORM_NAME_FREERTOS" in text
    assert "CLOCK_MONOTONIC" not in text and "-include" not in text  # ESP-IDF's newlib has both
    assert (
        'set(CMAKE_C_COMPILER "/home/me/.espressif/tools/xtensa-esp-elf/esp-14.2.0_20241119/xtensa-esp-elf/bin/xtensa-esp32s3-elf-gcc")'
        in text
    )
    assert "set(CMAKE_C_STANDARD 17)" in text


def test_rv32imc_selects_picolibc_for_compiles_and_links() -> None:
    req = ToolchainRequest(find_profile("rv32imc"), micro_ros=True, gcc_major=12, clock_header="/ws/h.h")
    text = render_toolchain(req)
    check_golden("rv32imc.micro-ros.cmake", text)
    for var in ("CMAKE_C_FLAGS_INIT", "CMAKE_CXX_FLAGS_INIT"):
        line = next(line for line in text.splitlines() if line.startswith(f"set({var} "))
        assert "-march=rv32imc -mabi=ilp32 --specs=picolibc.specs" in line, var
    # a link goes through the compiler with the language's flags, which carry the specs already:
    # GCC refuses a specs file twice ("attempt to rename spec 'link'"), as the rv32imc probe's link did
    line = next(line for line in text.splitlines() if line.startswith("set(CMAKE_EXE_LINKER_FLAGS_INIT "))
    assert "-march=rv32imc -mabi=ilp32" in line and "specs" not in line


def _idf(version: tuple[int, int, int] = (5, 3, 1), sha: str = "a" * 64) -> IdfProject:
    return IdfProject(
        build_dir="/proj/build",
        idf_path="/esp/idf",
        version=version,
        target="esp32s3",
        include_dirs=(
            "/esp/idf/components/freertos/config/include",
            "/esp/my idf/components/lwip/include",
            "/proj/build/config",
            "/esp/idf/components/soc/esp32s3/include",
        ),
        c_flags=("-mlongcalls", "-fno-builtin-memcpy"),
        cxx_flags=("-mlongcalls", "-fno-rtti-x"),
        sdkconfig_h="/proj/build/config/sdkconfig.h",
        sdkconfig_sha256=sha,
        components=2,
    )


def test_esp32s3_against_an_idf_project_golden() -> None:
    req = ToolchainRequest(find_profile("esp32s3"), micro_ros=True, gcc_major=14, idf=_idf(), transport="udp")
    text = render_toolchain(req)
    check_golden("esp32s3-idf.micro-ros.cmake", text)
    c_line = next(line for line in text.splitlines() if line.startswith("set(CMAKE_C_FLAGS_INIT"))
    cxx_line = next(line for line in text.splitlines() if line.startswith("set(CMAKE_CXX_FLAGS_INIT"))
    # IDF's flags, then every include folder, one word each (the space is quoted for the shell)
    assert "-fno-builtin-memcpy -I/esp/idf/components/freertos/config/include" in c_line
    assert "'-I/esp/my idf/components/lwip/include' -I/proj/build/config" in c_line
    assert c_line.endswith('-I/esp/idf/components/soc/esp32s3/include")')
    assert "-fno-rtti-x" in cxx_line and "-fno-rtti-x" not in c_line
    assert 'set(PLATFORM_NAME "LwIP")' in text
    assert "set(CMAKE_C_STANDARD 17)" in text and f"sdkconfig.h sha256 {'a' * 64}" in text


def test_idf_flags_never_reach_the_firmware_toolchain() -> None:
    text = render_toolchain(ToolchainRequest(find_profile("esp32s3"), micro_ros=False, idf=_idf()))
    assert "/esp/idf" not in text and "sdkconfig" not in text
    assert "PLATFORM_NAME" not in text.replace("PLATFORM_NAME_FREERTOS", "")


def test_a_changed_sdkconfig_changes_the_toolchain_file() -> None:
    profile = find_profile("esp32s3")
    one = render_toolchain(ToolchainRequest(profile, micro_ros=True, idf=_idf(sha="a" * 64)))
    two = render_toolchain(ToolchainRequest(profile, micro_ros=True, idf=_idf(sha="b" * 64)))
    assert one != two


def test_idf4_compiles_micro_ros_as_c11() -> None:
    text = render_toolchain(ToolchainRequest(find_profile("esp32s3"), micro_ros=True, idf=_idf((4, 4, 8))))
    assert "set(CMAKE_C_STANDARD 11)" in text


def test_platform_name_only_with_an_ip_transport() -> None:
    profile = find_profile("esp32s3")
    custom = render_toolchain(ToolchainRequest(profile, micro_ros=True, transport="custom"))
    assert "set(PLATFORM_NAME" not in custom
    arm = render_toolchain(ToolchainRequest(find_profile("cortex-m7"), micro_ros=True, transport="udp"))
    assert "set(PLATFORM_NAME" not in arm


def test_a_compiler_seed_is_one_language_and_leaves_binutils_to_cmake() -> None:
    """The seed module of a language sets that language's facts only, then runs CMake's own module;
    CMakeFindBinUtils still makes its cache entries (the lines that would pre-empt it are left out)."""
    facts = "\n".join(
        [
            'set(CMAKE_C_COMPILER "/usr/bin/arm-none-eabi-gcc")',
            'set(CMAKE_C_COMPILER_ID "GNU")',
            'set(CMAKE_AR "/usr/bin/arm-none-eabi-ar")',
            'set(CMAKE_C_COMPILER_AR "/usr/bin/arm-none-eabi-gcc-ar")',
            'set(CMAKE_RANLIB "/usr/bin/arm-none-eabi-ranlib")',
            'set(CMAKE_LINKER "/usr/bin/arm-none-eabi-ld")',
        ]
    )
    text = seed_module_text("C", facts, "ELF", "uros 1 build")
    assert text.startswith("# Written by uros 1 build")
    assert 'set(CMAKE_C_COMPILER_ID "GNU")' in text and "CMAKE_AR" not in text and "LINKER" not in text
    assert 'set(CMAKE_EXECUTABLE_FORMAT "ELF" CACHE INTERNAL "Executable file format")' in text
    assert text.rstrip().endswith("include(${CMAKE_ROOT}/Modules/CMakeDetermineCCompiler.cmake)")
    assert "set(CMAKE_C_COMPILER_ID_RUN 1)" in text and "set(CMAKE_C_COMPILER_FORCED TRUE)" in text
    assert "CMAKE_EXECUTABLE_FORMAT" not in seed_module_text("C", facts, "", "uros 1 build")

    toolchain = seeded_toolchain_text(Path('/w "q"/toolchain.cmake'), Path("/w/seed $x"), "uros 1 build")
    assert 'include("/w \\"q\\"/toolchain.cmake")' in toolchain
    assert 'list(APPEND CMAKE_MODULE_PATH "/w/seed \\$x")' in toolchain
    assert "COMPILER_ID" not in toolchain  # no language's facts for every project
    assert "ARCHIVE" not in toolchain  # no plugin found: CMake's own archive rules

    plugin = "/usr/lib/gcc/arm-none-eabi/12.2.1/liblto_plugin.so"
    with_plugin = seeded_toolchain_text(Path("/w/toolchain.cmake"), Path("/w/seed"), "uros 1 build", plugin)
    for lang in ("C", "CXX"):
        assert f"if(NOT DEFINED CMAKE_{lang}_ARCHIVE_CREATE)" in with_plugin  # a toolchain's own rules stay
        assert (
            f'set(CMAKE_{lang}_ARCHIVE_CREATE "<CMAKE_AR> --plugin {plugin} qcs <TARGET> <LINK_FLAGS> <OBJECTS>")'
            in with_plugin
        )
        assert f'set(CMAKE_{lang}_ARCHIVE_APPEND "<CMAKE_AR> --plugin {plugin} qs <TARGET>' in with_plugin
        assert f'set(CMAKE_{lang}_ARCHIVE_FINISH "")' in with_plugin  # qcs wrote the index: no ranlib
    assert with_plugin.index("include(") < with_plugin.index("ARCHIVE_CREATE")  # after the toolchain's


def test_a_kept_render_is_the_render_and_anything_off_renders_again(tmp_path: Path) -> None:
    """An up-to-date build takes its toolchain texts from the target's renders.json (no
    jinja2): the same request gives the text render_toolchain gives; another request, a changed
    key or a text that no longer matches its digest gives a fresh render."""
    import json

    from uros_build.steps.renders import RENDERS
    from uros_build.steps.target_kind import rendered_toolchain

    m7 = find_profile("cortex-m7")
    req = ToolchainRequest(m7, micro_ros=True, command="uros build --toolchain cortex-m7")
    assert rendered_toolchain(tmp_path, "toolchain.cmake", req) == render_toolchain(req)
    kept = json.loads((tmp_path / RENDERS).read_text(encoding="utf-8"))
    kept["toolchain.cmake"]["text"] += "# tampered\n"
    (tmp_path / RENDERS).write_text(json.dumps(kept), encoding="utf-8")
    assert rendered_toolchain(tmp_path, "toolchain.cmake", req) == render_toolchain(req)
    other = replace(req, command="uros build --toolchain cortex-m7 --other")
    assert rendered_toolchain(tmp_path, "toolchain.cmake", other) == render_toolchain(other)
    assert rendered_toolchain(tmp_path, "portable", req) == render_toolchain(req)
    kept = json.loads((tmp_path / RENDERS).read_text(encoding="utf-8"))
    assert sorted(kept) == ["portable", "toolchain.cmake"]  # one entry each, the other kept
    (tmp_path / RENDERS).write_text("not json", encoding="utf-8")
    assert rendered_toolchain(tmp_path, "portable", req) == render_toolchain(req)


def test_a_changed_template_renders_again(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The kept text's key holds the templates' bytes: a template edited (a uros upgrade, a
    development checkout) is rendered again, never taken from renders.json."""
    from uros_build import resources
    from uros_build.steps.renders import kept_render

    templates = tmp_path / "templates"
    templates.mkdir()
    (templates / "t.j2").write_text("one\n", encoding="utf-8")
    monkeypatch.setattr(resources, "templates_dir", lambda: templates)
    calls: list[str] = []

    def render() -> str:
        calls.append((templates / "t.j2").read_text(encoding="utf-8"))
        return calls[-1]

    folder = tmp_path / "target"
    folder.mkdir()
    assert kept_render(folder, "t", "same inputs", ("t.j2",), render) == "one\n"
    assert kept_render(folder, "t", "same inputs", ("t.j2",), render) == "one\n"
    assert len(calls) == 1  # the second came from renders.json
    (templates / "t.j2").write_text("two\n", encoding="utf-8")
    assert kept_render(folder, "t", "same inputs", ("t.j2",), render) == "two\n"
    assert len(calls) == 2
