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
