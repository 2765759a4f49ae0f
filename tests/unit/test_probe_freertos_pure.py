"""The probe on FreeRTOS, its pure pieces (run/freertos.py): the kernel's port for each core, when the
FreeRTOS variant is chosen and with which kernel, the configure definitions, the shipped firmware
files, and what the console's FreeRTOS lines say. The firmware itself runs in
tests/integration/test_probe_freertos.py."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.output.buildinfo import RtosInfo
from uros_build.run import freertos
from uros_build.run import machines as probe


def task_h(version: str) -> str:
    """include/task.h's version lines as FreeRTOS-Kernel writes them (V11.1.0's layout)."""
    major, minor, build = version[1:].split(".")
    return (
        f'#define tskKERNEL_VERSION_NUMBER       "{version}"\n'
        f"#define tskKERNEL_VERSION_MAJOR        {major}\n"
        f"#define tskKERNEL_VERSION_MINOR        {minor}\n"
        f"#define tskKERNEL_VERSION_BUILD        {build}\n"
    )


def fake_kernel(root: Path, ports: tuple[str, ...] = ("GCC/ARM_CM7/r0p1",), version: str = "V11.1.0") -> Path:
    """A folder shaped like a FreeRTOS-Kernel checkout (no kernel code: these tests only look)."""
    (root / "include").mkdir(parents=True)
    (root / "tasks.c").write_text("/* fake */\n")
    (root / "include" / "FreeRTOS.h").write_text("/* fake */\n")
    (root / "include" / "task.h").write_text(task_h(version))
    for port in ports:
        (root / "portable" / port).mkdir(parents=True)
        (root / "portable" / port / "port.c").write_text("/* fake */\n")
    return root


def library(kernel: Path, port: str = "GCC/ARM_CM7/r0p1", config: str = "/cfg") -> RtosInfo:
    """build-info.json's rtos of a library built with uros build --rtos freertos."""
    return RtosInfo("freertos", str(kernel), port, config, "0" * 64)


@pytest.mark.parametrize(
    ("target", "port"),
    [
        ("cortex-m7", "GCC/ARM_CM7/r0p1"),
        ("cortex-m4f", "GCC/ARM_CM4F"),
        ("cortex-m4", "GCC/ARM_CM3"),  # no FPU: the M3's port
        ("cortex-m3", "GCC/ARM_CM3"),
        ("cortex-m33", "GCC/ARM_CM33_NTZ/non_secure"),
        ("cortex-m55", "GCC/ARM_CM55_NTZ/non_secure"),
        ("cortex-m0plus", "GCC/ARM_CM0"),
    ],
)
def test_the_port_of_each_probed_core(target: str, port: str) -> None:
    assert freertos.port_for(target) == port


def test_every_probed_arm_target_has_a_port() -> None:
    # the FreeRTOS variant of the probe is Arm's (its board files); rv32imc's probe is bare metal
    arm = {t for t, m in probe.load_machines().items() if m.board.arch == "arm"}
    assert all(freertos.port_for(target) for target in arm)


def test_a_core_without_a_port_says_so() -> None:
    with pytest.raises(ConfigError, match="the probe runs no FreeRTOS port for target esp32s3 here"):
        freertos.port_for("esp32s3")


def test_a_bare_metal_library_stays_bare_metal_even_with_UROS_FREERTOS(tmp_path: Path) -> None:
    kernel = fake_kernel(tmp_path / "k")
    assert freertos.choose("cortex-m7", None, None, str(kernel)) is None


def test_freertos_flag_runs_any_library_on_freertos(tmp_path: Path) -> None:
    kernel = fake_kernel(tmp_path / "k")
    rtos = freertos.choose("cortex-m7", None, str(kernel), None)
    assert rtos == freertos.FreeRtos(kernel, kernel / "portable/GCC/ARM_CM7/r0p1", "--freertos", None)
    assert freertos.firmware_folders(rtos) == ["freertos"] and freertos.firmware_folders(None) == []
    assert freertos.cmake_defines(rtos) == [
        f"-DUROS_FREERTOS_KERNEL={kernel}",
        f"-DUROS_FREERTOS_PORT={kernel}/portable/GCC/ARM_CM7/r0p1",
    ]
    assert freertos.cmake_defines(None) == []


def test_a_freertos_library_runs_on_its_own_kernel_and_port(tmp_path: Path) -> None:
    own = fake_kernel(tmp_path / "own", ("GCC/ARM_CM7/r0p1", "GCC/ARM_CM4F"))
    other = fake_kernel(tmp_path / "other", ("GCC/ARM_CM7/r0p1", "GCC/ARM_CM4F"))
    built = library(own, "GCC/ARM_CM4F", str(tmp_path / "cfg"))  # uros build --rtos-port GCC/ARM_CM4F
    rtos = freertos.choose("cortex-m7", built, None, str(other))
    assert rtos == freertos.FreeRtos(
        own, own / "portable/GCC/ARM_CM4F", "the library was built for FreeRTOS", tmp_path / "cfg"
    )
    # --freertos overrides the library's kernel; $UROS_FREERTOS stands in only for a kernel that is gone
    assert freertos.choose("cortex-m7", built, str(other), None).kernel == other  # type: ignore[union-attr]
    gone = library(tmp_path / "gone")
    assert freertos.choose("cortex-m7", gone, None, str(other)).kernel == other  # type: ignore[union-attr]
    with pytest.raises(ConfigError, match=r"the library's FreeRTOS kernel .*gone is gone"):
        freertos.choose("cortex-m7", gone, None, None)


@pytest.mark.parametrize(
    ("built", "flag", "message"),
    [
        (
            RtosInfo("zephyr", "/z", "", "", ""),
            None,
            "the library was built for 'zephyr'; the probe runs FreeRTOS only",
        ),
        (None, "nowhere", "--freertos nowhere: not a FreeRTOS-Kernel checkout \\(no tasks.c\\)"),
    ],
)
def test_what_the_probe_refuses(built: RtosInfo | None, flag: str | None, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        freertos.choose("cortex-m7", built, flag, None)


@pytest.mark.parametrize("version", ["V10.6.2", "V10.4.3", "V9.0.0"])
def test_a_kernel_before_v11_is_refused_with_the_version_it_needs(tmp_path: Path, version: str) -> None:
    """Round 5 (issue 43, 5): a V10 kernel failed in the linker (`collect2: error: ld returned 1`)."""
    kernel = fake_kernel(tmp_path / "k", version=version)
    assert freertos.kernel_version(kernel) == (int(version[1:].split(".")[0]), version)
    with pytest.raises(
        ConfigError, match=rf"--freertos .*k: FreeRTOS-Kernel {version}; the probe runs on V11\.x"
    ):
        freertos.choose("cortex-m7", None, str(kernel), None)
    # the library's own kernel is checked the same way
    with pytest.raises(ConfigError, match=rf"build-info.json's rtos.kernel .*: FreeRTOS-Kernel {version}"):
        freertos.choose("cortex-m7", library(kernel), None, None)


def test_a_freertos_library_is_not_probed_on_a_kernel_of_another_major_version(tmp_path: Path) -> None:
    """--freertos V11 over a library compiled against V10: its kernel objects may differ in layout."""
    built = library(fake_kernel(tmp_path / "v10", version="V10.6.2"))
    v11 = fake_kernel(tmp_path / "v11")
    with pytest.raises(
        ConfigError, match=r"FreeRTOS-Kernel V11.1.0, but the library was compiled against V10.6.2"
    ) as err:
        freertos.choose("cortex-m7", built, str(v11), None)
    assert "build the library against a FreeRTOS-Kernel V11.x" in str(err.value.hint)
    # another minor of V11 is the same kernel's objects
    other = fake_kernel(tmp_path / "v11.0", version="V11.0.1")
    assert freertos.choose("cortex-m7", library(other), str(v11), None).kernel == v11  # type: ignore[union-attr]


def test_a_kernel_whose_version_cannot_be_read_is_refused(tmp_path: Path) -> None:
    kernel = fake_kernel(tmp_path / "k")
    (kernel / "include" / "task.h").write_text("/* no version here */\n")
    assert freertos.kernel_version(kernel) is None
    with pytest.raises(ConfigError, match="names no tskKERNEL_VERSION_MAJOR"):
        freertos.choose("cortex-m7", None, str(kernel), None)
    assert freertos.kernel_version(fake_kernel(tmp_path / "v11", version="V11.0.1")) == (11, "V11.0.1")


def test_the_probe_config_serves_every_port_from_what_the_compiler_targets() -> None:
    """Round 5 (issue 43, 5): the ARMv8-M ports need configENABLE_FPU/MPU/TRUSTZONE, the CM55's
    configENABLE_MVE too (the CM33's refuses MVE 1); V11.1's ARM_CM0 and the ARMv8-M ports name
    their handlers SVC_Handler/PendSV_Handler/SysTick_Handler and keep them in portasm.c."""
    config = freertos.probe_config().read_text()
    for line in (
        "#if defined(__ARM_FP)\n#define configENABLE_FPU 1\n#else\n#define configENABLE_FPU 0",
        "#if defined(__ARM_FEATURE_MVE) && (__ARM_FEATURE_MVE > 0)\n#define configENABLE_MVE 1\n#else\n"
        "#define configENABLE_MVE 0",
        "#define configENABLE_MPU 0",
        "#define configENABLE_TRUSTZONE 0",
        "#define SVC_Handler probe_svcall",
        "#define PendSV_Handler probe_pendsv",
        "#define SysTick_Handler xPortSysTickHandler",
        "#define configCPU_CLOCK_HZ PROBE_CLOCK_HZ",
    ):
        assert line in config, line
    kernel = (probe.firmware_sources() / "freertos" / "kernel.cmake").read_text()
    assert 'if(EXISTS "${port}/portasm.c")' in kernel and '"${CMAKE_CURRENT_SOURCE_DIR}/board"' in kernel


def test_a_kernel_without_the_cores_port_is_refused(tmp_path: Path) -> None:
    kernel = fake_kernel(tmp_path / "k")  # only the M7's port
    with pytest.raises(ConfigError, match=r"portable/GCC/ARM_CM4F/port\.c"):
        freertos.choose("cortex-m4f", None, str(kernel), None)


def test_the_library_config_is_compared_with_the_probes(tmp_path: Path) -> None:
    kernel = fake_kernel(tmp_path / "k")
    same = tmp_path / "same"
    same.mkdir()
    (same / "FreeRTOSConfig.h").write_bytes(freertos.probe_config().read_bytes())
    other = tmp_path / "other"
    other.mkdir()
    (other / "FreeRTOSConfig.h").write_text("#define configUSE_TRACE_FACILITY 1\n")
    port = kernel / freertos.port_for("cortex-m7")
    assert freertos.config_differs(freertos.FreeRtos(kernel, port, "", None)) is None
    assert freertos.config_differs(freertos.FreeRtos(kernel, port, "", same)) is None
    warning = freertos.config_differs(freertos.FreeRtos(kernel, port, "", other))
    assert warning is not None and "must agree on what sizes the kernel's objects" in warning


def test_the_shipped_freertos_firmware_files() -> None:
    sources = probe.firmware_sources()
    cmake = (sources / "CMakeLists.txt").read_text()
    # the kernel's target before find_package(microros): a FreeRTOS library's package asks for it
    assert cmake.index("include(freertos/kernel.cmake)") < cmake.index("find_package(microros")
    assert "include(freertos/freertos.cmake)" in cmake
    assert "add_library(freertos_kernel STATIC" in (sources / "freertos" / "kernel.cmake").read_text()
    # `uros probe --app` on FreeRTOS: the app firmware (target uros_probe too) includes freertos.cmake
    # alone, which declares the kernel then, and runs no two-task stage
    app = (sources.parent / "probe-app.cmake.j2").read_text()
    assert "include(freertos/freertos.cmake)" in app
    assert app.index("include(freertos/kernel.cmake)") < app.index("find_package(microros")
    rtos_cmake = (sources / "freertos" / "freertos.cmake").read_text()
    assert 'include("${here}/kernel.cmake")' in rtos_cmake and "UROS_PROBE_APP=1" in rtos_cmake
    for name in ("FreeRTOSConfig.h", "rtos.c", "two_tasks.c", "kernel.cmake", "freertos.cmake"):
        assert (sources / "freertos" / name).is_file()
    config = freertos.probe_config().read_text()
    # what the client's multithread profile and the vector table need of the kernel
    for line in (
        "#define configUSE_RECURSIVE_MUTEXES 1",
        "#define configSUPPORT_STATIC_ALLOCATION 1",
        "#define vPortSVCHandler probe_svcall",
        "#define xPortPendSVHandler probe_pendsv",
    ):
        assert line in config
    rtos = (sources / "freertos" / "rtos.c").read_text()
    assert "rcutils_set_default_allocator(&allocator)" in rtos and "pvPortMalloc" in rtos
    assert "void *microros_allocate(size_t size, void *state) {" in rtos
    board = (sources / "arm" / "board.c").read_text()
    assert "probe_svcall, probe_idle, 0, probe_pendsv, probe_systick" in board
    for weak in ("uint32_t probe_millis(void)", "int clock_gettime(", "size_t probe_heap_used(void)"):
        assert f"__attribute__((weak)) {weak}" in board, weak


CONSOLE = """uros-probe: PASS
uros-probe: two tasks: a published 20 (0 failed), 20 intact, 0 torn, 0 twice; ...
uros-probe: stage two_tasks pass 2 tasks x 20 samples on 2 publishers, 40 of 40 arrived intact in 928 ms (multithread profile on)
uros-probe: freertos heap 34832 of 262144 B used at most, probe task stack 2216 of 16384 B
"""


def test_what_the_console_says_of_the_freertos_run() -> None:
    assert freertos.kernel_use(CONSOLE) == (34832, 262144, 2216, 16384)
    assert freertos.two_tasks(CONSOLE) == (
        "pass",
        "2 tasks x 20 samples on 2 publishers, 40 of 40 arrived intact in 928 ms (multithread profile on)",
    )
    assert freertos.describe_run(CONSOLE).startswith(
        "FreeRTOS: heap_4 34,832 of 262,144 B used at most, probe task stack 2,216 of 16,384 B; two_tasks pass: 2 tasks"
    )
    assert freertos.describe_run("") == "FreeRTOS: the firmware reported nothing more"
    assert "UCLIENT_PROFILE_MULTITHREAD=ON" in probe.verdict(9)
