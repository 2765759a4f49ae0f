"""`uros doctor`: is this host ready to build, and what state is the workspace in?

One line per check, each with the fix. The checks are pure functions of what the probes found
(unit-tested); the probes run tools through the runner. A FAIL line is something that would make a
build fail; the command then exits 5 (a verification failed), like `uros check`, so scripts and CI
can gate on it. WARN lines (a sourced ROS 2, stale outputs, clones off their locked commit) do not
change the exit code.
"""

from __future__ import annotations

import importlib.metadata
import os
import shutil
import sys
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from uros_build import console
from uros_build.colcon import command as colcon
from uros_build.colcon import hosttools
from uros_build.config.buildargs import BuildArgs, expand_targets
from uros_build.config.resolver import resolve_outside, resolve_workspace
from uros_build.config.settings import AGENT, ROS2_VENV
from uros_build.config.targets import resolve_target
from uros_build.defaults import BUILD_INFO
from uros_build.errors import ConfigError, MissingToolError, StepFailed, UrosError, VerifyError
from uros_build.output import folders as outputs
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.run import builtagent, machines
from uros_build.sources.workspace import Workspace
from uros_build.sources.wsfiles import CONFIG, Lock, load_config, read_lock
from uros_build.steps import inputs as inputs_step
from uros_build.target import abi, compilers
from uros_build.target.profiles import TargetProfile

OK, WARN, FAIL, SKIP = "ok", "warn", "FAIL", "skip"

GIT_CONFIG_ENV = (2, 31)  # GIT_CONFIG_COUNT: how mirror rules reach the clones CMake makes
EMPY_BELOW = 4  # empy 4 breaks the rosidl generators (see pyproject.toml)
CMAKE_POLICY_MAJOR = 4  # from CMake 4 on, uros passes CMAKE_POLICY_VERSION_MINIMUM=3.5
DISK_FAIL = 1 << 30  # 1 GiB: colcon's build trees of one real target do not fit
DISK_WARN = 4 << 30


@dataclass(frozen=True)
class Check:
    name: str
    status: str  # OK, WARN, FAIL or SKIP
    detail: str
    fix: str = ""


def version_tuple(version: str) -> tuple[int, ...]:
    """'2.39.5' -> (2, 39, 5); stops at the first part that is not a number ('3.3.4rc1' -> (3, 3))."""
    out = []
    for part in version.split("."):
        if not part.isdigit():
            break
        out.append(int(part))
    return tuple(out)


# -- the checks (pure) -------------------------------------------------------------------------


def eval_cmake(version: str | None) -> Check:
    if version is None:
        return Check("cmake", FAIL, "not found", "apt-get install cmake (or pip install cmake)")
    if version_tuple(version)[:1] >= (CMAKE_POLICY_MAJOR,):
        note = "; CMake 4: uros passes CMAKE_POLICY_VERSION_MINIMUM=3.5 (vendored libyaml/uncrustify need it)"
        return Check("cmake", OK, f"{version}{note}")
    return Check("cmake", OK, version)


def eval_ninja(path: str | None) -> Check:
    if path is None:
        return Check("ninja", WARN, "not found: builds use Makefiles (slower)", "pip install ninja")
    return Check("ninja", OK, path)


def eval_ccache(path: str | None, version: str | None, trouble: str | None = None) -> Check:
    """ccache is optional: without it every compile that misses uros's caches runs; one that cannot
    be used (``trouble``) is left out by the build, with a warning."""
    if path is None:
        why = "not found: compiles are not cached across builds and checkouts"
        return Check("ccache", SKIP, why, "apt-get install ccache")
    if trouble:
        why = f"{path} cannot be used ({trouble}): uros build compiles without it"
        return Check("ccache", WARN, why, "point CCACHE_DIR at a folder you can write in")
    return Check("ccache", OK, f"{path} {version or ''}".rstrip() + " (uros build compiles through it)")


def eval_probe_tools(
    qemus: Mapping[str, str | None],
    agent: str | None,
    agent_given: bool,
    machine_table: Mapping[str, machines.Machine],
    board_qemus: Sequence[tuple[machines.Machine, BoardQemu]] = (),
) -> list[Check]:
    """What `uros probe` needs: each QEMU program (path or None) with the targets it lets the probe
    boot (meta/probe/machines.yaml), the QEMU builds boards name through their qemu_env, and the
    agent; none is needed to build, so a missing one is a note, not a failure."""
    checks = []
    for program, path in qemus.items():
        targets = ", ".join(
            sorted(t for t, m in machine_table.items() if m.board.qemu == program and not m.board.qemu_env)
        )
        if not targets:  # rv32imc, esp8266: no library here to probe (docs/probe.md, Cores)
            what = "no target's probe runs on it yet (docs/probe.md, Cores)"
            checks.append(Check(program, OK if path else SKIP, f"{path or 'not found'}: {what}"))
        elif path:
            checks.append(Check(program, OK, f"{path} (uros probe runs: {targets})"))
        else:
            why = f"not found: `uros probe` cannot run {targets}"
            checks.append(Check(program, SKIP, why, machines.qemu_hint(program)))
    checks += [eval_board_qemu(m, found) for m, found in board_qemus]
    if agent:
        checks.append(Check("agent", OK, agent))
    elif agent_given:
        checks.append(
            Check("agent", WARN, "UROS_AGENT names no program", "point UROS_AGENT at a MicroXRCEAgent")
        )
    else:
        checks.append(
            Check(
                "agent",
                SKIP,
                "no Micro XRCE-DDS Agent (UROS_AGENT unset, none built): `uros probe` needs one",
                "uros agent build (docs/probe.md, The agent)",
            )
        )
    return checks


def eval_git(version: str | None, mirrors: bool) -> Check:
    if version is None:
        return Check("git", FAIL, "not found (create-firmware clones with it)", "apt-get install git")
    if version_tuple(version) < GIT_CONFIG_ENV:
        why = "mirror rules cannot reach the clones CMake makes during the build (needs git >= 2.31)"
        return Check("git", FAIL if mirrors else WARN, f"{version}: {why}", "install git 2.31 or newer")
    return Check("git", OK, version)


def eval_colcon(path: str | None) -> Check:
    if path is None:
        return Check("colcon", FAIL, "not found", "pip install colcon-common-extensions (a uros dependency)")
    return Check("colcon", OK, path)


def eval_empy(version: str | None, python: str) -> Check:
    fix = f"{python} -m pip install 'empy>=3.3.4,<4'"
    if version is None:
        return Check("empy", FAIL, f"not importable in {python} (the rosidl generators need it)", fix)
    if version_tuple(version)[:1] >= (EMPY_BELOW,):
        return Check("empy", FAIL, f"{version}: empy 4 breaks the rosidl generators", fix)
    return Check("empy", OK, f"{version} in {python}")


def eval_ros_env(env: Mapping[str, str]) -> Check:
    found = [v for v in colcon.SCRUBBED_VARIABLES if env.get(v)]
    if not found:
        return Check("ROS environment", OK, "none sourced")
    return Check(
        "ROS environment",
        WARN,
        f"set: {', '.join(found)}; uros ignores them for its builds",
        "nothing to do; open a shell without ROS 2 sourced to silence the notice",
    )


def eval_disk(free: int, where: Path) -> Check:
    detail = f"{free / (1 << 30):.1f} GiB free in {where}"
    if free < DISK_FAIL:
        return Check("disk", FAIL, detail, "free some space (`uros clean --all` removes uros's build trees)")
    if free < DISK_WARN:
        return Check(
            "disk", WARN, detail, "a real micro-ROS build may fill it: `uros clean --all` frees uros's trees"
        )
    return Check("disk", OK, detail)


def eval_target(
    profile: TargetProfile, compiler: str | None, problem: str | None, code: str | None = None
) -> list[Check]:
    """The compiler check and, with it found, libc and C++ headers (``problem``: which is missing);
    ``code``: what the compiler makes for the core, where uros asked it (abi.xtensa_code, abi.riscv_code)."""
    hint = profile.install_hint or f"install {profile.tool('gcc')}"
    name = f"{profile.name} compiler"
    if compiler is None:
        return [Check(name, FAIL, problem or f"{profile.tool('gcc')} not found", hint)]
    checks = [Check(name, OK, f"{compiler}: {code}" if code else compiler)]
    libc_missing = problem is not None and "libc" in problem
    checks.append(
        Check(f"{profile.name} C library", FAIL, problem or "", hint)
        if libc_missing
        else Check(f"{profile.name} C library", OK, "libc.a found")
    )
    if libc_missing:
        checks.append(Check(f"{profile.name} C++ headers", SKIP, "not probed without a C library"))
    elif problem is not None:
        checks.append(Check(f"{profile.name} C++ headers", FAIL, problem, hint))
    elif profile.micro_ros.cxx_wrapper_headers:
        why = "none with the compiler: uros hands micro-ROS its wrappers of <cstddef>, <cstdio>, <cstring>"
        checks.append(Check(f"{profile.name} C++ headers", OK, why))
    else:
        checks.append(Check(f"{profile.name} C++ headers", OK, "<cstdint> compiles"))
    return checks


def eval_lock(lock: Lock, heads: Mapping[str, str | None]) -> Check:
    """``heads``: workspace path -> HEAD commit of its clone (None: no clone there)."""
    missing = sorted(p for p in lock.repositories if heads.get(p) is None)
    moved = sorted(
        p for p, r in lock.repositories.items() if heads.get(p) is not None and heads[p] != r.commit
    )
    # `create-firmware --force` refuses a clone off its locked commit (it may hold the user's work),
    # so the hint for one names the git command that puts it back, never --force
    back = ""
    if moved:
        back = f"git -C {moved[0]} checkout {lock.repositories[moved[0]].commit}" + (
            f" (and the same in the other {len(moved) - 1})" if len(moved) > 1 else ""
        )
    distro = f" --distro {lock.distro}" if lock.distro else ""
    reclone = f"uros create-firmware{distro} --locked --force clones the missing ones (in the workspace)"
    if missing:
        more = f" (and {len(missing) - 3} more)" if len(missing) > 3 else ""
        fix = f"{back} first, then {reclone}" if moved else reclone
        return Check("checkouts", FAIL, f"no clone at {', '.join(missing[:3])}{more}", fix)
    if moved:
        more = f" (and {len(moved) - 3} more)" if len(moved) > 3 else ""
        fix = f"in the workspace, {back} puts it back; or keep it (a build uses each clone as it is)"
        return Check("checkouts", WARN, f"not at the locked commit: {', '.join(moved[:3])}{more}", fix)
    return Check("checkouts", OK, f"{len(lock.repositories)} repositories at their locked commits")


def eval_dev_ws(built: bool, same_lock: bool, has_dev: bool) -> Check:
    if not has_dev:
        return Check("dev_ws", SKIP, "no dev_ws in this workspace (a plain colcon workspace)")
    if not built:
        return Check("dev_ws", WARN, "not built yet", "the next `uros build` builds it once (a few minutes)")
    if not same_lock:
        return Check("dev_ws", WARN, "built from another uros.lock", "delete dev_ws/install to rebuild it")
    return Check("dev_ws", OK, "built")


def eval_output(key: str, built: bool, changed: Sequence[str] | None) -> Check:
    """``built``: the output holds the build's build-info.json; ``changed``: what differs from the
    target's last good build (steps.inputs.changes over the workspace's own inputs: the sources'
    content and its settings files; None: no record to compare with)."""
    name = f"target {key}"
    if not built:
        return Check(
            name,
            WARN,
            "trees but no output (a build failed or was interrupted)",
            f"uros build --toolchain {key}",
        )
    if changed:
        return Check(
            name,
            WARN,
            f"stale: inputs changed since the last build: {', '.join(changed)}",
            f"uros build --toolchain {key}",
        )
    return Check(name, OK, "built and up to date" if changed is not None else "built (no record to compare)")


def failed(checks: Iterable[Check]) -> list[Check]:
    return [c for c in checks if c.status == FAIL]


def render(checks: Sequence[Check]) -> str:
    width = max(len(c.name) for c in checks)
    lines = []
    for c in checks:
        fix = f"  -> {c.fix}" if c.fix and c.status in (FAIL, WARN) else ""
        lines.append(f"{c.status:<4}  {c.name:<{width}}  {c.detail}{fix}".rstrip())
    return "\n".join(lines) + "\n"


# -- the probes --------------------------------------------------------------------------------


@dataclass(frozen=True)
class BoardQemu:
    """What doctor found for a board's qemu_env: the variable's value ("" unset), whether it names a
    program, and whether that program's `-cpu help` lists the board's CPU."""

    named: str
    runs: bool
    has_cpu: bool


def eval_board_qemu(machine: machines.Machine, found: BoardQemu) -> Check:
    board = machine.board
    name = f"{board.qemu} ({board.cpu})"
    fix = machines.qemu_hint(board.qemu, board)
    if not found.named:
        return Check(name, SKIP, f"{board.qemu_env} unset: `uros probe` cannot run {machine.target}", fix)
    if not found.runs:
        return Check(name, WARN, f"{board.qemu_env}={found.named}: no such program", fix)
    if not found.has_cpu:
        return Check(name, WARN, f"{found.named} ({board.qemu_env}) has no {board.cpu} CPU (-cpu help)", fix)
    return Check(
        name, OK, f"{found.named} ({board.qemu_env}, -cpu {board.cpu}; uros probe runs: {machine.target})"
    )


def _board_qemus(
    runner: Runner, table: Mapping[str, machines.Machine]
) -> list[tuple[machines.Machine, BoardQemu]]:
    out = []
    for machine in table.values():
        board = machine.board
        if not board.qemu_env:
            continue
        named = os.environ.get(board.qemu_env, "")
        runs = bool(named) and Path(named).is_file() and os.access(named, os.X_OK)
        has_cpu = False
        if runs:
            try:
                listed = runner.query([named, "-cpu", "help"], step=f"{board.qemu} -cpu help")
                has_cpu = board.cpu is not None and board.cpu in listed.split()
            except StepFailed:
                pass
        out.append((machine, BoardQemu(named, runs, has_cpu)))
    return out


def _which(runner: Runner, program: str, path: str | None = None) -> str | None:
    try:
        return runner.which(program, path=path)
    except MissingToolError:
        return None


def _version(runner: Runner, program: str) -> str | None:
    found = _which(runner, program)
    if found is None:
        return None
    try:
        return hosttools.first_version(runner.query([found, "--version"], step=f"{program} --version"))
    except StepFailed:
        return None


def _empy_version() -> str | None:
    # uros's own Python runs the generators (colcon.host_python): ask this interpreter
    try:
        return importlib.metadata.version("empy")
    except importlib.metadata.PackageNotFoundError:
        return None


def probe_target(runner: Runner, profile: TargetProfile) -> list[Check]:
    try:
        tools, _tool_dir = compilers.probe_target_tools(runner, profile)
    except MissingToolError as exc:
        return eval_target(profile, None, exc.message)
    problem = None
    with tempfile.TemporaryDirectory(prefix="uros-doctor-") as scratch:
        try:
            compilers.check_target_prerequisites(runner, profile, tools, Path(scratch))
        except (MissingToolError, StepFailed) as exc:
            problem = exc.message
        code = _code(runner, profile, tools["gcc"], Path(scratch))
    return eval_target(profile, tools["gcc"], problem, code)


def _code(runner: Runner, profile: TargetProfile, gcc: str, scratch: Path) -> str | None:
    """What an ESP32's compiler makes of abi.XTENSA_CODE_PROBE with the profile's flags: Espressif-core
    code or the lx106 stand-in's (docs/esp32.md); a RISC-V target's F/M/A instructions and float ABI."""
    windowed = profile.elf.xtensa_abi == "0"
    if not windowed and profile.elf.machine != "RISC-V":
        return None
    source, obj = scratch / "uros_code_probe.c", scratch / "uros_code_probe.o"
    source.write_text(abi.XTENSA_CODE_PROBE, encoding="utf-8")
    try:
        argv = [gcc, *profile.cpu_flags, "-O2", "-c", str(source), "-o", str(obj)]
        runner.query(argv, step="compile a probe")
        objdump = gcc[: -len("gcc")] + "objdump"
        disassembly = runner.query([objdump, "-dr", str(obj)], step="disassemble the probe")
        if windowed:
            return abi.xtensa_code(disassembly)
        header = runner.query(
            [gcc[: -len("gcc")] + "readelf", "-h", str(obj)], step="read the probe's header"
        )
        return abi.riscv_code(disassembly, header)
    except (MissingToolError, StepFailed):
        return None


def _head(runner: Runner, clone: Path) -> str | None:
    if not (clone / ".git").exists():
        return None
    try:
        return runner.query(["git", "-C", str(clone), "rev-parse", "HEAD"], step="git rev-parse").strip()
    except (StepFailed, MissingToolError):
        return None


def probe_workspace(runner: Runner, ws: Workspace) -> list[Check]:
    checks = []
    lock_path = ws.lock_path
    lock = read_lock(lock_path, "uros.lock") if lock_path.is_file() else None
    if lock is not None:
        heads = {p: _head(runner, ws.root / p) for p in lock.repositories}
        checks.append(eval_lock(lock, heads))
        same = ws.dev_built() and ws.dev_built_from() == lock_path.read_text(encoding="utf-8")
        checks.append(eval_dev_ws(ws.dev_built(), same, ws.dev_dir.is_dir()))
    for key in outputs.target_keys(ws):
        built = (ws.default_output(key) / BUILD_INFO).is_file()
        changed = inputs_step.output_changes(ws, key) if built else None
        if built:
            rtos = inputs_step.rtos_change(ws.default_output(key))
            changed = [*(changed or []), rtos] if rtos else changed
        checks.append(eval_output(key, built, changed))
    if not outputs.target_keys(ws):
        checks.append(Check("targets", OK, "none built yet"))
    return checks


def _profiles(toolchain: str | None, ws_root: Path | None) -> list[TargetProfile]:
    """The target named, else the workspace uros.yaml's target(s); shipped or own profiles only."""
    if toolchain is not None:
        names = [toolchain]
    elif ws_root is not None:
        names = [str(a.toolchain) for a in expand_targets(BuildArgs(workspace=ws_root)) if a.toolchain]
    else:
        names = []
    out = []
    for name in names:
        target = resolve_target(name, None)
        if hasattr(target, "profile"):
            out.append(target.profile)
    return out


def doctor(workspace: Path | None, toolchain: str | None, as_json: bool) -> list[Check]:
    root = resolve_workspace(workspace)
    if workspace is not None and not root.is_dir():  # a folder named on purpose: a typo is no "ok"
        raise ConfigError(
            f"--workspace {workspace}: {'is a file, not a folder' if root.exists() else 'no such folder'}",
            "pass the folder of a workspace, or leave -w out to check this host alone",
        )
    ws = Workspace(root.resolve()) if root.is_dir() else None
    runner = Runner(new_run_log(ws.log_dir if ws else user_log_dir(), "doctor"))
    cfg = load_config(ws.root) if ws else None
    # colcon runs with uros's Python's bin/ first on PATH: pip's ninja is there
    build_path = os.pathsep.join([str(Path(colcon.host_python()).parent), os.environ.get("PATH", "")])
    checks = [
        eval_cmake(_version(runner, "cmake")),
        eval_ninja(colcon.ninja_program({"PATH": build_path})),
        eval_git(_version(runner, "git"), bool(cfg and cfg.mirror.rules)),
        eval_colcon(_which(runner, hosttools.colcon_program())),
        eval_empy(_empy_version(), colcon.host_python()),
        eval_ros_env(os.environ),
    ]
    ccache = _which(runner, "ccache", build_path)
    trouble = hosttools.ccache_unusable(runner, ccache, os.environ) if ccache else None
    checks.append(eval_ccache(ccache, _version(runner, "ccache"), trouble))
    agent = resolve_outside(AGENT).value
    built = builtagent.current_agent(resolve_outside(ROS2_VENV).value.expanduser())  # uros agent build's
    found = _which(runner, agent) if agent else f"{built.describe()}: uros agent build's" if built else None
    qemus = {program: _which(runner, program) for program in machines.QEMU_PROGRAMS}
    table = machines.load_machines()
    checks += eval_probe_tools(qemus, found, bool(agent), table, _board_qemus(runner, table))
    where = ws.root if ws else Path.cwd()
    checks.append(eval_disk(shutil.disk_usage(where).free, where))
    try:
        profiles = _profiles(toolchain, ws.root if ws else None)
    except UrosError as exc:
        checks.append(Check("target", FAIL, exc.message, exc.hint or ""))
        profiles = []
    if not profiles and toolchain is None:
        checks.append(
            Check("target", SKIP, "none named", f"pass --toolchain NAME, or set target: in {CONFIG}")
        )
    for profile in profiles:
        checks += probe_target(runner, profile)
    if ws is not None:
        checks += probe_workspace(runner, ws)
    else:
        checks.append(Check("workspace", SKIP, f"no workspace at {root}", "pass -w DIR, or run inside one"))
    if as_json:
        data = {"ok": not failed(checks), "checks": [asdict(c) for c in checks]}
        console.print_json(data)
    else:
        sys.stdout.write(render(checks))
    bad = failed(checks)
    if bad:
        raise VerifyError(
            f"{len(bad)} check(s) failed ({', '.join(c.name for c in bad)}): a build would fail",
            "fix the FAIL lines above",
        )
    return checks
