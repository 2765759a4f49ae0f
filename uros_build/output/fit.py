"""Does the firmware's code fit the library? The entities its rclc calls create, against the
library's ``RMW_UXRCE_MAX_*`` pools, and the handles its executors are given, against the number
they were initialised for (pure: the firmware's calls in, the output's include tree and
build-info.json read, lines out).

rmw_microxrcedds takes every node, publisher, subscription, service, client, guard condition and
wait set from a static pool of ``RMW_UXRCE_MAX_*`` slots (rmw_microxrcedds_c/src/types.c, humble);
the call that finds its pool empty returns an error at run time. What each rclc call takes, read
from the sources of humble (cited where each count is):

- a parameter server: a service for each of its ``RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES`` executor
  handles (rclc_parameter.h: 5 in humble, 6 from iron on; read from the library's own header) and 1
  publisher (``/parameter_events``, when ``notify_changed_over_dds``: true in the default options):
  rclc_parameter/src/rclc_parameter/parameter_server.c, ``rclc_parameter_server_init_with_option``
  creates the services (humble: get, get_types, set, list, describe) and
  ``rclc_executor_add_parameter_server_with_context`` adds each to the executor;
- an action server: 3 services and 2 publishers (micro-ROS/rcl, rcl_action/src/rcl_action/
  action_server.c: ``SERVICE_INIT(goal|cancel|result)``, ``PUBLISHER_INIT(feedback|status)``) and
  the goal-expiry timer's guard condition (its ``rcl_timer_init``);
- an action client: 3 clients and 2 subscriptions (rcl_action/src/rcl_action/action_client.c:
  ``CLIENT_INIT(goal|cancel|result)``, ``SUBSCRIPTION_INIT(feedback|status)``);
- a timer: 1 guard condition (micro-ROS/rcl, rcl/src/rcl/timer.c: ``rcl_timer_init`` calls
  ``rcl_guard_condition_init``, which takes one from rmw's pool);
- an executor: 1 wait set (rclc/src/rclc/executor.c: ``rcl_wait_set_init`` on its first spin);
  every ``rclc_executor_add_*`` takes 1 handle, and the one past ``number_of_handles`` returns
  RCL_RET_ERROR ("Buffer overflow of 'executor->handles'"): output/executors.py counts those.

A static count is approximate: a call in a loop, or in a helper called twice, counts once; a call
an ``#if`` leaves out counts. ``uros probe --app DIR`` runs the firmware and proves it.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.output import budget
from uros_build.output.buildinfo import BuildInfo
from uros_build.output.executors import (
    PARAMETER_HANDLES_DEFAULT,
    PARAMETER_HEADERS,
    Executor,
    executor_line,
    executors,
    parameter_handles,
)
from uros_build.sources.firmware_scan import Call, FirmwareUse
from uros_build.sources.options import KnownOption

APPROXIMATE = (
    "a static count of the rclc calls in its sources: a call in a loop or in a helper called twice "
    "counts once; `uros probe --app DIR` runs the firmware and proves it"
)
RMW = "rmw_microxrcedds"
RMW_HEADER = "rmw_microxrcedds_c/config.h"

# kind -> the option that sizes its pool
LIMITS = (
    ("nodes", "RMW_UXRCE_MAX_NODES"),
    ("publishers", "RMW_UXRCE_MAX_PUBLISHERS"),
    ("subscriptions", "RMW_UXRCE_MAX_SUBSCRIPTIONS"),
    ("services", "RMW_UXRCE_MAX_SERVICES"),
    ("clients", "RMW_UXRCE_MAX_CLIENTS"),
    ("guard conditions", "RMW_UXRCE_MAX_GUARD_CONDITION"),
    ("wait sets", "RMW_UXRCE_MAX_WAIT_SETS"),
)
# (the call's name prefix, what it is called in a line, kind -> how many it takes); first match wins
_TAKES: tuple[tuple[str, str, Mapping[str, int]], ...] = (
    ("rclc_node_init", "node", {"nodes": 1}),
    ("rclc_publisher_init", "publisher", {"publishers": 1}),
    ("rclc_subscription_init", "subscription", {"subscriptions": 1}),
    ("rclc_service_init", "service", {"services": 1}),
    ("rclc_client_init", "client", {"clients": 1}),
    ("rclc_timer_init", "timer", {"guard conditions": 1}),
    ("rclc_parameter_server_init", "parameter server", {"services": 5, "publishers": 1}),
    ("rclc_action_server_init", "action server", {"services": 3, "publishers": 2, "guard conditions": 1}),
    ("rclc_action_client_init", "action client", {"clients": 3, "subscriptions": 2}),
    ("rclc_executor_init", "executor", {"wait sets": 1}),
)


def takes(
    function: str, parameter_services: int = PARAMETER_HANDLES_DEFAULT
) -> tuple[str, Mapping[str, int]] | None:
    """(what the call creates, kind -> slots it takes), or None for a call that creates nothing
    (``parameter_services``: a parameter server's, the library's handles number)."""
    if function.startswith("rclc_executor_add_"):
        return None
    for prefix, what, kinds in _TAKES:
        if function.startswith(prefix):
            return what, {**kinds, "services": parameter_services} if what == "parameter server" else kinds
    return None


@dataclass(frozen=True)
class Limit:
    """One pool: what the firmware's calls take of it against the library's slots."""

    kind: str
    option: str
    needed: int
    uses: tuple[tuple[str, int, tuple[str, ...]], ...]  # (what, slots, where) per kind of call
    value: int | None  # the library's slots (None: not a whole number, or not known)
    value_from: str = "default"  # "header", "meta" or "default"
    each: int | None = None  # RAM bytes one slot takes in this library (None: its pool not found)

    @property
    def fits(self) -> bool:
        return self.value is None or self.needed <= self.value

    @property
    def extra_bytes(self) -> int | None:
        if self.fits or self.each is None or self.value is None:
            return None
        return (self.needed - self.value) * self.each

    def used_by(self) -> str:
        """``5 for a parameter server at main.c:40, 2 for 2 services at main.c:30, main.c:31``."""
        return ", ".join(f"{slots} for {_calls(what, where)}" for what, slots, where in self.uses)


def _calls(what: str, where: Sequence[str]) -> str:
    shown = ", ".join(where[:3]) + (", ..." if len(where) > 3 else "")
    one = "an" if what[0] in "aeiou" else "a"
    return f"{one if len(where) == 1 else len(where)} {what}{'s' if len(where) != 1 else ''} at {shown}"


def count(
    calls: Iterable[Call], parameter_services: int = PARAMETER_HANDLES_DEFAULT
) -> dict[str, list[tuple[str, int, tuple[str, ...]]]]:
    """kind -> [(what, slots, where)] for the firmware's calls, in the order of ``LIMITS``' kinds
    and of the calls."""
    found: dict[str, dict[str, tuple[int, list[str]]]] = {}
    for call in calls:
        taken = takes(call.function, parameter_services)
        if taken is None:
            continue
        what, kinds = taken
        for kind, slots in kinds.items():
            total, where = found.setdefault(kind, {}).get(what, (0, []))
            found[kind][what] = (total + slots, [*where, call.where])
    return {
        kind: [(what, total, tuple(where)) for what, (total, where) in found[kind].items()]
        for kind, _ in LIMITS
        if kind in found
    }


def limits(
    use: FirmwareUse,
    known: Mapping[str, KnownOption],
    headers: Mapping[str, Mapping[str, str]],
    meta: Mapping[str, str],
    each: Mapping[str, int | None],
    parameter_services: int = PARAMETER_HANDLES_DEFAULT,
) -> list[Limit]:
    """Each pool the firmware's calls take from, with the library's value (``known``: the rmw's
    options by name; ``headers``: header -> defines of the library's include tree; ``meta``: the
    rmw's options in build-info.json; ``each``: option -> RAM bytes of one slot)."""
    out = []
    for kind, uses in count(use.calls, parameter_services).items():
        name = dict(LIMITS)[kind]
        option = known.get(name)
        value, value_from = (
            budget.value_in_force(option, {RMW: meta}, headers) if option is not None else (None, "default")
        )
        number = int(value) if value is not None and re.fullmatch(r"[0-9]+", value) else None
        out.append(
            Limit(kind, name, sum(s for _, s, _ in uses), tuple(uses), number, value_from, each.get(name))
        )
    return out


@dataclass(frozen=True)
class Fit:
    """The firmware's calls against one library."""

    limits: tuple[Limit, ...]
    executors: tuple[Executor, ...]
    has_rmw: bool
    missing_packages: tuple[tuple[str, str], ...] = ()  # (package, what needs it)
    hazards: tuple[str, ...] = ()  # calls known to fail on a microcontroller, a line each

    @property
    def fits(self) -> bool:
        return all(limit.fits for limit in self.limits)


def library_fit(
    output: Path,
    info: BuildInfo,
    use: FirmwareUse,
    known: Iterable[KnownOption],
    nm_sizes: Mapping[str, int],
) -> Fit:
    """The firmware's calls against the output's library: its options read from its own include
    tree and build-info.json, a slot's RAM from the pools' symbol sizes (``nm_sizes``; empty: not
    priced)."""
    rmw_options = {o.name: o for o in known if o.package == RMW}
    names = {RMW_HEADER, *PARAMETER_HEADERS, *(o.header for o in rmw_options.values() if o.header)}
    headers = budget.configured_headers(output / info.include.dir, names)
    meta = dict(info.cmake_options.get(RMW, {}))
    costs = budget.option_costs(rmw_options.values(), {RMW: meta}, None, nm_sizes, headers)
    each = {c.option: c.each for c in costs}
    topic = _topic_slot(rmw_options, headers, meta, nm_sizes)
    for name in ("RMW_UXRCE_MAX_PUBLISHERS", "RMW_UXRCE_MAX_SUBSCRIPTIONS"):
        slot = each.get(name)
        if slot is not None and topic is not None:
            each[name] = slot + topic
    handles = parameter_handles(headers)
    found = limits(use, rmw_options, headers, meta, each, handles)
    packages = set(info.packages)
    functions = {call.function for call in use.calls}
    missing = []
    if any(f.startswith("rclc_parameter_server_init") for f in functions):
        missing += [
            (p, "the parameter server") for p in ("rclc_parameter", "rcl_interfaces") if p not in packages
        ]
    if any(f.startswith("rclc_action_") for f in functions):
        missing += [(p, "actions") for p in ("rcl_action", "action_msgs") if p not in packages]
    return Fit(
        tuple(found),
        tuple(e for e in executors(use, handles) if e.adds or e.init),
        RMW in packages,
        tuple(missing),
        hazards(use.calls),
    )


def missing_line(package: str, why: str) -> str:
    return f"{why} needs {package}, which the library does not hold: build it with --packages {package}"


def _topic_slot(
    options: Mapping[str, KnownOption],
    headers: Mapping[str, Mapping[str, str]],
    meta: Mapping[str, str],
    nm_sizes: Mapping[str, int],
) -> int | None:
    """The bytes of one topic slot when ``RMW_UXRCE_MAX_TOPICS`` is -1 (the pool is then publishers +
    subscriptions long: config.h.in, humble), so that a publisher or a subscription more costs its
    slot and a topic's; None when the topics pool is sized otherwise or not found."""
    names = ("RMW_UXRCE_MAX_TOPICS", "RMW_UXRCE_MAX_PUBLISHERS", "RMW_UXRCE_MAX_SUBSCRIPTIONS")
    if any(n not in options for n in names) or not nm_sizes.get("custom_topics"):
        return None
    topics, publishers, subscriptions = (
        budget.value_in_force(options[n], {RMW: meta}, headers)[0] for n in names
    )
    # meta/options.yaml names no header for the topics option: its config.h define first all the same
    topics = headers.get(RMW_HEADER, {}).get(names[0], topics)
    if topics != "-1" or not (publishers.isdigit() and subscriptions.isdigit()):
        return None
    slots = int(publishers) + int(subscriptions)
    size = nm_sizes["custom_topics"]
    return size // slots if slots and size % slots == 0 else None


# rclc's action client (humble; iron and rolling the same) writes each goal id with two uint64_t stores
# into the byte array at offset 9 of its goal handle (rclc/src/rclc/action_client.c, set_uuid: next and
# the union take 8 bytes on a 32-bit target, status 1): an unaligned 64-bit store, STRD on Cortex-M,
# which faults; measured by uros probe's action stage (docs/probe.md).
ACTION_CLIENT_HAZARD = (
    "{where}: rclc's action client writes each goal id with two 64-bit stores at offset 9 of its goal "
    "handle (rclc action_client.c, set_uuid), unaligned on a 32-bit MCU: on cortex-m7 (-Os) "
    "rclc_action_send_goal_request hard-faulted (UsageFault UNALIGNED, measured in QEMU); rcl_action's "
    "client (rcl_action_send_goal_request) is not affected"
)


def hazards(calls: Iterable[Call]) -> tuple[str, ...]:
    """The lines for calls known to fail on a microcontroller (the first call of each kind)."""
    client = next((c for c in calls if c.function.startswith("rclc_action_client_init")), None)
    return (ACTION_CLIENT_HAZARD.format(where=client.where),) if client is not None else ()


def limit_line(limit: Limit, priced: bool = True) -> str:
    """One pool's line: the count, what takes it, the library's value; when it does not fit, the
    ``--set`` that fits and what it costs in RAM (``priced``: the pools' sizes were read; else
    the line says where to see them)."""
    have = (
        f"{limit.option}={limit.value}"
        if limit.value is not None
        else f"{limit.option} not a number uros can read"
    )
    line = f"{limit.kind}: {limit.needed} ({limit.used_by()}); the library has {have}"
    if limit.value_from != "header" and limit.value is not None:
        line += f" ({'its build-info' if limit.value_from == 'meta' else 'upstream default'})"
    if limit.fits:
        return line
    more = limit.needed - (limit.value or 0)
    cost = (
        f"+{limit.extra_bytes:,} B of RAM: {limit.each:,} B a slot, measured in this library"
        if limit.extra_bytes is not None
        else "its RAM: uros check LIBRARY --for-firmware DIR"
        if not priced
        else "RAM per slot not measured: its pool is not among the library's symbols"
    )
    return f"{line}: {more} too few; --set {RMW}.{limit.option}={limit.needed} fits ({cost})"


def report(fit: Fit) -> dict[str, object]:
    """The fit as JSON (sorted keys by the caller)."""
    return {
        "approximate": APPROXIMATE,
        "fits": fit.fits,
        "limits": {
            limit.kind: {
                "needed": limit.needed,
                "option": limit.option,
                "value": limit.value,
                "value_from": limit.value_from,
                "fits": limit.fits,
                "set": None if limit.fits else f"{RMW}.{limit.option}={limit.needed}",
                "extra_ram": limit.extra_bytes,
                "slot_ram": limit.each,
                "uses": [{"what": w, "slots": s, "where": list(where)} for w, s, where in limit.uses],
            }
            for limit in fit.limits
        },
        "executors": [
            {
                "name": e.name,
                "init": e.init.where if e.init else None,
                "handles": e.handles,
                "given": e.given,
                "short": e.short,
                "adds": [{"call": c.function, "where": c.where, "handles": n} for c, n in e.adds],
            }
            for e in fit.executors
        ],
        "missing_packages": {p: why for p, why in fit.missing_packages},
        "hazards": list(fit.hazards),
    }


def say(fitted: Fit, firmware: Path, priced: bool) -> None:
    """The entities the firmware's calls create against the library's pools, each executor's
    handles: a warning a line for what does not fit, the rest as information."""
    if not fitted.limits and not fitted.executors:
        console.info(f"{firmware}: no rclc call that creates an entity ({APPROXIMATE})")
        return
    console.step(f"the entities {firmware} creates, against the library's pools ({APPROXIMATE}):")
    if not fitted.has_rmw:
        console.info(f"the library holds no {RMW}: its upstream defaults are shown")
    for limit in fitted.limits:
        (console.info if limit.fits else console.warn)(limit_line(limit, priced))
    for executor in fitted.executors:
        warn, line = executor_line(executor)
        (console.warn if warn else console.info)(line)
    for package, why in fitted.missing_packages:
        console.warn(missing_line(package, why))
    for line in fitted.hazards:
        console.warn(line)


def summary(fitted: Fit, firmware: str = "DIR") -> list[tuple[bool, str]]:
    """`uros build --for-firmware`'s few lines: (is it a warning, the line); what does not fit
    a warning each, else one line that it fits."""
    lines = [(True, limit_line(limit, priced=False)) for limit in fitted.limits if not limit.fits]
    lines += [line for line in map(executor_line, fitted.executors) if line[0]]
    lines += [(True, missing_line(package, why)) for package, why in fitted.missing_packages]
    lines += [(True, line) for line in fitted.hazards]
    if not lines and fitted.limits:
        counted = ", ".join(f"{limit.kind} {limit.needed} of {limit.value}" for limit in fitted.limits)
        lines.append((False, f"the firmware's entities fit the library: {counted} ({APPROXIMATE})"))
    elif lines:
        lines.append((False, f"{APPROXIMATE}; `uros check LIBRARY --for-firmware {firmware}` says more"))
    return lines
