"""The RTOS micro-ROS is compiled against (`uros build --rtos freertos --rtos-dir KERNEL
--rtos-config DIR`): its kernel's include folder, the port's folder for the target's core and the
folder of the application's FreeRTOSConfig.h, checked and hashed.

Why micro-ROS needs them: with ``UCLIENT_PROFILE_MULTITHREAD`` the XRCE-DDS client's
``include/uxr/client/profile/multithread/multithread.h`` includes ``FreeRTOS.h`` and ``semphr.h``
when ``PLATFORM_NAME_FREERTOS`` is defined, and its ``src/c/profile/multithread/multithread.c``
locks with FreeRTOS's recursive mutexes (eProsima/Micro-XRCE-DDS-Client, branch ros2). FreeRTOS.h
includes FreeRTOSConfig.h (the application's) and portable.h, which includes the port's
portmacro.h. micro_ros_setup's FreeRTOS platforms hand these folders to the library's compile the
same way (freertos_apps' Makefiles: ``-I.../Source/include -I.../portable/GCC/ARM_CM7/r0p1``).

The port comes from ``meta/rtos/freertos.yaml`` (data: a rule per core). The headers are hashed
(``headers_sha256``): the kernel's include/*.h, every port folder's *.h and FreeRTOSConfig.h, by
their names relative to their folder, so that the build key is the same wherever the kernel lives
and a changed FreeRTOSConfig.h is a changed input. Other headers FreeRTOSConfig.h includes are
followed by the compiler's own dependency output (colcon/depfiles.py: headers read outside the
workspace).

Pure: reads files, starts no process.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uros_build import loader, resources
from uros_build.errors import ConfigError

if TYPE_CHECKING:  # a type only: the exports read this module at every start (start-up cost)
    from uros_build.target.profiles import TargetProfile

NAMES = ("freertos",)  # the RTOSes uros knows (--rtos)
FREERTOS = "freertos"
# What upstream keys the client's FreeRTOS code on (multithread.h, multithread.c): a C define, not
# a CMake PLATFORM_NAME (the client's CMakeLists.txt knows FreeRTOS only as FreeRTOS_Plus_TCP, a
# network stack, for its UDP/TCP transports).
DEFINE = "PLATFORM_NAME_FREERTOS"
DEFINES = {FREERTOS: DEFINE}  # each RTOS's define, for the firmware's compile too (output/exports/cmake.py)
KERNEL_HEADER = "FreeRTOS.h"
CONFIG_HEADER = "FreeRTOSConfig.h"
PORT_HEADER = "portmacro.h"
# where a portable folder named relatively is found: FreeRTOS-Kernel's layout (and CubeMX's
# Middlewares/Third_Party/FreeRTOS/Source, the same)
PORTABLE = "portable"


@dataclass(frozen=True)
class PortRule:
    """A row of meta/rtos/freertos.yaml: a core (its -mcpu, or an -march prefix), whether it has
    a hardware FPU (None: either), and its port folders under the kernel's portable/."""

    port: tuple[str, ...]
    mcpu: str = ""
    march: str = ""
    fpu: bool | None = None

    def matches(self, mcpu: str, march: str, fpu: bool) -> bool:
        if self.mcpu and self.mcpu != mcpu:
            return False
        if self.march and not march.startswith(self.march):
            return False
        return self.fpu is None or self.fpu == fpu


def parse_ports(data: Any, source: str) -> tuple[PortRule, ...]:
    top = loader.mapping(data, source, {"ports"}, ("ports",))
    rules = []
    rows = loader.mapping_list(top, "ports", source, {"mcpu", "march", "fpu", "port"}, ("port",))
    for i, row in enumerate(rows):
        where = f"{source}: ports[{i}]"
        port = loader.string_list(row, "port", where)
        if not port:
            raise ConfigError(f"{where}: port: must name at least one folder")
        if not row.get("mcpu") and not row.get("march"):
            raise ConfigError(f"{where}: needs mcpu or march")
        fpu = row.get("fpu")
        if fpu is not None and not isinstance(fpu, bool):
            raise ConfigError(f"{where}: fpu: must be true or false, got {fpu!r}")
        rules.append(
            PortRule(
                port=port,
                mcpu=loader.string(row, "mcpu", where, "-") if row.get("mcpu") else "",
                march=loader.string(row, "march", where, "-") if row.get("march") else "",
                fpu=fpu,
            )
        )
    return tuple(rules)


@functools.cache
def port_rules() -> tuple[PortRule, ...]:
    path = resources.meta_dir() / "rtos" / "freertos.yaml"
    return parse_ports(loader.load_yaml(path), str(path))


def _last(flags: tuple[str, ...], name: str) -> str:
    """The value of the last ``-name=VALUE`` (GCC: the last one wins); "" when none."""
    found = ""
    for flag in flags:
        if flag.startswith(f"-{name}="):
            found = flag.split("=", 1)[1]
    return found


def core_of(profile: TargetProfile) -> tuple[str, str, bool]:
    """(-mcpu, -march, has a hardware FPU) of the profile's CPU flags."""
    flags = profile.cpu_flags
    return _last(flags, "mcpu"), _last(flags, "march"), _last(flags, "mfloat-abi") in ("hard", "softfp")


def port_for(profile: TargetProfile, rules: tuple[PortRule, ...] | None = None) -> tuple[str, ...] | None:
    """The port folders (under portable/) of the profile's core; None when the table has none."""
    mcpu, march, fpu = core_of(profile)
    for rule in port_rules() if rules is None else rules:
        if rule.matches(mcpu, march, fpu):
            return rule.port
    return None


@dataclass(frozen=True)
class RtosHeaders:
    """What micro-ROS is compiled against: folders absolute, the port as named (under portable/,
    or absolute with --rtos-port DIR)."""

    name: str
    kernel: str  # the kernel's folder (holds include/FreeRTOS.h)
    port: tuple[str, ...]  # the port folders as named (GCC/ARM_CM7/r0p1)
    config: str  # the folder holding FreeRTOSConfig.h
    include_dirs: tuple[str, ...]  # kernel/include, the port folders, the config folder
    headers_sha256: str

    @property
    def define(self) -> str:
        return DEFINE

    def portable(self) -> RtosHeaders:
        """The same with placeholder folders (the portable build key's toolchain text): the kernel
        as /rtos/kernel, the config folder as /rtos/config."""

        return RtosHeaders(
            self.name,
            "/rtos/kernel",
            self.port,
            "/rtos/config",
            placeholders(
                self.include_dirs, (self.config, "/rtos/config"), (self.kernel, "/rtos/kernel"), "/rtos/port"
            ),
            self.headers_sha256,
        )

    def record(self) -> Mapping[str, str]:
        """build-info.json's ``rtos`` (the TEAM contract): name, kernel, port, config, headers_sha256."""
        return {
            "name": self.name,
            "kernel": self.kernel,
            "port": " ".join(self.port),
            "config": self.config,
            "headers_sha256": self.headers_sha256,
        }


def placeholders(
    folders: tuple[str, ...], config: tuple[str, str], root: tuple[str, str], other: str
) -> tuple[str, ...]:
    """``folders`` with this machine's places replaced (the portable build key's toolchain text):
    the config folder (``config``: folder, placeholder), the root's folder and those below it
    (``root``), anything else ``other``."""

    def swap(folder: str) -> str:
        if folder == config[0]:
            return config[1]
        if folder == root[0] or folder.startswith(root[0] + "/"):
            return root[1] + folder[len(root[0]) :]
        return other

    return tuple(swap(f) for f in folders)


def headers_digest(folders: list[tuple[str, Path, tuple[str, ...]]]) -> str:
    """sha256 over (label, file name, content) of the headers named: each folder's ``*.h`` (or only
    the names given), in a fixed order, with no path outside the folder in it."""
    h = hashlib.sha256()
    for label, folder, names in folders:
        files = [folder / n for n in names] if names else sorted(folder.glob("*.h"))
        for path in sorted(files):
            if not path.is_file():
                continue
            h.update(f"{label}/{path.name}\0".encode())
            h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()


def freertos_digest(kernel: Path, port_dirs: list[Path], config: Path) -> str:
    """``headers_sha256`` of a FreeRTOS build: the kernel's include/*.h, each port folder's *.h and
    the config folder's FreeRTOSConfig.h (what build-info.json records, what `uros doctor` compares)."""
    return headers_digest(
        [
            ("include", kernel / "include", ()),
            *((f"port{i}", d, ()) for i, d in enumerate(port_dirs)),
            ("config", config, (CONFIG_HEADER,)),
        ]
    )


def recorded_digest(kernel: str, port: str, config: str) -> str:
    """:func:`freertos_digest` of the folders build-info.json's ``rtos`` records (its ``port``: the
    port folders as named, joined by spaces; relative ones under the kernel's portable/)."""
    base = Path(kernel)
    ports = [Path(p) if Path(p).is_absolute() else base / PORTABLE / p for p in port.split(" ") if p]
    return freertos_digest(base, ports, Path(config))


def flag_named(chosen_where: Mapping[str, str], name: str) -> str:
    """How messages name setting ``name``: where it was chosen (settings' ``Chosen.where``, e.g.
    ``uros.yaml: rtos_dir``), else its flag. The RTOS's and the IP stack's checks share it."""
    return chosen_where.get(name, f"--{name.replace('_', '-')}")


def read_freertos(
    kernel: Path | None,
    config: Path | None,
    port: str | None,
    profile: TargetProfile,
    where: Mapping[str, str] | None = None,
) -> RtosHeaders:
    """The FreeRTOS folders for ``profile``'s compile of micro-ROS, checked: ``kernel`` holds
    include/FreeRTOS.h, ``config`` FreeRTOSConfig.h, the port (``port`` as given, else the table's
    for the core) portmacro.h. ``where``: setting name -> how the user gave it (a flag, a uros.yaml
    key), for the one-line errors."""
    names = where or {}
    dir_flag, config_flag, port_flag = (
        flag_named(names, n) for n in ("rtos_dir", "rtos_config", "rtos_port")
    )
    rtos_flag = f"{flag_named(names, 'rtos')} {FREERTOS}"
    if kernel is None:
        raise ConfigError(
            f"{rtos_flag} without the kernel's folder",
            "add --rtos-dir KERNEL (a FreeRTOS-Kernel checkout: it holds include/FreeRTOS.h), "
            "or rtos_dir: in uros.yaml",
        )
    kernel = kernel.expanduser().resolve()
    if not (kernel / "include" / KERNEL_HEADER).is_file():
        hint = "pass the FreeRTOS-Kernel folder (it holds include/FreeRTOS.h and portable/)"
        if (kernel / KERNEL_HEADER).is_file():
            hint = f"pass {kernel.parent} (the folder above include/)"
        raise ConfigError(f"{dir_flag} {kernel}: no include/{KERNEL_HEADER} there", hint)
    if config is None:
        raise ConfigError(
            f"{rtos_flag} without the folder of your FreeRTOSConfig.h",
            "add --rtos-config DIR (your application's folder holding FreeRTOSConfig.h), "
            "or rtos_config: in uros.yaml",
        )
    config = config.expanduser().resolve()
    if not (config / CONFIG_HEADER).is_file():
        raise ConfigError(
            f"{config_flag} {config}: no {CONFIG_HEADER} there",
            "pass the folder holding your application's FreeRTOSConfig.h (FreeRTOS-Kernel's "
            "examples/template_configuration has a template)",
        )
    if port:
        ports: tuple[str, ...] = (port,)
    else:
        found = port_for(profile)
        if found is None:
            mcpu, march, _ = core_of(profile)
            core = f"-mcpu={mcpu}" if mcpu else (f"-march={march}" if march else "no -mcpu/-march")
            raise ConfigError(
                f"{rtos_flag}: uros knows no FreeRTOS port for {profile.name} ({core})",
                "name its folder under the kernel's portable/: --rtos-port GCC/<PORT> (or absolute)",
            )
        ports = found
    port_dirs = [Path(p) if Path(p).is_absolute() else kernel / PORTABLE / p for p in ports]
    first = port_dirs[0]
    if not (first / PORT_HEADER).is_file():
        shown = f"{port_flag} {ports[0]}" if port else f"{rtos_flag} ({profile.name}: port {ports[0]})"
        raise ConfigError(
            f"{shown}: no {PORT_HEADER} in {first}",
            "pass a FreeRTOS-Kernel with this port (V11 has GCC ports for Cortex-M0 to M85 and RISC-V), "
            "or name the port's folder with --rtos-port",
        )
    for extra in port_dirs[1:]:
        if not extra.is_dir():
            raise ConfigError(
                f"{rtos_flag} ({profile.name}): the port folder {extra} does not exist",
                "pass a complete FreeRTOS-Kernel (V11), or name the port's folder with --rtos-port",
            )
    digest = freertos_digest(kernel, port_dirs, config)
    dirs = (str(kernel / "include"), *(str(d) for d in port_dirs), str(config))
    return RtosHeaders(
        name=FREERTOS,
        kernel=str(kernel),
        port=ports,
        config=str(config),
        include_dirs=tuple(dict.fromkeys(dirs)),
        headers_sha256=digest,
    )
