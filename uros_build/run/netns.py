"""A private network namespace for a run whose agent speaks DDS: loopback only, multicast on, so a
test never sees (nor disturbs) another DDS participant on the machine, and two runs at once do not
discover each other. Pure argv builders (run/session.py runs them through the one runner), and
the processes in a namespace, read from /proc (what a run left in it, stopped at its end).

The namespace is held by one process (``unshare --net sleep``); every program that must be in it
(``ip`` to bring loopback up, the agent, a host ROS 2 peer) is started through ``nsenter`` into that
holder's namespace. QEMU needs no network (its link is a pseudo-terminal) and stays outside.
Creating a network namespace needs root (CAP_SYS_ADMIN)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from uros_build.errors import ConfigError

ROOT_HINT = (
    "run uros as root (e.g. in a container or with sudo): the DDS side of the run is kept in a "
    "network namespace of its own (unshare -n), loopback only"
)


def holder_argv() -> list[str]:
    """The process that keeps the namespace alive while the run lasts (stopped with the run)."""
    return ["unshare", "--net", "--", "sleep", "infinity"]


def namespace_of(pid: int) -> Path:
    return Path("/proc") / str(pid) / "ns" / "net"


def enter_argv(pid: int, argv: Sequence[str]) -> list[str]:
    """``argv`` run inside the network namespace of the holder ``pid`` (nsenter execs it: the
    process uros waits for and stops is the program itself)."""
    return ["nsenter", f"--net={namespace_of(pid)}", "--", *argv]


def loopback_argv() -> list[str]:
    """Loopback up with multicast on: DDS discovery (SPDP) is multicast, and a new namespace's
    loopback is down and has no MULTICAST flag."""
    return ["ip", "link", "set", "lo", "up", "multicast", "on"]


def check_root(euid: int, what: str) -> None:
    """One line when uros cannot make a namespace (not root)."""
    if euid != 0:
        raise ConfigError(f"{what}: needs root for its own network namespace (unshare -n)", ROOT_HINT)


def namespace_id(pid: int) -> str | None:
    """The network namespace process ``pid`` is in (``net:[4026532...]``), or None: it is gone."""
    try:
        return os.readlink(namespace_of(pid))
    except OSError:
        return None


def members(namespace: str, proc: Path = Path("/proc")) -> list[int]:
    """The processes in ``namespace`` (a :func:`namespace_id`), other than uros itself: once the run
    is over, what its programs left in it (a daemon a peer double-forked keeps the namespace alive,
    whatever its environment). Reads /proc only; the caller stops them (proc.stop_processes)."""
    me = os.getpid()
    found = []
    for entry in proc.iterdir() if proc.is_dir() else ():
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        try:
            if os.readlink(entry / "ns" / "net") == namespace:
                found.append(int(entry.name))
        except OSError:  # gone meanwhile
            continue
    return sorted(found)


def entered(pid: int) -> bool:
    """Whether the holder has left uros's own network namespace (unshare done): before that, a
    program nsenter'ed into it would run on the machine's network."""
    mine = namespace_id(os.getpid())
    held = namespace_id(pid)
    return held is not None and held != mine
