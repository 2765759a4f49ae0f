"""FreeRTOS fixtures the RTOS tests share (tests/integration/test_rtos.py, and anyone who needs a
FreeRTOSConfig.h): a stand-in kernel folder in FreeRTOS-Kernel's layout, written here (a few
lines of the test's own, not FreeRTOS code), and a minimal FreeRTOSConfig.h that a real
FreeRTOS-Kernel V11 (UROS_FREERTOS) compiles with on a Cortex-M."""

from __future__ import annotations

import textwrap
from pathlib import Path

# The fewest settings FreeRTOS-Kernel V11's FreeRTOS.h and its Cortex-M ports need, plus what
# the XRCE-DDS client's multithread profile uses: static recursive mutexes.
FREERTOS_CONFIG_H = textwrap.dedent(
    """\
    /* FreeRTOSConfig.h written by uros's tests: the fewest settings FreeRTOS-Kernel V11 needs. */
    #ifndef FREERTOS_CONFIG_H
    #define FREERTOS_CONFIG_H
    #define configUSE_PREEMPTION 1
    #define configCPU_CLOCK_HZ 25000000UL
    #define configTICK_RATE_HZ 1000
    #define configMAX_PRIORITIES 5
    #define configMINIMAL_STACK_SIZE 256
    #define configTOTAL_HEAP_SIZE (64 * 1024)
    #define configMAX_TASK_NAME_LEN 16
    #define configTICK_TYPE_WIDTH_IN_BITS TICK_TYPE_WIDTH_32_BITS
    #define configUSE_MUTEXES 1
    #define configUSE_RECURSIVE_MUTEXES 1
    #define configSUPPORT_STATIC_ALLOCATION 1
    #define configSUPPORT_DYNAMIC_ALLOCATION 1
    #define configUSE_IDLE_HOOK 0
    #define configUSE_TICK_HOOK 0
    #define configKERNEL_INTERRUPT_PRIORITY (7 << 5)
    #define configMAX_SYSCALL_INTERRUPT_PRIORITY (5 << 5)
    #define INCLUDE_vTaskDelay 1
    #endif
    """
)


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def make_standin_kernel(root: Path, port: str = "GCC/ARM_CM7/r0p1") -> Path:
    """``root`` in FreeRTOS-Kernel's layout with the headers micro-ROS's compile includes, each a
    line or two: include/FreeRTOS.h (which, as the real one, includes FreeRTOSConfig.h and the
    port's portmacro.h), include/semphr.h, portable/<port>/portmacro.h (FX_PORT names the port)."""
    _write(
        root / "include" / "FreeRTOS.h",
        '#ifndef FX_FREERTOS_H\n#define FX_FREERTOS_H\n#include "FreeRTOSConfig.h"\n#include "portmacro.h"\n'
        "#define FX_KERNEL 1\n#endif\n",
    )
    _write(root / "include" / "semphr.h", "typedef void *SemaphoreHandle_t;\n")
    macro = port.replace("/", "_").upper()
    _write(root / "portable" / port / "portmacro.h", f"#define FX_PORT_{macro} 1\n")
    return root


def write_config(folder: Path, text: str = "#define configTICK_RATE_HZ 1000\n") -> Path:
    """``folder``/FreeRTOSConfig.h with ``text`` (the stand-in kernel's tests change it)."""
    _write(folder / "FreeRTOSConfig.h", text)
    return folder
