"""Packages a firmware project consumes: a CMake config package (and, per target, ESP-IDF's).

Text is rendered by pure functions; the writers put it next to a build output.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

from uros_build import __version__, templating
from uros_build.defaults import BUILD_INFO
from uros_build.errors import ConfigError
from uros_build.output import folders
from uros_build.output.buildinfo import BuildInfo, RtosInfo
from uros_build.target import rtos as rtos_mod

CMAKE_FILES = ("microrosConfig.cmake", "microrosConfigVersion.cmake", "microros.cmake")

# ---------------------------------------------------------------------------------------------
# The export's folder: what each consumer can carry in it (measured with pkgconf 1.8.1, Meson 1.0,
# CMake 3.25 and GNU make 4.3; tests/integration/test_export_consumers.py). None of them can be
# told the folder in an escaped form: pkg-config finds it as ${pcfiledir}, make as MAKEFILE_LIST,
# CMake as CMAKE_CURRENT_LIST_DIR, so what they cannot carry is refused before anything is written.

# pkgconf prints ${pcfiledir} into the compile line with only spaces (and non-ASCII bytes)
# escaped, a line a shell (or Meson's shlex) reads: any other shell character breaks it (a '$' is
# expanded, a quote left open, '(' or ';' a syntax error or a second command); microros.mk's
# -I$(MICROROS_DIR)/include reaches the recipe's shell the same way.
_SHELL_SAFE = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 /._+-,:@%=~^#")
_WHY_SHELL = "{tool} puts the folder unquoted into the command line a shell reads"
_FOLDER_RULES = {
    "pkg-config": ("pkg-config", _WHY_SHELL.format(tool="pkg-config")),
    "make": ("make", _WHY_SHELL.format(tool="microros.mk")),
    # Meson decodes pkgconf's output as UTF-8 before undoing its byte escapes (e-acute: \\303\\251)
    "meson": ("Meson", "Meson reads pkg-config's answer, which escapes every non-ASCII byte, as UTF-8"),
    "cmake": (
        "CMake",
        "CMake splits the folder at ';' into a list, reads '\\' as an escape, and its Makefiles "
        "generator writes '\"' unescaped",
    ),
}
_FOLDER_KINDS = {"esp-idf": "cmake", "zephyr": "cmake"}


def folder_refusal(kind: str, folder: str) -> tuple[str, str, str] | None:
    """(the character, the format, why) when the consumer of export ``kind`` cannot use a package
    in ``folder``; None when it can (pure)."""
    rule = _FOLDER_KINDS.get(kind, kind)
    if rule not in _FOLDER_RULES:
        return None  # platformio (-L. from the library's folder), arduino: the folder is not written
    fmt, why = _FOLDER_RULES[rule]
    for char in folder:
        if rule == "cmake":
            bad = char in ';\\"'
        elif rule == "meson":
            bad = char not in _SHELL_SAFE
        else:
            bad = char not in _SHELL_SAFE and char.isascii()
        if bad:
            return char, fmt, why
    return None


def refuse_package_folder(kind: str, folder: Path, flag: str, fix: str) -> None:
    """One line, before anything is written, for a folder whose package the consumer of ``kind``
    could not use (folder_refusal): `uros export` and `uros build --output` (its CMake package)."""
    refused = folder_refusal(kind, str(folder))
    if refused is not None:
        char, fmt, why = refused
        raise ConfigError(
            f"{flag} {folder}: holds {char!r}, which {fmt} cannot use in the folder of a package ({why})",
            f"{fix} (or link one to it)",
        )


ESP_IDF_COMPONENT_FILE = "CMakeLists.txt"


ABI_FLAGS = ("mcpu", "mfpu", "mfloat-abi", "mabi")


def abi_flags(cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """-mcpu/-mfpu/-mfloat-abi/-mabi -> the value the library was built with ('' when it names
    none; the last one wins, as with GCC) (pure)."""
    found = dict.fromkeys(ABI_FLAGS, "")
    for flag in cpu_flags:
        name, sep, value = flag[1:].partition("=")
        if flag.startswith("-") and sep and name in found:
            found[name] = value
    return found


def cmake_package_files(
    target: str, cpu_flags: tuple[str, ...], rtos: RtosInfo | None = None
) -> dict[str, str]:
    """File name -> text of the CMake package (pure). ``rtos``: the RTOS the library was compiled
    against, which the package asks the firmware for at configure time."""
    ctx = {
        "version": __version__,
        "target": target,
        "cpu_flags": list(cpu_flags),
        "abi": abi_flags(cpu_flags),
        "package_version": __version__,
        "rtos": rtos,
        # the define the library's headers were compiled with: the firmware's compile gets it too
        "rtos_define": rtos_mod.DEFINES.get(rtos.name, "") if rtos else "",
    }
    return {name: templating.render(f"{name}.j2", **ctx) for name in CMAKE_FILES}


def esp_idf_component_files(target: str, idf_target: str, transport: str | None) -> dict[str, str]:
    """File name -> text of the ESP-IDF component around a build output (pure)."""
    # XRCE-DDS' UDP transport on FreeRTOS calls lwIP's sockets; custom transports need nothing.
    requires = ["lwip"] if transport in ("udp", "tcp") else []
    text = templating.render(
        "esp-idf-component.cmake.j2",
        version=__version__,
        target=target,
        idf_target=idf_target,
        transport=transport or "custom",
        requires=requires,
    )
    return {ESP_IDF_COMPONENT_FILE: text, IDF_MANIFEST_FILE: idf_component_manifest(target, idf_target)}


IDF_MANIFEST_FILE = "idf_component.yml"


def idf_component_manifest(target: str, idf_target: str) -> str:
    """idf_component.yml, so that the IDF component manager accepts the component (a local or
    registry dependency): its version, the one IDF target the library was built for, and the IDF
    versions uros builds against (https://docs.espressif.com/projects/idf-component-manager/en/latest/reference/manifest_file.html)."""
    data = {
        "version": __version__,
        "description": f"micro-ROS, prebuilt by uros for {target} (ESP-IDF target {idf_target})",
        "url": "https://micro.ros.org",
        "targets": [idf_target],
        "dependencies": {"idf": ">=5.0"},
    }
    header = f"# Generated by uros {__version__} for target '{target}': `uros export esp-idf` rewrites it.\n"
    return header + json.dumps(data, indent=2, sort_keys=True) + "\n"  # JSON is YAML: every value quoted


MAKE_FILE = "microros.mk"
PC_FILE = "microros.pc"
MESON_FILE = "microros-cross.ini"


def make_fragment(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.mk: MICROROS_CFLAGS / MICROROS_LIBS / MICROROS_CPU_FLAGS for a Make firmware (pure)."""
    text = templating.render(f"{MAKE_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {MAKE_FILE: text}


def pkg_config_file(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """microros.pc, relocatable (${pcfiledir}) (pure)."""
    text = templating.render(f"{PC_FILE}.j2", version=__version__, target=target, cpu_flags=list(cpu_flags))
    return {PC_FILE: text}


def tool_prefix(compiler: str) -> str:
    """``/usr/bin/arm-none-eabi-gcc`` -> ``/usr/bin/arm-none-eabi-`` (pure)."""
    folder, _, name = compiler.rpartition("/")
    stem = name[: -len("gcc")] if name.endswith("gcc") else name
    return f"{folder}/{stem}" if folder else stem


def meson_cpu_family(prefix: str) -> str:
    """Meson's cpu_family for a GCC triplet (https://mesonbuild.com/Reference-tables.html#cpu-families)."""
    name = prefix.rpartition("/")[2]
    for start, family in (
        ("arm", "arm"),
        ("xtensa", "xtensa"),
        ("riscv32", "riscv32"),
        ("riscv64", "riscv64"),
    ):
        if name.startswith(start):
            return family
    return name.split("-", 1)[0] or "arm"


def meson_cross_file(target: str, compiler: str, cpu_flags: tuple[str, ...], folder: str) -> dict[str, str]:
    """microros-cross.ini beside microros.pc: the compiler, the CPU flags and pkg-config's folder (pure)."""
    prefix = tool_prefix(compiler)
    text = templating.render(
        f"{MESON_FILE}.j2",
        version=__version__,
        target=target,
        prefix=prefix,
        cpu_flags=list(cpu_flags),
        link_flags=list(cpu_flags),
        cpu_family=meson_cpu_family(prefix),
        cpu=target,
        folder=folder,
    )
    return {MESON_FILE: text, **pkg_config_file(target, cpu_flags)}


def _write(out: Path, files: dict[str, str]) -> list[Path]:
    for name, text in files.items():
        (out / name).write_text(text, encoding="utf-8")
    return [out / name for name in files]


def write_cmake_package(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, cmake_package_files(info.target, info.flags.cpu, info.rtos))


def write_make_fragment(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, make_fragment(info.target, info.flags.cpu))


def write_pkg_config(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, pkg_config_file(info.target, info.flags.cpu))


def write_meson_cross(out: Path, info: BuildInfo, folder: Path | None = None) -> list[Path]:
    """``folder``: where the files will be read from (pkg_config_libdir), when not ``out``."""
    compiler = info.compiler.path if info.compiler else ""
    return _write(out, meson_cross_file(info.target, compiler, info.flags.cpu, str(folder or out)))


def write_esp_idf_component(out: Path, info: BuildInfo) -> list[Path]:
    assert info.idf_target, "callers check that the build is for an ESP-IDF target"
    return _write(out, esp_idf_component_files(info.target, info.idf_target, info.transport))


def copy_build_output(src: Path, dst: Path) -> list[str]:
    """Copy library, headers and build-info from one output folder to another; returns the names
    copied."""
    dst.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src / "libmicroros.a", dst / "libmicroros.a")
    if (dst / "include").exists():
        shutil.rmtree(dst / "include")
    shutil.copytree(src / "include", dst / "include")
    copied = ["libmicroros.a", "include"]
    for name in (BUILD_INFO, "toolchain.cmake"):
        if (src / name).is_file():
            shutil.copy2(src / name, dst / name)
            copied.append(name)
    return copied


# ---------------------------------------------------------------------------------------------
# Arduino: one precompiled library for several targets
# (https://arduino.github.io/arduino-cli/latest/library-specification/#precompiled-binaries)

ARDUINO_NAME = "micro_ros_uros"


@dataclass(frozen=True)
class ArduinoCore:
    """Boards of one Arduino core, as its sources say it compiles for them."""

    boards: str
    architecture: str  # the platform's architecture: library.properties' architectures= value
    mcu: str  # build.mcu: the folder below src/ that arduino-cli looks in
    cpu: str  # the -mcpu it compiles with
    fpu: str = ""  # -mfpu, "" for none
    float_abi: str = ""  # -mfloat-abi, "" for soft (none given)


# From the cores' own boards.txt/platform.txt (README, "Arduino"): STM32duino
# (stm32duino/Arduino_Core_STM32), Teensy 4 (Teensyduino's boards.txt: build.mcu=imxrt1062 and
# PaulStoffregen/cores teensy4/Makefile's CPUOPTIONS), Arduino's mbed core (arduino/ArduinoCore-mbed:
# its M4/M7 boards compile softfp, which no hard-float library fits).
ARDUINO_CORES = (
    ArduinoCore("Teensy 4.0/4.1/MicroMod", "avr", "imxrt1062", "cortex-m7", "fpv5-d16", "hard"),
    ArduinoCore("STM32duino F7/H7 (Cortex-M7)", "stm32", "cortex-m7", "cortex-m7", "fpv5-sp-d16", "hard"),
    ArduinoCore(
        "STM32duino F3/F4/G4/L4/WB/WL (Cortex-M4)", "stm32", "cortex-m4", "cortex-m4", "fpv4-sp-d16", "hard"
    ),
    ArduinoCore(
        "STM32duino H5/L5/U5/WBA (Cortex-M33)", "stm32", "cortex-m33", "cortex-m33", "fpv5-sp-d16", "hard"
    ),
    ArduinoCore("STM32duino F1/F2/L1 (Cortex-M3)", "stm32", "cortex-m3", "cortex-m3"),
    ArduinoCore("STM32duino C0/G0/L0/U0 (Cortex-M0+)", "stm32", "cortex-m0plus", "cortex-m0plus"),
    ArduinoCore("Arduino Nano RP2040 Connect (mbed)", "mbed_nano", "cortex-m0plus", "cortex-m0plus"),
    ArduinoCore("Raspberry Pi Pico (Arduino mbed)", "mbed_rp2040", "cortex-m0plus", "cortex-m0plus"),
    ArduinoCore(
        "Portenta H7, Opta, Nicla Vision, Giga (mbed, M7)",
        "mbed_portenta",
        "cortex-m7",
        "cortex-m7",
        "fpv5-d16",
        "softfp",
    ),
    ArduinoCore(
        "Nano 33 BLE, Nicla Sense/Voice (mbed, M4)",
        "mbed_nano",
        "cortex-m4",
        "cortex-m4",
        "fpv4-sp-d16",
        "softfp",
    ),
)


def arduino_cores(cpu_flags: tuple[str, ...]) -> tuple[ArduinoCore, ...]:
    """The cores whose compile flags are the library's: the same -mcpu, FPU and float ABI (pure)."""
    abi = abi_flags(cpu_flags)
    float_abi = "" if abi["mfloat-abi"] in ("", "soft") else abi["mfloat-abi"]
    fpu = abi["mfpu"] if float_abi else ""  # soft float uses no FPU
    return tuple(c for c in ARDUINO_CORES if (c.cpu, c.fpu, c.float_abi) == (abi["mcpu"], fpu, float_abi))


def arduino_folders(cpu_flags: tuple[str, ...]) -> list[str]:
    """Where arduino-cli looks for the archive on the boards the library fits (its builder's
    findExpectedPrecompiledLibFolder): ``src/{build.mcu}/{fpu}-{float-abi}`` (the values it reads
    from the compile line), then ``src/{build.mcu}``, the fallback PlatformIO's Arduino builder and
    arduino-cli since its #3199 (May 2026: it composes the first from build.fpu/build.float-abi,
    "-mfpu=...--mfloat-abi=..." with STM32duino's values, a folder no library has) find. Pure;
    empty when no core fits."""
    folders: list[str] = []
    for core in arduino_cores(cpu_flags):
        specs = [f"{core.mcu}/{core.fpu}-{core.float_abi}"] if core.fpu else []
        folders += [f for f in (*specs, core.mcu) if f not in folders]
    return folders


def arduino_properties(targets: list[str], architectures: list[str]) -> str:
    """library.properties for a precompiled library (pure)."""
    lines = [
        f"# Generated by uros {__version__} for {', '.join(targets)}: `uros export arduino` rewrites it.",
        f"name={ARDUINO_NAME}",
        f"version={__version__}",
        "author=uros",
        "maintainer=uros",
        "sentence=micro-ROS, prebuilt by uros for " + ", ".join(targets) + ".",
        "paragraph=libmicroros.a per target (src/<mcu>/<fpu>-<float-abi>/ and src/<mcu>/) and its headers.",
        "category=Communication",
        "url=https://micro.ros.org",
        # the platforms of the cores the libraries fit (Teensyduino's is "avr": FQBN teensy:avr:teensy41)
        f"architectures={','.join(sorted(set(architectures)))}",
        f"includes={ARDUINO_NAME}.h",
        "precompiled=true",
        "ldflags=-lmicroros",
    ]
    return "\n".join(lines) + "\n"


def arduino_header() -> str:
    return (
        f"// Generated by uros {__version__}: the header Arduino's builder finds this library by.\n"
        "#pragma once\n#include <rcl/rcl.h>\n#include <rclc/rclc.h>\n#include <rclc/executor.h>\n"
    )


# ---------------------------------------------------------------------------------------------
# PlatformIO: a library folder for lib_deps (https://docs.platformio.org/en/latest/manifests/library-json/)

PLATFORMIO_FILE = "library.json"
# PlatformIO gives a library's build.flags to the compiler only: its extra script puts the CPU
# flags on the firmware's link (templates/platformio-abi.py.j2 says how and why)
PLATFORMIO_SCRIPT = "uros_platformio_abi.py"


def platformio_manifest(target: str) -> dict[str, str]:
    """library.json beside libmicroros.a and include/: nothing to compile, the headers on the
    include path, the prebuilt archive linked (flags are relative to the library's folder), and
    the extra script that links the firmware with the library's CPU flags."""
    data = {
        "name": ARDUINO_NAME,
        "version": __version__,
        "description": f"micro-ROS, prebuilt by uros for {target}",
        "keywords": ["micro-ros", "ros2", "uros"],
        "license": "Apache-2.0",
        "frameworks": "*",
        "platforms": "*",
        "build": {
            "includeDir": "include",
            "srcFilter": ["-<*>"],
            "libArchive": False,
            "flags": ["-L.", "-lmicroros"],
            "extraScript": PLATFORMIO_SCRIPT,
        },
    }
    return {PLATFORMIO_FILE: json.dumps(data, indent=2, sort_keys=True) + "\n"}


def platformio_files(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """library.json and its extra script (pure)."""
    abi = {name: value for name, value in abi_flags(cpu_flags).items() if value}
    script = templating.render(
        "platformio-abi.py.j2", version=__version__, target=target, cpu_flags=list(cpu_flags), abi=abi
    )
    return {**platformio_manifest(target), PLATFORMIO_SCRIPT: script}


def platformio_build_flags(cpu_flags: tuple[str, ...]) -> str:
    """The platformio.ini line that compiles a firmware with the library's ABI (pure)."""
    return "build_flags = " + " ".join(cpu_flags)


def write_platformio(out: Path, info: BuildInfo) -> list[Path]:
    return _write(out, platformio_files(info.target, info.flags.cpu))


# ---------------------------------------------------------------------------------------------
# Zephyr: a module around the prebuilt library (https://docs.zephyrproject.org/latest/develop/modules.html)

ZEPHYR_FILES = ("zephyr/module.yml", "CMakeLists.txt", "Kconfig", "zephyr/uros_clock.c")

# Zephyr's Kconfig symbol for each -mcpu (arch/arm/core/Kconfig; cmake/gcc-m-cpu.cmake maps them back)
_ZEPHYR_CPUS = {
    "cortex-m0plus": "CPU_CORTEX_M0PLUS",
    "cortex-m3": "CPU_CORTEX_M3",
    "cortex-m4": "CPU_CORTEX_M4",
    "cortex-m7": "CPU_CORTEX_M7",
    "cortex-m33": "CPU_CORTEX_M33",
}


def zephyr_depends(cpu_flags: tuple[str, ...]) -> list[str]:
    """The Kconfig expressions the module's option depends on (pure): newlib (against picolibc,
    Zephyr's default since 3.5, or the minimal libc, __errno and _impure_ptr are undefined), and the
    architecture, CPU and float ABI that Zephyr compiles with the library's flags: with FPU and
    FP_HARDABI it compiles -mfloat-abi=hard, with FP_SOFTABI softfp, else soft; -mfpu is
    fpv4/fpv5-d16 when CPU_HAS_FPU_DOUBLE_PRECISION, else the -sp- one (cmake/gcc-m-fpu.cmake).
    Never a board."""
    abi = abi_flags(cpu_flags)
    depends = ["NEWLIB_LIBC"]
    if abi["mcpu"] in _ZEPHYR_CPUS:
        arm = ["ARM", _ZEPHYR_CPUS[abi["mcpu"]]]
        if abi["mfloat-abi"] == "hard":
            precision = (
                "!CPU_HAS_FPU_DOUBLE_PRECISION" if "-sp-" in abi["mfpu"] else "CPU_HAS_FPU_DOUBLE_PRECISION"
            )
            arm += ["FPU", "FP_HARDABI", precision]
        else:
            arm.append("!FP_HARDABI")  # soft and softfp pass floats alike
        depends.append(" && ".join(arm))
    elif any(f.startswith("-march=rv") for f in cpu_flags):
        depends.append("RISCV")
    elif any(f.startswith("-mcpu=") or f.startswith("-march=") for f in cpu_flags):
        raise ConfigError(
            f"{' '.join(cpu_flags)}: uros knows no Zephyr CPU for these flags",
            "export a Cortex-M0+, M3, M4, M7, M33 or RISC-V output",
        )
    return depends


def zephyr_module_files(target: str, cpu_flags: tuple[str, ...]) -> dict[str, str]:
    """zephyr/module.yml (its build: cmake and kconfig at the module's root), the CMakeLists.txt that
    links the library, the clock shim it compiles, and the Kconfig option that turns it on (pure)."""
    shown = templating.cmake_comment(target)
    module = json.dumps({"name": ARDUINO_NAME, "build": {"cmake": ".", "kconfig": "Kconfig"}}, sort_keys=True)
    flags = templating.cmake_comment(" ".join(cpu_flags))
    kconfig = (
        f"# Generated by uros {__version__} for target '{shown}'.\n"
        "config MICRO_ROS_UROS\n"
        '\tbool "micro-ROS, prebuilt by uros"\n'
        + "".join(f"\tdepends on {d}\n" for d in zephyr_depends(cpu_flags))
        + "\thelp\n"
        f"\t  Link libmicroros.a (built by uros for {shown}: {flags}) and use its headers.\n"
        "\t  It needs newlib (CONFIG_NEWLIB_LIBC=y; with picolibc or the minimal libc\n"
        "\t  __errno and _impure_ptr are undefined) and a CPU compiled with the flags above.\n"
    )
    header = f"# Generated by uros {__version__}: uros export zephyr rewrites it.\n"
    return {
        "zephyr/module.yml": f"{header}{module}\n",
        "CMakeLists.txt": templating.render("zephyr-module.cmake.j2", version=__version__, target=target),
        "Kconfig": kconfig,
        "zephyr/uros_clock.c": templating.render("zephyr-uros-clock.c.j2", version=__version__),
    }


def write_zephyr_module(out: Path, info: BuildInfo) -> list[Path]:
    (out / "zephyr").mkdir(exist_ok=True)
    return _write(out, zephyr_module_files(info.target, info.flags.cpu))


# ---------------------------------------------------------------------------------------------
# Exports beside the library (`uros export make --output build/cortex-m7`, the README's flow)


def carry_over(out: Path, staging: Path, info: BuildInfo) -> list[str]:
    """The exports an earlier `uros export KIND --output OUT` wrote into the output ``out`` (its
    marker names them), written again into the next build's ``staging`` for its library, so that
    the build's swap does not drop them. Returns the kinds carried over."""
    owned = folders.owned_entries(out) or frozenset()

    def has(*names: str) -> bool:
        return all(n in owned and (out / n).exists() for n in names)

    carried = []
    meson = has(MESON_FILE) and info.compiler is not None
    for kind, present, write in (
        ("make", has(MAKE_FILE), write_make_fragment),
        ("pkg-config", has(PC_FILE) and not meson, write_pkg_config),
        ("meson", meson, lambda s, i: write_meson_cross(s, i, out)),
        ("platformio", has(PLATFORMIO_FILE), write_platformio),
        ("zephyr", has("CMakeLists.txt", "Kconfig", "zephyr"), write_zephyr_module),
        (
            "esp-idf",
            has(ESP_IDF_COMPONENT_FILE, IDF_MANIFEST_FILE) and bool(info.idf_target),
            write_esp_idf_component,
        ),
    ):
        if present:
            write(staging, info)
            carried.append(kind)
    return carried
