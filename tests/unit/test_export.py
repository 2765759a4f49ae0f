from __future__ import annotations

from pathlib import Path

import pytest
from golden import check_golden

from uros_build.errors import ConfigError
from uros_build.output import exports
from uros_build.output.exports import arduino, base, cmake, make, meson, pkgconfig, platformio, zephyr
from uros_build.output.exports.espidf import esp_idf_component_files


def test_esp_idf_component_golden() -> None:
    files = esp_idf_component_files("esp32s3", "esp32s3", "udp")
    text = files["CMakeLists.txt"]
    check_golden("esp32s3.esp-idf-CMakeLists.txt", text)
    assert 'idf_component_register(INCLUDE_DIRS "include" REQUIRES lwip)' in text
    assert 'add_prebuilt_library(microros_prebuilt "${COMPONENT_DIR}/libmicroros.a" REQUIRES lwip)' in text
    assert "target_link_libraries(${COMPONENT_LIB} INTERFACE microros_prebuilt)" in text
    assert 'if(NOT IDF_TARGET STREQUAL "esp32s3")' in text


def test_custom_transport_needs_no_lwip() -> None:
    files = esp_idf_component_files("esp32c3", "esp32c3", "custom")
    assert "lwip" not in files["CMakeLists.txt"]


def test_make_pkg_config_and_meson_text_escape_their_values() -> None:

    flags = ("-mcpu=cortex-m7", "-DNAME=$HOME", "-DHASH=a#b")
    mk = make.make_fragment("cortex-m7", flags)["microros.mk"]
    assert "MICROROS_TARGET := cortex-m7\n" in mk
    assert "MICROROS_CPU_FLAGS := -mcpu=cortex-m7 '-DNAME=$$HOME' '-DHASH=a\\#b'\n" in mk
    # pkgconf prints '$' bare into a shell-read line and reads '#' as a comment: refused (issue 34, 7)
    for flag in ("-DNAME=$HOME", "-DHASH=a#b"):
        with pytest.raises(ConfigError, match="which pkg-config cannot pass on"):
            pkgconfig.pkg_config_file("cortex-m7", ("-mcpu=cortex-m7", flag))
    pc = pkgconfig.pkg_config_file("cortex-m7", ("-mcpu=cortex-m7", "-DNAME=a b"))["microros.pc"]
    assert "cpu_flags=-mcpu=cortex-m7 '-DNAME=a b'\n" in pc and "prefix=${pcfiledir}\n" in pc
    files = meson.meson_cross_file("cortex-m7", "/opt/gcc it's/bin/arm-none-eabi-gcc", flags[:1], "/o")
    ini = files["microros-cross.ini"]
    assert "c = '/opt/gcc it\\'s/bin/arm-none-eabi-gcc'" in ini and "cpu_family = 'arm'" in ini
    assert "c_args = ['-mcpu=cortex-m7']" in ini
    assert "pkg_config_libdir = ['/o']" in ini and "microros.pc" in files


def test_tool_prefix_and_meson_cpu_family() -> None:

    assert meson.tool_prefix("/usr/bin/arm-none-eabi-gcc") == "/usr/bin/arm-none-eabi-"
    assert meson.tool_prefix("xtensa-esp32s3-elf-gcc") == "xtensa-esp32s3-elf-"
    assert meson.meson_cpu_family("/x/xtensa-esp32s3-elf-") == "xtensa"
    assert meson.meson_cpu_family("riscv32-esp-elf-") == "riscv32"
    assert meson.meson_cpu_family("arm-none-eabi-") == "arm"


@pytest.mark.parametrize(
    ("flags", "folders", "architectures"),
    [
        # Teensy 4: build.mcu=imxrt1062, -mfpu=fpv5-d16 -mfloat-abi=hard (cores/teensy4/Makefile)
        (
            ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard"),
            ["imxrt1062/fpv5-d16-hard", "imxrt1062"],
            ["avr"],
        ),
        # STM32duino F7/H7 boards all compile -mfpu=fpv5-sp-d16 (boards.txt), not fpv5-d16
        (
            ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-sp-d16", "-mfloat-abi=hard"),
            ["cortex-m7/fpv5-sp-d16-hard", "cortex-m7"],
            ["stm32"],
        ),
        (
            ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"),
            ["cortex-m4/fpv4-sp-d16-hard", "cortex-m4"],
            ["stm32"],
        ),
        (("-mcpu=cortex-m3", "-mthumb", "-mfloat-abi=soft"), ["cortex-m3"], ["stm32"]),
        (
            ("-march=armv6-m", "-mcpu=cortex-m0plus", "-mthumb"),
            ["cortex-m0plus"],
            ["mbed_nano", "mbed_rp2040", "stm32"],
        ),
        # soft-float Cortex-M4 and the ESP32-C3's RISC-V: no core checked compiles so
        (("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=soft"), [], []),
        (("-march=rv32imc", "-mabi=ilp32"), [], []),
    ],
)
def test_arduino_folders_as_the_cores_look_them_up(
    flags: tuple[str, ...], folders: list[str], architectures: list[str]
) -> None:
    """Issue 34, item 5: the folders as arduino-cli composes them for the cores' own flags, with
    the src/<mcu> fallback; the architectures of those cores only (not '*')."""

    assert arduino.arduino_folders(flags) == folders
    assert sorted({c.architecture for c in arduino.arduino_cores(flags)}) == architectures


def test_arduino_declares_a_precompiled_library_for_its_cores_only() -> None:

    props = arduino.arduino_properties(["cortex-m7", "cortex-m4f"], ["stm32", "avr", "stm32"])
    fields = dict(
        line.split("=", 1) for line in props.splitlines() if "=" in line and not line.startswith("#")
    )
    assert fields["precompiled"] == "true" and fields["ldflags"] == "-lmicroros"
    assert fields["includes"] == "micro_ros_uros.h" and fields["architectures"] == "avr,stm32"
    # every field the library specification requires
    assert {"name", "version", "author", "maintainer", "sentence", "paragraph", "category", "url"} <= set(
        fields
    )


def test_the_esp_idf_component_has_a_manifest_the_component_manager_reads() -> None:
    import yaml

    files = esp_idf_component_files("esp32s3", "esp32s3", "udp")
    manifest = yaml.safe_load(files["idf_component.yml"])
    # the manifest's documented top-level keys; the version is semver, the targets IDF's names
    assert set(manifest) <= {
        "version",
        "description",
        "url",
        "targets",
        "dependencies",
        "files",
        "tags",
        "maintainers",
    }
    assert manifest["targets"] == ["esp32s3"] and manifest["dependencies"] == {"idf": ">=5.0"}
    assert manifest["version"].count(".") == 2


def test_the_zephyr_module_follows_zephyrs_module_file_rules() -> None:
    import yaml

    files = zephyr.zephyr_module_files("cortex-m7", _M7)
    module = yaml.safe_load(files["zephyr/module.yml"])
    # zephyr/module.yml's schema (scripts/zephyr_module.py): name, and build: cmake / kconfig relative
    # to the module's root (https://docs.zephyrproject.org/latest/develop/modules.html)
    assert module == {"name": "micro_ros_uros", "build": {"cmake": ".", "kconfig": "Kconfig"}}
    assert "if(CONFIG_MICRO_ROS_UROS)" in files["CMakeLists.txt"]
    assert files["Kconfig"].splitlines()[1] == "config MICRO_ROS_UROS"


_M7 = ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard")


def test_the_zephyr_module_links_only_what_the_firmware_uses() -> None:
    """Issue 34, item 4: zephyr_library_import() puts the archive on ZEPHYR_LIBS, which Zephyr links
    --whole-archive (all of micro-ROS in every firmware); an imported target on zephyr_interface's
    link (zephyr_link_libraries) is an ordinary archive."""

    text = zephyr.zephyr_module_files("cortex-m7", _M7)["CMakeLists.txt"]
    code = [line.strip() for line in text.splitlines() if not line.lstrip().startswith("#")]
    assert not any(line.startswith("zephyr_library_import(") for line in code)
    assert "add_library(micro_ros_uros_prebuilt STATIC IMPORTED GLOBAL)" in code
    assert 'IMPORTED_LOCATION "${CMAKE_CURRENT_LIST_DIR}/libmicroros.a"' in code
    assert "zephyr_link_libraries(micro_ros_uros_prebuilt)" in code
    # the steady clock: every clock_gettime call through the module's shim
    assert "zephyr_ld_options(-Wl,--wrap=clock_gettime)" in code
    assert 'zephyr_library_sources("${CMAKE_CURRENT_LIST_DIR}/zephyr/uros_clock.c")' in code


@pytest.mark.parametrize(
    ("flags", "depends"),
    [
        (_M7, "ARM && CPU_CORTEX_M7 && FPU && FP_HARDABI && CPU_HAS_FPU_DOUBLE_PRECISION"),
        (
            ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-sp-d16", "-mfloat-abi=hard"),
            "ARM && CPU_CORTEX_M7 && FPU && FP_HARDABI && !CPU_HAS_FPU_DOUBLE_PRECISION",
        ),
        (
            ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"),
            "ARM && CPU_CORTEX_M4 && FPU && FP_HARDABI && !CPU_HAS_FPU_DOUBLE_PRECISION",
        ),
        (("-mcpu=cortex-m0plus", "-mthumb", "-mfloat-abi=soft"), "ARM && CPU_CORTEX_M0PLUS && !FP_HARDABI"),
        (("-march=rv32imc", "-mabi=ilp32"), "RISCV"),
    ],
)
def test_the_zephyr_option_depends_on_newlib_and_the_librarys_cpu(
    flags: tuple[str, ...], depends: str
) -> None:
    """Issue 34, item 4: the option needs newlib (with picolibc, Zephyr's default, __errno and
    _impure_ptr are undefined) and the CPU/float ABI Zephyr compiles with the library's flags
    (cmake/gcc-m-fpu.cmake: fpv5-d16 with CPU_HAS_FPU_DOUBLE_PRECISION, else fpv5-sp-d16; FP_HARDABI:
    -mfloat-abi=hard); never a board. Zephyr aborts on CONFIG_MICRO_ROS_UROS=y that these refuse."""

    kconfig = zephyr.zephyr_module_files("t", flags)["Kconfig"]
    assert [line for line in kconfig.splitlines() if line.startswith("\tdepends on ")] == [
        "\tdepends on NEWLIB_LIBC",
        f"\tdepends on {depends}",
    ]
    assert "BOARD" not in kconfig


def test_the_zephyr_module_refuses_a_cpu_zephyr_has_no_symbol_for() -> None:
    from uros_build.errors import ConfigError

    with pytest.raises(ConfigError, match="uros knows no Zephyr CPU"):
        zephyr.zephyr_depends(("-mcpu=cortex-a53",))


def test_the_cmake_package_names_the_librarys_abi_flags() -> None:
    """The configure-time guard compares these with the firmware's flags (issue 34, item 6)."""
    from cmake_text import set_values

    m7 = ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard")
    assert base.abi_flags(m7) == {"mcpu": "cortex-m7", "mfpu": "fpv5-d16", "mfloat-abi": "hard", "mabi": ""}
    assert (
        base.abi_flags(("-march=rv32imc", "-mabi=ilp32", "-mabi=ilp32e"))["mabi"] == "ilp32e"
    )  # GCC: last wins
    values = set_values(cmake.cmake_package_files("cortex-m7", m7)["microros.cmake"])
    assert values["_microros_want_mcpu"] == "cortex-m7" and values["_microros_want_mfloat-abi"] == "hard"
    assert values["_microros_want_mabi"] == ""


def test_a_build_carries_over_the_exports_its_marker_names(tmp_path: Path) -> None:
    """Issue 34, item 7: only the exports uros wrote (the marker) and that are still there are
    written again into the next build's staged folder; a user's same-named file is not uros's."""
    from uros_build.output import folders
    from uros_build.output.buildinfo import parse_build_info

    info = parse_build_info(
        {
            "generated_by": "uros 0.1.0",
            "target": "cortex-m7",
            "library": {"file": "libmicroros.a", "sha256": "s"},
        },
        "b",
    )
    out, staging = tmp_path / "out", tmp_path / "staging"
    out.mkdir()
    staging.mkdir()
    for name in ("microros.mk", "library.json", "microros.pc"):
        (out / name).write_text("x")
    folders.write_marker(
        out, "cortex-m7", ["libmicroros.a", "microros.mk", "library.json", "microros-cross.ini"]
    )
    # microros.pc is the user's (not in the marker); microros-cross.ini was removed by the user
    assert exports.carry_over(out, staging, info) == ["make", "platformio"]
    assert sorted(p.name for p in staging.iterdir()) == [
        "library.json",
        "microros.mk",
        platformio.PLATFORMIO_SCRIPT,
    ]


@pytest.mark.parametrize(
    ("kind", "folder", "char"),
    [
        ("pkg-config", "/w/a$b", "$"),
        ("make", "/w/it's", "'"),
        ("meson", "/w/caf\u00e9", "\u00e9"),
        ("cmake", "/w/a;b", ";"),
        ("zephyr", "/w/a\\b", "\\"),
        ("cmake", "/w/a$b (1) 'q' \u00e9", None),
        ("pkg-config", "/w/micro ros/caf\u00e9#1", None),
        ("platformio", "/w/a;b$", None),
    ],
)
def test_export_folders_each_consumer_cannot_use(kind: str, folder: str, char: str | None) -> None:

    refused = exports.folder_refusal(kind, folder)
    assert (refused[0] if refused else None) == char
