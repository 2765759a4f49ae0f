"""The probe on FreeRTOS (docs/rtos.md): which kernel and which of its ports the probe firmware is
built with, and the CMake definitions that add them (templates/probe/freertos/freertos.cmake).

A library built for FreeRTOS (build-info.json's ``rtos``, written by ``uros build --rtos freertos``)
runs on the FreeRTOS variant of the probe with the kernel it was compiled against; any library runs
on it when asked with ``uros probe --freertos KERNEL``. $UROS_FREERTOS alone never switches the
variant (a bare-metal library stays bare metal); it names the kernel when a FreeRTOS library's own
kernel folder is gone. Pure: nothing here starts a process.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import resources
from uros_build.errors import ConfigError

# The kernel's GCC port for each core uros has a profile for (FreeRTOS-Kernel V11.x,
# portable/GCC/): an M4 without its FPU and an M3 share ARM_CM3; the M7 takes ARM_CM7/r0p1, which
# the kernel's ARM_CM7/ReadMe.txt says runs on every M7 revision (an erratum workaround for r0p1
# silicon); ARMv8-M cores take the non-TrustZone port.
PORTS: Mapping[str, str] = {
    "cortex-m7": "portable/GCC/ARM_CM7/r0p1",
    "cortex-m7-sp": "portable/GCC/ARM_CM7/r0p1",
    "cortex-m4f": "portable/GCC/ARM_CM4F",
    "cortex-m4": "portable/GCC/ARM_CM3",
    "cortex-m3": "portable/GCC/ARM_CM3",
    "cortex-m0plus": "portable/GCC/ARM_CM0",
    "cortex-m33": "portable/GCC/ARM_CM33_NTZ/non_secure",
    "cortex-m55": "portable/GCC/ARM_CM55_NTZ/non_secure",
}

_KERNEL_HINT = (
    "give a FreeRTOS-Kernel checkout (V11.x: git clone --branch V11.1.0 "
    "https://github.com/FreeRTOS/FreeRTOS-Kernel) with --freertos DIR or $UROS_FREERTOS"
)


@dataclass(frozen=True)
class FreeRtos:
    kernel: Path  # a FreeRTOS-Kernel checkout (tasks.c, include/FreeRTOS.h)
    port: Path  # the core's port folder (port.c, portmacro.h)
    why: str  # what chose FreeRTOS: "the library was built for FreeRTOS" or "--freertos"
    library_config: Path | None  # the FreeRTOSConfig.h folder the library was compiled with, if any


def port_for(target: str) -> str:
    """The kernel's port folder (relative to the kernel) for a target."""
    if target not in PORTS:
        raise ConfigError(
            f"uros probe: FreeRTOS has no port here for target {target} (ports: {', '.join(sorted(PORTS))})",
            "probe this target without FreeRTOS",
        )
    return PORTS[target]


def check_kernel(kernel: Path, where: str) -> Path:
    """A folder that holds the kernel's sources and headers, or one line saying what is missing."""
    missing = [name for name in ("tasks.c", "include/FreeRTOS.h") if not (kernel / name).is_file()]
    if missing:
        raise ConfigError(f"{where} {kernel}: not a FreeRTOS-Kernel checkout (no {missing[0]})", _KERNEL_HINT)
    return kernel


def choose(
    target: str,
    library_rtos: Mapping[str, object] | None,
    flag: str | None,
    env: str | None,
) -> FreeRtos | None:
    """The kernel the probe runs on, or None (bare metal).

    ``library_rtos`` is build-info.json's ``rtos`` (None: the library names no RTOS); ``flag`` is
    --freertos (it alone makes a library without an RTOS run on FreeRTOS, and it overrides the
    library's kernel); ``env`` is $UROS_FREERTOS, used only where a FreeRTOS library's own kernel
    folder is gone (a library moved to another machine)."""
    name = str(library_rtos.get("name", "")) if library_rtos else ""
    if library_rtos and name != "freertos":
        raise ConfigError(f"uros probe: the library was built for {name!r}; the probe runs FreeRTOS only")
    built_for = name == "freertos"
    if flag:
        kernel = check_kernel(Path(flag).expanduser(), "--freertos")
        why = "the library was built for FreeRTOS" if built_for else "--freertos"
    elif built_for:
        recorded = Path(str(library_rtos.get("kernel", ""))) if library_rtos else Path()
        if (recorded / "tasks.c").is_file():
            kernel = check_kernel(recorded, "build-info.json's rtos.kernel")
        elif env:
            kernel = check_kernel(Path(env).expanduser(), "$UROS_FREERTOS")
        else:
            raise ConfigError(
                f"uros probe: the library's FreeRTOS kernel {recorded} is gone",
                _KERNEL_HINT,
            )
        why = "the library was built for FreeRTOS"
    else:
        return None
    config = library_rtos.get("config") if library_rtos else None
    port = kernel / port_for(target)
    if not (port / "port.c").is_file():
        raise ConfigError(f"uros probe: FreeRTOS kernel {kernel}: no {port_for(target)}/port.c", _KERNEL_HINT)
    return FreeRtos(kernel, port, why, Path(str(config)) if config else None)


def cmake_defines(rtos: FreeRtos | None) -> list[str]:
    """The probe firmware's configure definitions: none on bare metal."""
    if rtos is None:
        return []
    return [f"-DUROS_FREERTOS_KERNEL={rtos.kernel}", f"-DUROS_FREERTOS_PORT={rtos.port}"]


def firmware_folders(rtos: FreeRtos | None) -> list[str]:
    """The probe sources' sub-folders the firmware needs: the FreeRTOS variant's own files."""
    return ["freertos"] if rtos is not None else []


def probe_config() -> Path:
    """The probe's own FreeRTOSConfig.h (a library for the probe is built with --rtos-config its folder)."""
    return resources.templates_dir() / "probe" / "freertos" / "FreeRTOSConfig.h"


def config_differs(rtos: FreeRtos) -> str | None:
    """A warning when the library was compiled with another FreeRTOSConfig.h than the probe's kernel
    runs with: the kernel objects the library allocates (its mutexes) must have the same layout."""
    if rtos.library_config is None:
        return None
    theirs = rtos.library_config / "FreeRTOSConfig.h"
    if not theirs.is_file():
        return f"the library's FreeRTOSConfig.h ({theirs}) is gone: the probe's own is used"
    if hashlib.sha256(theirs.read_bytes()).digest() == hashlib.sha256(probe_config().read_bytes()).digest():
        return None
    return (
        f"the library was compiled with {theirs}, the probe's kernel runs with its own "
        f"({probe_config()}): they must agree on what sizes the kernel's objects (tick width, "
        "static allocation, trace facility, queue sets)"
    )


_KERNEL_USE = re.compile(
    r"uros-probe: freertos heap (\d+) of (\d+) B used at most, probe task stack (\d+) of (\d+) B"
)
_TWO_TASKS = re.compile(r"uros-probe: stage two_tasks (pass|fail|skip) ?(.*)")


def kernel_use(console: str) -> tuple[int, int, int, int] | None:
    """(kernel heap used at most, its size, the probe task's stack high-water, its size), in bytes."""
    found = _KERNEL_USE.search(console)
    return (int(found[1]), int(found[2]), int(found[3]), int(found[4])) if found else None


def two_tasks(console: str) -> tuple[str, str] | None:
    """The two-task stage's result and detail, from its `uros-probe: stage two_tasks ...` line."""
    found = _TWO_TASKS.search(console)
    return (found[1], found[2].strip()) if found else None


def describe_run(console: str) -> str:
    """What the FreeRTOS run adds to the verdict: the kernel's memory and the two-task stage."""
    parts = []
    used = kernel_use(console)
    if used:
        heap, size, stack, depth = used
        parts.append(f"heap_4 {heap:,} of {size:,} B used at most, probe task stack {stack:,} of {depth:,} B")
    stage = two_tasks(console)
    if stage:
        parts.append(f"two_tasks {stage[0]}: {stage[1]}")
    return "FreeRTOS: " + ("; ".join(parts) if parts else "the firmware reported nothing more")
