"""The IP stack micro-ROS's UDP transport is compiled against (`uros build --transport udp
--ip-stack lwip --ip-stack-dir LWIP --ip-stack-config DIR`): the stack's include folders, its
port for the RTOS and the application's config folder (lwipopts.h, arch/cc.h), checked and hashed.

Why micro-ROS needs them: on a Generic system the XRCE-DDS client picks its UDP transport's
socket code by its CMake ``PLATFORM_NAME`` (branch ros2, CMakeLists.txt): ``LwIP`` compiles the
POSIX_NOPOLL sources, which include <sys/socket.h>, <netdb.h> and <arpa/inet.h>; lwIP provides
them in ``src/include/compat/posix`` over its own headers, which include the application's
lwipopts.h and arch/cc.h and, with threads (NO_SYS 0), the RTOS port's arch/sys_arch.h and the
RTOS's headers. ESP-IDF hands the same folders to micro_ros_espidf_component's build.

The facts of each stack (folders, headers, platform) are data: ``meta/ipstack/<name>.yaml``. The
headers are hashed (``headers_sha256``) by their names relative to their folder, so that the build
key is the same wherever the stack lives and a changed lwipopts.h is a changed input.

Pure: reads files, starts no process.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import loader, resources
from uros_build.errors import ConfigError
from uros_build.target.rtos import RtosHeaders, flag_named, headers_digest, placeholders

NAMES = ("lwip", "freertos-tcp")  # the IP stacks uros knows (--ip-stack): meta/ipstack/<name>.yaml
# The XRCE-DDS transports that run over an IP stack.
IP_TRANSPORTS = ("udp",)


@dataclass(frozen=True)
class StackFacts:
    """meta/ipstack/<name>.yaml: where a stack's headers are and what the client calls it."""

    name: str
    platform: str  # the client's CMake PLATFORM_NAME
    marker: str  # a file under the stack's folder that says it is one
    include: tuple[str, ...]  # include folders under the stack's folder
    config: tuple[str, ...]  # headers the config folder must hold
    rtos: Mapping[str, str]  # RTOS name -> the stack's port folder for it ("": it needs none)
    hashed: tuple[str, ...]  # folders under the stack's folder whose *.h are hashed


def parse_facts(name: str, data: Any, source: str) -> StackFacts:
    keys = ("platform", "marker", "include", "config", "rtos", "hashed")
    top = loader.mapping(data, source, set(keys), keys)
    platform = loader.string(top, "platform", source)
    if not platform.replace("_", "").isalnum():
        raise ConfigError(f"{source}: platform: {platform!r} is not a word like 'LwIP'")
    return StackFacts(
        name=name,
        platform=platform,
        marker=loader.string(top, "marker", source),
        include=loader.string_list(top, "include", source),
        config=loader.string_list(top, "config", source),
        rtos=loader.string_map(top, "rtos", source),
        hashed=loader.string_list(top, "hashed", source),
    )


@functools.cache
def stack_facts(name: str) -> StackFacts:
    path = resources.meta_dir() / "ipstack" / f"{name}.yaml"
    return parse_facts(name, loader.load_yaml(path), str(path))


@dataclass(frozen=True)
class IpStackHeaders:
    """What micro-ROS's UDP transport is compiled against: folders absolute."""

    name: str
    dir: str  # the stack's folder (lwIP's root: src/, contrib/)
    config: str  # the folder holding lwipopts.h and arch/cc.h
    platform: str  # the XRCE-DDS client's PLATFORM_NAME (LwIP)
    include_dirs: tuple[str, ...]
    headers_sha256: str

    def portable(self) -> IpStackHeaders:
        """The same with placeholder folders (the portable build key's toolchain text): the stack
        as /ipstack/dir, the config folder as /ipstack/config."""

        folders = placeholders(
            self.include_dirs, (self.config, "/ipstack/config"), (self.dir, "/ipstack/dir"), "/ipstack/other"
        )
        return IpStackHeaders(
            self.name, "/ipstack/dir", "/ipstack/config", self.platform, folders, self.headers_sha256
        )

    def record(self) -> Mapping[str, str]:
        """build-info.json's ``ip_stack``: name, dir, config, platform, headers_sha256."""
        return {
            "name": self.name,
            "dir": self.dir,
            "config": self.config,
            "platform": self.platform,
            "headers_sha256": self.headers_sha256,
        }


def read_ip_stack(
    name: str,
    folder: Path | None,
    config: Path | None,
    rtos: RtosHeaders | None,
    transport: str | None,
    target: str,
    where: Mapping[str, str] | None = None,
    facts: StackFacts | None = None,
) -> IpStackHeaders:
    """The stack ``name``'s folders for micro-ROS's compile on ``target``, checked: ``folder``
    holds the stack (its marker file), ``config`` its config headers; the transport runs over IP;
    an RTOS is there (the stack's sockets block in threads) and the stack has a port for it.
    ``where``: setting name -> how the user gave it (a flag, a uros.yaml key), for the one-line
    errors."""
    names = where or {}
    facts = facts or stack_facts(name)
    stack_flag = f"{flag_named(names, 'ip_stack')} {name}"
    if transport not in IP_TRANSPORTS:
        raise ConfigError(
            f"{stack_flag} with transport {transport or 'custom'}: an IP stack carries only "
            f"{', '.join(IP_TRANSPORTS)}",
            "add --transport udp (or transport: udp in uros.yaml), or leave --ip-stack out",
        )
    if rtos is None:
        raise ConfigError(
            f"{stack_flag} on {target} without an RTOS: UDP through {name} needs one "
            "(its sockets block in threads)",
            "add --rtos freertos --rtos-dir KERNEL --rtos-config DIR (docs/rtos.md)",
        )
    port = facts.rtos.get(rtos.name)
    if port is None:
        raise ConfigError(f"{stack_flag}: uros knows no {name} port for {rtos.name}")
    dir_flag, config_flag = flag_named(names, "ip_stack_dir"), flag_named(names, "ip_stack_config")
    if folder is None:
        raise ConfigError(
            f"{stack_flag} without the stack's folder",
            f"add --ip-stack-dir DIR (a {name} checkout: it holds {facts.marker}), "
            "or ip_stack_dir: in uros.yaml",
        )
    folder = folder.expanduser().resolve()
    if not (folder / facts.marker).is_file():
        hint = f"pass the {name} folder (it holds {facts.marker})"
        for parent in folder.parents:
            if (parent / facts.marker).is_file():
                hint = f"pass {parent} (the stack's root)"
                break
        raise ConfigError(f"{dir_flag} {folder}: no {facts.marker} there", hint)
    if config is None:
        raise ConfigError(
            f"{stack_flag} without the folder of your {facts.config[0]}",
            f"add --ip-stack-config DIR (your application's folder holding {', '.join(facts.config)}), "
            "or ip_stack_config: in uros.yaml",
        )
    config = config.expanduser().resolve()
    for header in facts.config:
        if not (config / header).is_file():
            raise ConfigError(
                f"{config_flag} {config}: no {header} there",
                f"pass the folder holding your application's {', '.join(facts.config)}",
            )
    port_dirs = [folder / port] if port else []
    for port_dir in port_dirs:
        if not port_dir.is_dir():
            raise ConfigError(
                f"{dir_flag} {folder}: no {port} (the stack's {rtos.name} port)",
                f"pass a complete {name} tree (its contrib/ holds the ports)",
            )
    config_parts = {str(Path(h).parent) for h in facts.config}
    digest = headers_digest(
        [
            *((f"stack/{sub}", folder / sub, ()) for sub in facts.hashed),
            *((f"port/{port}", port_dir / "arch", ()) for port_dir in port_dirs),
            *((f"config/{part}", config / part, ()) for part in sorted(config_parts)),
        ]
    )
    dirs = (*(str(folder / sub) for sub in facts.include), *(str(d) for d in port_dirs), str(config))
    return IpStackHeaders(
        name=name,
        dir=str(folder),
        config=str(config),
        platform=facts.platform,
        include_dirs=tuple(dict.fromkeys(dirs)),
        headers_sha256=digest,
    )
