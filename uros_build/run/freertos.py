"""The probe on FreeRTOS (docs/rtos.md): which kernel and which of its ports the probe firmware is
built with, and the CMake definitions that add them (templates/probe/freertos/kernel.cmake, freertos.cmake).

A library built for FreeRTOS (build-info.json's ``rtos``, written by ``uros build --rtos freertos``)
runs on the FreeRTOS variant of the probe with the kernel it was compiled against; any library runs
on it when asked with ``uros probe --freertos KERNEL``. $UROS_FREERTOS alone never switches the
variant (a bare-metal library stays bare metal); it names the kernel when a FreeRTOS library's own
kernel folder is gone. Pure: nothing here starts a process.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from uros_build import resources
from uros_build.errors import ConfigError
from uros_build.output.buildinfo import RtosInfo
from uros_build.target import rtos as rtos_table
from uros_build.target.profiles import shipped_profiles

_KERNEL_HINT = (
    "give a FreeRTOS-Kernel checkout (V11.x: git clone --branch V11.1.0 "
    "https://github.com/FreeRTOS/FreeRTOS-Kernel) with --freertos DIR or $UROS_FREERTOS"
)

_REBUILD_HINT = (
    "build the library against a FreeRTOS-Kernel V11.x (uros build --rtos freertos --rtos-dir KERNEL; "
    "git clone --branch V11.1.0 https://github.com/FreeRTOS/FreeRTOS-Kernel): the probe runs the "
    "kernel the library was compiled against"
)


@dataclass(frozen=True)
class FreeRtos:
    kernel: Path  # a FreeRTOS-Kernel checkout (tasks.c, include/FreeRTOS.h)
    port: Path  # the core's port folder (port.c, portmacro.h)
    why: str  # what chose FreeRTOS: "the library was built for FreeRTOS" or "--freertos"
    library_config: Path | None  # the FreeRTOSConfig.h folder the library was compiled with, if any


def port_for(target: str) -> str:
    """The kernel's port folder under portable/ for a target (meta/rtos/freertos.yaml, the table
    `uros build --rtos` chooses from: ARM_CM7/r0p1 on an M7, ARM_CM4F, ARM_CM3 ...)."""
    profile = shipped_profiles().get(target)
    folders = rtos_table.port_for(profile) if profile is not None else None
    if not folders or len(folders) != 1:
        raise ConfigError(
            f"uros probe: the probe runs no FreeRTOS port for target {target} here",
            "probe this target without FreeRTOS (the probe's FreeRTOS runs on Cortex-M cores)",
        )
    return folders[0]


def _port_dir(kernel: Path, port: str) -> Path:
    """A port folder as build-info.json or the table names it: absolute, or under <kernel>/portable."""
    return Path(port) if Path(port).is_absolute() else kernel / "portable" / port


NEEDED_MAJOR = 11  # the probe's FreeRTOSConfig.h: configKERNEL_PROVIDED_STATIC_MEMORY (V11.0), the V11 ports
_MAJOR = re.compile(rb"^[ \t]*#[ \t]*define[ \t]+tskKERNEL_VERSION_MAJOR[ \t]+(\d+)", re.MULTILINE)
_NUMBER = re.compile(
    rb'^[ \t]*#[ \t]*define[ \t]+tskKERNEL_VERSION_NUMBER[ \t]+"([^"\n]{1,40})"', re.MULTILINE
)


def kernel_version(kernel: Path) -> tuple[int, str] | None:
    """(major version, the version as the kernel names it) from its include/task.h, or None when it
    says neither (tskKERNEL_VERSION_MAJOR, tskKERNEL_VERSION_NUMBER)."""
    task_h = kernel / "include" / "task.h"
    try:
        with task_h.open("rb") as handle:
            text = handle.read(256 * 1024)  # the defines are at its top; a bounded read
    except OSError:
        return None
    major = _MAJOR.search(text)
    if major is None:
        return None
    number = _NUMBER.search(text)
    return int(major[1]), (number[1].decode("ascii", "replace") if number else f"V{int(major[1])}")


def check_kernel(kernel: Path, where: str, hint: str = _KERNEL_HINT) -> Path:
    """A folder that holds the kernel's sources and headers, of a version the probe runs (V11), or
    one line saying what is missing: before anything is built (a V10 kernel failed in the linker)."""
    missing = [name for name in ("tasks.c", "include/FreeRTOS.h") if not (kernel / name).is_file()]
    if missing:
        raise ConfigError(f"{where} {kernel}: not a FreeRTOS-Kernel checkout (no {missing[0]})", _KERNEL_HINT)
    version = kernel_version(kernel)
    if version is None:
        raise ConfigError(
            f"{where} {kernel}: its include/task.h names no tskKERNEL_VERSION_MAJOR: the probe cannot tell "
            f"the kernel's version (it needs V{NEEDED_MAJOR}.x)",
            _KERNEL_HINT,
        )
    if version[0] < NEEDED_MAJOR:
        raise ConfigError(
            f"{where} {kernel}: FreeRTOS-Kernel {version[1]}; the probe runs on V{NEEDED_MAJOR}.x (its "
            "FreeRTOSConfig.h and the V11 ports: the kernel's own idle task memory, the ARMv8-M and "
            "ARM_CM0 handlers)",
            hint,
        )
    return kernel


def choose(target: str, library: RtosInfo | None, flag: str | None, env: str | None) -> FreeRtos | None:
    """The kernel the probe runs on, or None (bare metal).

    ``library`` is build-info.json's ``rtos`` (None: the library names no RTOS); ``flag`` is
    --freertos (it alone makes a library without an RTOS run on FreeRTOS, and it overrides the
    library's kernel); ``env`` is $UROS_FREERTOS, used only where a FreeRTOS library's own kernel
    folder is gone (a library moved to another machine)."""
    if library is not None and library.name != "freertos":
        raise ConfigError(
            f"uros probe: the library was built for {library.name!r}; the probe runs FreeRTOS only"
        )
    if flag:
        kernel = check_kernel(Path(flag).expanduser(), "--freertos")
    elif library is not None:
        recorded = Path(library.kernel)
        if (recorded / "tasks.c").is_file():
            kernel = check_kernel(recorded, "build-info.json's rtos.kernel", _REBUILD_HINT)
        elif env:
            kernel = check_kernel(Path(env).expanduser(), "$UROS_FREERTOS")
        else:
            raise ConfigError(f"uros probe: the library's FreeRTOS kernel {recorded} is gone", _KERNEL_HINT)
    else:
        return None
    if flag and library is not None:
        _same_major(kernel, Path(library.kernel))
    # the library's own port (it may have chosen another with --rtos-port), else the table's
    names = library.port.split() if library is not None else []
    port = _port_dir(kernel, names[0] if len(names) == 1 else port_for(target))
    if not (port / "port.c").is_file():
        raise ConfigError(f"uros probe: FreeRTOS kernel {kernel}: no {port}/port.c", _KERNEL_HINT)
    why = "the library was built for FreeRTOS" if library is not None else "--freertos"
    return FreeRtos(kernel, port, why, Path(library.config) if library is not None else None)


def _same_major(given: Path, recorded: Path) -> None:
    """--freertos over a FreeRTOS library: a kernel of another major version than the one the library
    was compiled against is refused (the kernel objects the library holds, its mutexes, may have
    another layout); the recorded kernel gone, nothing can be compared."""
    theirs, ours = kernel_version(recorded), kernel_version(given)
    if theirs is not None and ours is not None and theirs[0] != ours[0]:
        raise ConfigError(
            f"--freertos {given}: FreeRTOS-Kernel {ours[1]}, but the library was compiled against "
            f"{theirs[1]} ({recorded}): the kernel objects it holds (the multithread profile's mutexes) "
            "may not have the same layout",
            _REBUILD_HINT,
        )


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
