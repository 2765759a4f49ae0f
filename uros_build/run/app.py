"""`uros probe --app DIR`: a user's micro-ROS application run unchanged on the probe's board.

DIR holds C files written against rclc with micro_ros_setup's entry point, ``void appMain(void *arg)``
(its freertos_apps and zephyr_apps run apps that way, so existing apps need no change). The board
(templates/probe/: start-up, clock, heap, the serial link; app_main.c the runner) sets the custom
serial transport, makes its heap rcl's default allocator, waits for the agent and calls appMain. The
app ends the run with ``exit(status)`` (QEMU's exit status through semihosting), or the board ends it
``--duration`` seconds after appMain started.

DIR → its interface packages (its ``#include <pkg/msg|srv|action/...>``) checked against the
library's packages before anything is built → the firmware's CMakeLists rendered (every value
escaped) → built against the output like the probe → its size (the target's ``size``, LC_ALL=C) →
the QEMU + agent session → one verdict (run/appverdict.py). The pure parts are the scan, the checks
and the CMake text; :func:`stage_app` and :func:`build_app` make the firmware, and
uros_build/probesteps/ runs it (the probe's steps).

What the app cannot forge is judged in run/appverdict.py (the runner's nonce-marked end line and
QEMU's status). Here: the runner's nonce is compiled into app_main.c alone; the app's C files compile
apart (their -D in a response file the compiler reads exactly as typed, none of the runner's macro
names; no include folder shared with the board), reached through a link named ``app`` (no path of
the user's is in a build file), and their objects may define no symbol the board's objects define
(nm, before QEMU).
"""

from __future__ import annotations

import math
import re
import secrets
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import resources, templating
from uros_build.colcon.fingerprint import digest
from uros_build.errors import ConfigError, StepFailed
from uros_build.output.sizes import Sizes, parse_berkeley
from uros_build.output.symbols import STRONG, NmSymbol, parse_nm
from uros_build.proc import Runner
from uros_build.run.firmware import FirmwareBuild, build_firmware
from uros_build.target.toolsearch import BinTools

# -D names the board and the runner keep for themselves
RESERVED_PREFIXES = ("UROS_", "PROBE_")
# The board's weak definitions an app may replace (app_main.c: what apps written for an RTOS call)
APP_MAY_DEFINE = frozenset({"usleep", "sleep"})
# A C file name the build files carry as it is (make and CMake read ':', '$', '#', ';', spaces)
_SAFE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")
# How long uros waits for a --duration run before it stops QEMU itself: the runner's wait for the
# agent (20 s) and QEMU's start, and the board's clock running slow: it counts SysTick interrupts, and
# QEMU drops those a loaded host cannot deliver in time (--duration 3 took 12 s of wall time at load
# 13 on 2 cores), so the duration counts DURATION_SLOWDOWN times over.
DURATION_GRACE = 25.0
DURATION_SLOWDOWN = 4

_INCLUDE = re.compile(
    r'^[ \t]*#[ \t]*include[ \t]*[<"](?P<package>[A-Za-z][A-Za-z0-9_]*)/(?P<kind>msg|srv|action)/'
    r'(?P<rest>[A-Za-z0-9_./]+\.h)[>"]',
    re.MULTILINE,
)
_APP_MAIN = re.compile(r"^[ \t]*void[ \t\n]+appMain[ \t\n]*\([^;)]*\)[ \t\n]*\{", re.MULTILINE)
_DEFINE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_APP_HINT = "a folder of C files, one of which defines void appMain(void *arg) (micro_ros_setup's apps)"


@dataclass(frozen=True)
class AppSources:
    """An application folder: its C files and the interface packages they include."""

    folder: Path
    sources: tuple[Path, ...]  # DIR/*.c, sorted
    packages: Mapping[str, str]  # interface package -> where it is first included ("app.c:3")


@dataclass(frozen=True)
class AppPlan:
    """What `uros probe --app` runs: the app, its -D macros, --duration in ms (0: none)."""

    app: AppSources
    defines: tuple[str, ...]
    duration_ms: int


def app_work(base: Path, target: str, out: Path, folder: Path) -> Path:
    """The work folder of an app's runs against output ``out`` (beside the probe's, run/report.py)."""
    return base / "probe" / f"app-{target}-{digest(f'{out}|{folder}')[:10]}"


def interface_includes(text: str) -> list[tuple[str, int]]:
    """(package, line) of every ``#include <pkg/msg|srv|action/...h>`` in C text, in order."""
    return [(m.group("package"), text.count("\n", 0, m.start()) + 1) for m in _INCLUDE.finditer(text)]


def shown(path: Path) -> str:
    """A path for a one-line message: a line break or other unprintable character as its escape."""
    return templating.cmake_comment(str(path))


def app_folder(folder: Path) -> Path:
    """--app DIR made absolute, every link followed (pure); a link loop, or no folder, is one line."""
    try:
        resolved = folder.resolve()
        is_dir = resolved.is_dir()
    except (OSError, RuntimeError) as err:  # a symlink loop: RuntimeError before Python 3.13
        raise ConfigError(
            f"--app {shown(folder)}: cannot be followed ({getattr(err, 'strerror', None) or err})",
            f"a symbolic link that leads back to itself? give {_APP_HINT}",
        ) from None
    if not is_dir:
        raise ConfigError(f"--app {shown(folder)}: no such folder", f"give {_APP_HINT}")
    return resolved


def _check_name(folder: Path, path: Path) -> None:
    if not _SAFE_NAME.fullmatch(path.name):
        raise ConfigError(
            f"--app {shown(folder)}: the file name {path.name!r} cannot be written into the build files",
            "rename it with letters, digits, '_', '.', '-' and '+' only (make and CMake read ':', '$', '#', "
            "';', spaces and line breaks)",
        )


def scan_app(folder: Path) -> AppSources:
    """DIR's C files and interface packages (pure: reads DIR's *.c and *.h, not its subfolders)."""
    given, folder = folder, app_folder(folder)
    sources = tuple(sorted(p for p in folder.glob("*.c") if p.is_file()))
    if not sources:
        raise ConfigError(f"--app {shown(given)}: holds no .c file", f"give {_APP_HINT}")
    headers = sorted(p for p in folder.glob("*.h") if p.is_file())
    for path in (*sources, *headers):
        _check_name(given, path)
    texts = {p: p.read_text(encoding="utf-8", errors="replace") for p in sources}
    if not any(_APP_MAIN.search(text) for text in texts.values()):
        names = ", ".join(p.name for p in sources)
        raise ConfigError(
            f"--app {shown(given)}: no C file defines void appMain(void *arg) ({names})",
            "the board calls appMain once the agent answers, as micro_ros_setup's freertos_apps do",
        )
    for header in headers:
        texts[header] = header.read_text(encoding="utf-8", errors="replace")
    packages: dict[str, str] = {}
    for path, text in texts.items():
        for package, line in interface_includes(text):
            packages.setdefault(package, f"{path.name}:{line}")
    return AppSources(folder, sources, dict(sorted(packages.items())))


def missing_packages(app: AppSources, library_packages: Iterable[str]) -> list[str]:
    have = set(library_packages)
    return [p for p in app.packages if p not in have]


def missing_packages_error(
    app: AppSources, missing: Sequence[str], out: Path, workspace: Path | None
) -> ConfigError:
    """One line: which packages the app includes that the library lacks, and the fix."""
    where = ", ".join(f"{p} ({app.packages[p]})" for p in missing)
    wanted = " ".join(app.packages)
    ws = f" -w {workspace}" if workspace is not None else ""
    return ConfigError(
        f"--app {shown(app.folder)}: the library {out} lacks {where}",
        f"add the interface package to the workspace (`uros add-package{ws} PATH|URL`, or `uros interface "
        f"new`), then build it in: `uros build{ws} --packages {wanted}`",
    )


def parse_defines(defines: Iterable[str]) -> tuple[str, ...]:
    """-D NAME or -D NAME=VALUE, as for a C compiler; NAME must be a C identifier the runner does not
    keep for itself, VALUE one line (it reaches the compiler exactly as typed: :func:`response_file`)."""
    out = []
    for define in defines:
        name = define.split("=", 1)[0]
        if not _DEFINE.fullmatch(name):
            raise ConfigError(
                f"--define {define!r}: {name!r} is not a C macro name",
                "e.g. -D HSB_STATE_PERIOD_MS=200 or -D HSB_LOOPBACK",
            )
        if name.startswith(RESERVED_PREFIXES):
            raise ConfigError(
                f"--define {define!r}: {name} is the probe board's own (names starting with "
                f"{' or '.join(RESERVED_PREFIXES)} are kept for the runner)",
                "give the app's macro another name; --duration sets how long the board lets the app run",
            )
        bad = next((c for c in define if ord(c) < 32 or ord(c) == 127), None)
        if bad is not None:
            raise ConfigError(
                f"--define {define!r}: holds the control character {bad!r} (a line break ends a C "
                "definition)",
                "give the value on one line, e.g. -D 'MSG=\"a b\"'",
            )
        out.append(define)
    return tuple(out)


def response_file(defines: Sequence[str]) -> str:
    """The app's -D as a GCC response file (``@file``, libiberty's buildargv): every character
    escaped with a backslash, so each value reaches the compiler exactly as typed (no build tool
    between: CMake's own escaping drops '#' for make and splits ';')."""
    return "".join("".join("\\" + c for c in f"-D{define}") + "\n" for define in defines)


def check_duration(duration: float | None) -> int:
    """--duration in whole milliseconds (0: none)."""
    if duration is None:
        return 0
    if not (math.isfinite(duration) and 0 < duration <= 86400):
        raise ConfigError(
            f"--duration {duration:g}: must be a number of seconds more than 0 (at most a day)",
            "e.g. --duration 10",
        )
    return max(1, round(duration * 1000))


def session_timeout(timeout: float, duration_ms: int) -> float:
    """How long uros lets QEMU run: --timeout, or with --duration that and the runner's start-up."""
    return timeout if duration_ms == 0 else DURATION_SLOWDOWN * duration_ms / 1000 + DURATION_GRACE


def app_cmake(app: AppSources, defines: Sequence[str], duration_ms: int, nonce: str) -> str:
    """The app firmware's CMakeLists.txt: the app's C files by name under ``app/`` (the link to its
    folder), its -D in ``app-defines.rsp``; the runner's duration and nonce on app_main.c alone."""
    for path in app.sources:
        _check_name(app.folder, path)
    if not re.fullmatch(r"[0-9a-f]{16,64}", nonce):
        raise ValueError(f"a nonce is lowercase hex: {nonce!r}")
    return templating.render(
        "probe-app.cmake.j2",
        app_dir=str(app.folder),
        sources=[p.name for p in app.sources],
        defines=bool(defines),
        duration_define=f"UROS_APP_DURATION_MS={duration_ms}",
        nonce_define=f'UROS_APP_NONCE="{nonce}"',
    )


def symbol_conflicts(
    folder: Path, app_objects: Mapping[str, Sequence[NmSymbol]], board: Sequence[NmSymbol]
) -> ConfigError | None:
    """What the app's objects may not define (pure, over ``nm -g`` of each): a symbol the board's
    objects define (main, _exit, the heap and stack figures, the clock: the app would replace them or
    fail the link in its linker's words), the same symbol in two of its files, or no appMain."""
    board_defined = {s.name for s in board if s.kind != "U" and s.kind.isupper()}
    where: dict[str, list[str]] = {}
    for source, symbols in app_objects.items():
        for symbol in symbols:
            if symbol.kind != "U" and symbol.kind.isupper():
                if symbol.name in board_defined and symbol.name not in APP_MAY_DEFINE:
                    return ConfigError(
                        f"--app {shown(folder)}: {source} defines {symbol.name}, which the probe's board "
                        f"defines ({_board_role(symbol.name)})",
                        "rename it in the app, or leave it out: the board provides it "
                        "(docs/probe.md, 'Your own app')",
                    )
                if symbol.kind in STRONG:
                    where.setdefault(symbol.name, []).append(source)
    twice = next(((name, files) for name, files in sorted(where.items()) if len(files) > 1), None)
    if twice is not None:
        name, files = twice
        return ConfigError(
            f"--app {shown(folder)}: {name} is defined in both {files[0]} and {files[1]}",
            "keep one definition (make the other static, or remove it)",
        )
    if "appMain" not in where:
        names = ", ".join(app_objects)
        return ConfigError(
            f"--app {shown(folder)}: no C file defines void appMain(void *arg) once compiled ({names}: "
            "only in a comment, or under an #if that is off?)",
            "the board calls appMain once the agent answers, as micro_ros_setup's freertos_apps do",
        )
    return None


def _board_role(name: str) -> str:
    if name == "main":
        return "its runner is main; the app's entry is appMain"
    if name in ("_exit", "exit", "probe_exit_status"):
        return "its exit path records the app's status"
    if name.startswith("probe_"):
        return "the runner's own: its clock, figures or link"
    return "its start-up, clock, console or heap"


def link_error(output: Sequence[str]) -> str | None:
    """The linker's own reason from a failed build's output (pure): its first `multiple definition`
    or `undefined reference` line, not collect2's summary."""
    wanted = re.compile(r"(multiple definition of|undefined reference to) [`']([^'`]+)'")
    for line in output:
        found = wanted.search(line)
        if found:
            where = line[: found.start()].rstrip(": ").rsplit("ld: ", 1)[-1].rsplit("/", 1)[-1]
            return f"{found.group(1)} '{found.group(2)}' ({where})"
    return None


def elf_sizes(size_output: str) -> Sizes:
    """text/data/bss of one ELF from ``size`` (Berkeley format)."""
    found = list(parse_berkeley(size_output).values())
    if len(found) != 1:
        raise StepFailed("size of the app firmware: no text/data/bss line", size_output.strip()[:200] or None)
    return found[0]


def stage_app(plan: AppPlan, work: Path) -> tuple[Path, str]:
    """The app firmware's sources in work/app-src (the probe's board, the rendered CMakeLists, the
    app's -D response file) and this run's nonce (only the runner's compile sees it)."""
    nonce = secrets.token_hex(16)
    staged = work / "app-src"
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(resources.templates_dir() / "probe", staged)
    (staged / "CMakeLists.txt").write_text(
        app_cmake(plan.app, plan.defines, plan.duration_ms, nonce), encoding="utf-8"
    )
    if plan.defines:
        (staged / "app-defines.rsp").write_text(response_file(plan.defines), encoding="utf-8")
    return staged, nonce


def build_app(
    runner: Runner, spec: FirmwareBuild, verbose: bool, app: AppSources, tools: BinTools
) -> tuple[Path, Sizes]:
    """Build the app firmware (``spec``, its sources staged by :func:`stage_app`), check its objects
    against the board's (a failed link says the linker's reason) and measure it: its ELF and sizes."""
    build = spec.work / "build"
    try:
        elf = build_firmware(runner, spec, verbose)
    except StepFailed as failed:
        conflict = _check_objects(runner, tools.nm, build, app)
        if conflict is not None:
            raise conflict from failed
        said = link_error(failed.output)
        if said is not None:
            raise StepFailed(f"link the uros_app firmware: {said}", failed.hint) from failed
        raise
    conflict = _check_objects(runner, tools.nm, build, app)
    if conflict is not None:
        raise conflict
    size = runner.query([tools.size, str(elf)], step="size of the app firmware")
    return elf, elf_sizes(size)


def _objects(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.suffix in (".o", ".obj") and p.is_file())


def _check_objects(runner: Runner, nm: str, build: Path, app: AppSources) -> ConfigError | None:
    """nm over the app's objects and the board's (the two targets' object folders), then
    :func:`symbol_conflicts`; None also when the app's did not all compile (the compiler said why)."""
    app_dir, board_dir = build / "CMakeFiles" / "uros_app_code.dir", build / "CMakeFiles" / "uros_probe.dir"
    app_objects = {p.name: p for p in _objects(app_dir)}
    by_source = {
        src.name: app_objects.get(f"{src.name}.obj") or app_objects.get(f"{src.name}.o")
        for src in app.sources
    }
    if any(p is None for p in by_source.values()) or not _objects(board_dir):
        return None

    def symbols(paths: Sequence[Path]) -> tuple[NmSymbol, ...]:
        text = runner.query(
            [nm, "-g", "--format=posix", *map(str, paths)], step="nm of the app firmware's objects"
        )
        return parse_nm(text, paths[0].name if len(paths) == 1 else "")

    found = {name: symbols([path]) for name, path in by_source.items() if path is not None}
    return symbol_conflicts(app.folder, found, symbols(_objects(board_dir)))
