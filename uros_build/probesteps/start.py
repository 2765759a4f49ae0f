"""Open the run: the probe's lock of the target (one probe of a target at a time), what a killed
probe left running stopped, the work folder, the IP stack chosen, the run's log and its first lines.
Its result is the context every later step is handed."""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator
from pathlib import Path

from uros_build import console
from uros_build.config.resolver import resolve_outside
from uros_build.config.settings import FREERTOS_TCP, LWIP
from uros_build.errors import ConfigError
from uros_build.files import locked
from uros_build.probesteps.context import ProbeContext, ProbePlan, ProbeRequest
from uros_build.proc import Runner, new_run_log
from uros_build.run import app as app_mod
from uros_build.run import freertos as freertos_mod
from uros_build.run import network as network_mod
from uros_build.run.report import probe_work
from uros_build.run.session import run_owner, stop_left_running


@contextlib.contextmanager
def probe_lock(plan: ProbePlan) -> Iterator[None]:
    """The probe's lock of the target (in the workspace's .uros/), what a killed probe of it left
    running stopped. One probe of a target at a time: two at once shared the work folder (one deleted
    the other's firmware and console log) and blamed a good library ("no agent answered", "an entity
    could not be created"); the second waits, and says for whom. A folder this user cannot write (a
    root-owned workspace) is one line naming the fix, not a PermissionError."""
    base, target = plan.base, plan.info.target
    held = contextlib.ExitStack()
    try:
        held.enter_context(locked(base / "probe" / "locks" / target, target, command="uros probe"))
    except OSError as exc:
        if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS):
            raise
        raise _not_writable(exc, base) from None
    with held:
        stop_left_running(_owner(plan))
        yield


def open_run(request: ProbeRequest, plan: ProbePlan) -> ProbeContext:
    """The work folder, the run's log and its first lines; every process the run starts is marked
    as the probe's of the target (stopped with the run, or by the next run if this one is killed)."""
    out, info, machine, rtos = plan.out, plan.info, plan.machine, plan.rtos
    if plan.app is None:
        work = probe_work(plan.base, info.target, out)
    else:
        work = app_mod.app_work(plan.base, info.target, out, plan.app.app.folder)
    if machine.chosen:  # another board of the target keeps its own work folder (firmware, console, logs)
        work = work.with_name(f"{work.name}-{machine.board.name}")
    if plan.app is not None and rtos is not None:  # the FreeRTOS firmware keeps its own work folder
        work = work.with_name(f"{work.name}-freertos")
    env, env_tcp = resolve_outside(LWIP, None).value, resolve_outside(FREERTOS_TCP, None).value
    network = network_mod.choose(info.ip_stack, machine, rtos is not None, env, env_tcp)
    work.mkdir(parents=True, exist_ok=True)
    log = new_run_log(work / "log", "probe", info.target)
    runner = Runner(log, verbose=request.verbose, owner=_owner(plan))
    ctx = ProbeContext(request, plan, work, network, runner)
    app = f" --app {app_mod.shown(plan.app.app.folder)}" if plan.app is not None else ""
    console.step(f"uros probe{app}: {out} ({info.target}) in QEMU {machine.machine}{ctx.on}")
    if machine.note:
        console.info(f"{machine.machine}: {machine.note}")
    console.info(f"log: {runner.log_path}")
    if plan.app is None:
        _say_platform(ctx)
    return ctx


def _say_platform(ctx: ProbeContext) -> None:
    """The kernel and the IP stack the probe firmware compiles, and where their config differs."""
    rtos, network = ctx.plan.rtos, ctx.network
    if rtos is not None:
        console.info(f"FreeRTOS kernel {rtos.kernel}, port {rtos.port.relative_to(rtos.kernel)}, heap_4")
        mismatch = freertos_mod.config_differs(rtos)
        if mismatch:
            console.warn(mismatch)
    if network is not None:
        ours = network_mod.probe_config(network.stack)
        console.info(f"{network.label} {network.tree}, the probe's config ({ours})")
        mismatch = network_mod.config_differs(network)
        if mismatch:
            console.warn(mismatch)


def _owner(plan: ProbePlan) -> str:
    """What marks every process of a probe of the target (run/session.run_owner)."""
    return run_owner(plan.base / "probe" / "locks" / plan.info.target)


def _not_writable(exc: OSError, base: Path) -> ConfigError:
    where = Path(exc.filename) if exc.filename else base
    found = next((p for p in (where, *where.parents) if p.exists()), base)
    owner, me = found.stat().st_uid, os.geteuid()
    if owner == me:  # a read-only mount, or the folder's own mode
        return ConfigError(
            f"uros probe: cannot write {where} ({exc.strerror})",
            f"make {base} writable (chmod -R u+w {base}), or probe a copy of the workspace",
        )
    whose = "it belongs" if found == where else f"{found} belongs"
    return ConfigError(
        f"uros probe: cannot write {where} ({exc.strerror}): {whose} to {_user(owner)}, not {_user(me)}",
        f"run uros probe as {_user(owner)} (e.g. with sudo), or make the folder yours: "
        f"sudo chown -R $(id -un) {base}",
    )


def _user(uid: int) -> str:
    """root, or the uid (pwd, which names the others, is POSIX only: uros imports on Windows)."""
    return "root" if uid == 0 else f"uid {uid}"
