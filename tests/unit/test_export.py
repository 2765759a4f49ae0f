from __future__ import annotations

from golden import check_golden

from uros_build.export import esp_idf_component_files


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
    from uros_build import export as ex

    flags = ("-mcpu=cortex-m7", "-DNAME=$HOME", "-DHASH=a#b")
    mk = ex.make_fragment("cortex-m7", flags)["microros.mk"]
    assert "MICROROS_TARGET := cortex-m7\n" in mk
    assert "MICROROS_CPU_FLAGS := -mcpu=cortex-m7 '-DNAME=$$HOME' '-DHASH=a\\#b'\n" in mk
    pc = ex.pkg_config_file("cortex-m7", flags)["microros.pc"]
    assert "cpu_flags=-mcpu=cortex-m7 '-DNAME=$$HOME' '-DHASH=a#b'\n" in pc and "prefix=${pcfiledir}\n" in pc
    files = ex.meson_cross_file("cortex-m7", "/opt/gcc it's/bin/arm-none-eabi-gcc", flags, "/o")
    ini = files["microros-cross.ini"]
    assert "c = '/opt/gcc it\\'s/bin/arm-none-eabi-gcc'" in ini and "cpu_family = 'arm'" in ini
    assert "c_args = ['-mcpu=cortex-m7', '-DNAME=$HOME', '-DHASH=a#b']" in ini
    assert "pkg_config_libdir = ['/o']" in ini and "microros.pc" in files


def test_tool_prefix_and_meson_cpu_family() -> None:
    from uros_build import export as ex

    assert ex.tool_prefix("/usr/bin/arm-none-eabi-gcc") == "/usr/bin/arm-none-eabi-"
    assert ex.tool_prefix("xtensa-esp32s3-elf-gcc") == "xtensa-esp32s3-elf-"
    assert ex.meson_cpu_family("/x/xtensa-esp32s3-elf-") == "xtensa"
    assert ex.meson_cpu_family("riscv32-esp-elf-") == "riscv32"
    assert ex.meson_cpu_family("arm-none-eabi-") == "arm"
