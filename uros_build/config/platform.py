"""What the library compiles against besides its target: an ESP-IDF project, an RTOS's headers, an
IP stack's headers, each chosen by the settings and checked against the target and the colcon.meta
before anything is built (a transport without its stack, a multithread profile without an RTOS).
Nothing here starts a process."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uros_build.config import settings as rows
from uros_build.config.colconmeta import meta_option
from uros_build.config.resolver import Chosen, Resolved
from uros_build.config.targets import ProfileTarget, Target, target_profile
from uros_build.errors import ConfigError
from uros_build.sources import meta as meta_mod
from uros_build.sources.wsfiles import CONFIG
from uros_build.target.ipstack import IpStackHeaders, read_ip_stack
from uros_build.target.rtos import RtosHeaders, read_freertos

if TYPE_CHECKING:  # at run time imported for an ESP-IDF project only (start-up cost)
    from uros_build.target.espidf import IdfProject


@dataclass(frozen=True)
class Platform:
    """What the library compiles against besides its target, as the settings chose it (each None:
    not asked for); `BuildPlan.platform`."""

    idf: IdfProject | None = None  # the ESP-IDF project micro-ROS is compiled against
    rtos: RtosHeaders | None = None  # the RTOS micro-ROS is compiled against (--rtos)
    ip_stack: IpStackHeaders | None = None  # the IP stack the udp transport is compiled against


def idf_project(chosen: Chosen[Path | None], target: Target) -> IdfProject | None:
    """The ESP-IDF build folder settings.py chose (--idf-build, else uros.yaml's idf_build, which
    applies to an ESP-IDF target only: a workspace may name several targets), read and checked
    against the target."""
    profile = target_profile(target)
    folder, flag = chosen.value, chosen.source
    if folder is None or (flag != "--idf-build" and (profile is None or not profile.idf_target)):
        return None
    if profile is None:
        raise ConfigError(
            f"--idf-build with your own toolchain file {target.key}: uros knows no ESP-IDF target for it",
            "build for a target (uros build --toolchain esp32s3 --idf-build DIR) or a profile (--profile)",
        )
    from uros_build.target import espidf  # an ESP-IDF project only (start-up cost)

    return espidf.read_idf_build(folder, profile.idf_target, profile.name, flag)


def _named(
    settings: Resolved, main: rows.Setting[Any], folders: tuple[rows.Setting[Any], ...], example: str
) -> dict[str, str]:
    """How the user gave ``main`` (--rtos, --ip-stack) and its folder settings (setting name -> a
    flag or a uros.yaml key, for the one-line errors); a folder flag without ``main`` is refused,
    and a uros.yaml folder key without ``main``'s key too: either was ignored without a word (a
    kernel's folder built bare metal)."""
    if settings[main].value is None:
        for row in folders:
            source = settings.chosen[row.name].source
            if source == row.flag:
                raise ConfigError(
                    f"{row.flag} without {main.flag}",
                    f"add {main.flag} {example} (or {main.key}: {example} in {CONFIG})",
                )
            if source != rows.DEFAULT:
                raise ConfigError(
                    f"{source} without {main.key}: (the build would ignore it)",
                    f"add `{main.key}: {example}` to {CONFIG} (or pass {main.flag} {example}), "
                    f"or remove {row.key}:",
                )
    return {row.name: settings.chosen[row.name].source for row in (main, *folders)}


def rtos_headers(settings: Resolved, target: Target, idf: IdfProject | None) -> RtosHeaders | None:
    """The RTOS settings.py chose (--rtos, --rtos-dir, --rtos-config, --rtos-port, else uros.yaml's
    rtos keys), read and checked against the target's core (target/rtos.py)."""
    rtos = settings[rows.RTOS]
    where = _named(settings, rows.RTOS, (rows.RTOS_DIR, rows.RTOS_CONFIG, rows.RTOS_PORT), "freertos")
    if rtos.value is None:
        return None
    profile = target_profile(target)
    if profile is None:
        raise ConfigError(
            f"{rtos.source} {rtos.value} with your own toolchain file {target.key}: uros adds no flags to it",
            "build for a target (uros build --toolchain cortex-m7 --rtos freertos ...) or a profile "
            "(--profile), or put the RTOS's include folders in your toolchain file",
        )
    if idf is not None:
        raise ConfigError(
            f"{rtos.source} {rtos.value} with --idf-build: an ESP-IDF project brings its own FreeRTOS",
            "leave --rtos out: --idf-build already compiles micro-ROS against ESP-IDF's FreeRTOS headers",
        )
    return read_freertos(
        settings.value(rows.RTOS_DIR),
        settings.value(rows.RTOS_CONFIG),
        settings.value(rows.RTOS_PORT),
        profile,
        where,
    )


def ip_stack_headers(
    settings: Resolved,
    target: Target,
    idf: IdfProject | None,
    rtos: RtosHeaders | None,
    transport: str | None,
) -> IpStackHeaders | None:
    """The IP stack settings.py chose (--ip-stack, --ip-stack-dir, --ip-stack-config, else uros.yaml's
    ip_stack keys), read and checked against the transport and the RTOS (target/ipstack.py)."""
    stack = settings[rows.IP_STACK]
    where = _named(settings, rows.IP_STACK, (rows.IP_STACK_DIR, rows.IP_STACK_CONFIG), "lwip")
    if stack.value is None:
        return None
    if target_profile(target) is None:
        raise ConfigError(
            f"{stack.source} {stack.value} with your own toolchain file {target.key}: "
            "uros adds no flags to it",
            "build for a target (uros build --toolchain cortex-m7 --ip-stack lwip ...) or a profile "
            "(--profile), or put the stack's include folders and PLATFORM_NAME in your toolchain file",
        )
    if idf is not None:
        raise ConfigError(
            f"{stack.source} {stack.value} with --idf-build: an ESP-IDF project brings its own lwIP",
            "leave --ip-stack out: --idf-build already compiles the udp transport against ESP-IDF's lwIP",
        )
    return read_ip_stack(
        stack.value,
        settings.value(rows.IP_STACK_DIR),
        settings.value(rows.IP_STACK_CONFIG),
        rtos,
        transport,
        target.key,
        where,
    )


def check_udp_profile(meta: meta_mod.Meta, stack: IpStackHeaders | None) -> None:
    """--ip-stack with the client's UDP profile off: the transport the stack carries would not be
    compiled (rmw_microxrcedds' udp transport then has no uxr_init_udp_transport): said before
    anything runs."""
    value = meta_option(meta, "microxrcedds_client", "UCLIENT_PROFILE_UDP")
    if stack is None or value is None or value.upper() in _CMAKE_TRUE:
        return
    raise ConfigError(
        f"microxrcedds_client.UCLIENT_PROFILE_UDP={value} with --ip-stack {stack.name}: "
        "the XRCE-DDS client would compile no UDP transport for the stack to carry",
        "leave the option out (transport udp turns it on), or build without --ip-stack",
    )


def udp_without_stack(
    target: Target, idf: IdfProject | None, stack: IpStackHeaders | None, transport: str | None
) -> list[str]:
    """A warning for the udp transport on a profile's target that has no socket platform (no
    --ip-stack, no ESP-IDF, no xrce_platform in the profile): the client's udp_transport.h then
    has no platform ("field 'platform' has incomplete type")."""
    profile = target_profile(target)
    if transport != "udp" or stack is not None or idf is not None or profile is None:
        return []
    if profile.micro_ros.xrce_platform:
        return []
    return [
        f"transport udp on {target.key} without an IP stack: the XRCE-DDS client has no socket code "
        "for it; add --rtos freertos ... --ip-stack lwip --ip-stack-dir DIR --ip-stack-config DIR "
        "(docs/network.md)"
    ]


_CMAKE_TRUE = ("ON", "TRUE", "1", "YES", "Y")


def check_multithread(
    meta: meta_mod.Meta, target: Target, idf: IdfProject | None, rtos: RtosHeaders | None
) -> None:
    """UCLIENT_PROFILE_MULTITHREAD on a profile's bare-metal target: the XRCE-DDS client's
    multithread.c stops with `#error XRCE multithreading not supported for this platform` deep in
    the build (it knows FreeRTOS, Zephyr and POSIX mutexes only): said before anything runs."""
    value = meta_option(meta, "microxrcedds_client", "UCLIENT_PROFILE_MULTITHREAD")
    if value is None or value.upper() not in _CMAKE_TRUE:
        return
    if rtos is None and idf is None and isinstance(target, ProfileTarget):
        raise ConfigError(
            f"microxrcedds_client.UCLIENT_PROFILE_MULTITHREAD={value} on {target.key} without an RTOS: "
            "the client's mutexes are an RTOS's",
            "add --rtos freertos --rtos-dir KERNEL --rtos-config DIR (docs/rtos.md), or leave the option out",
        )


# ESP-IDF's newlib defines the 64-bit __atomic_*_8 routines from 5.3 on (components/newlib/stdatomic.c:
# ATOMIC_FUNCTIONS(8, ...)); 5.2 and earlier define none, so rcutils must bring its own there.
IDF_DEFINES_ATOMICS_8 = (5, 3)


def idf_platform(target: Target, idf: IdfProject | None) -> Target:
    """The target as the IDF project's version makes it: C17 from ESP-IDF 5 on, C11 before; and
    before 5.3 the platform does not define __atomic_*_8, so rcutils' own are built (and allowed by
    the ABI check)."""
    if idf is None or not isinstance(target, ProfileTarget):
        return target
    profile = replace(target.profile, c_standard=idf.c_standard)
    if idf.version < IDF_DEFINES_ATOMICS_8:
        profile = replace(profile, native_64bit_atomics=False)
    return ProfileTarget(target.key, profile)
