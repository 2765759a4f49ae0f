"""Helpers shared by the test suites."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE, fixture_build_args

from uros_build.sources import distros

REPO = Path(__file__).resolve().parent.parent
STM32H7_EXAMPLE = REPO / "examples" / "stm32h7-custom-interfaces"


def default_sigint() -> None:
    """preexec_fn for a uros that a test interrupts: Ctrl-C at its default. A shell without job
    control starts background commands with SIGINT ignored, and a Python started so keeps ignoring
    it (no KeyboardInterrupt): a CI started in the background would otherwise never interrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_uros(
    *args: str, cwd: Path | None = None, check: bool = True, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """Run the real `uros` CLI as a user would (a separate process)."""
    proc = subprocess.run(
        [sys.executable, "-m", "uros_build", *args],
        cwd=cwd,
        env=env if env is not None else os.environ.copy(),
        capture_output=True,
        text=True,
    )
    if check and proc.returncode != 0:
        raise AssertionError(
            f"uros {' '.join(args)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
        )
    return proc


def build_fixture(
    ws: Path,
    *more: str,
    meta: Path | None = None,
    toolchain: str = "cortex-m7",
    check: bool = True,
    env: dict[str, str] | None = None,
) -> subprocess.CompletedProcess[str]:
    """`uros build` of the fixture workspace ``ws`` (fixture_ws.fixture_build_args: its fixture.meta
    or ``meta``, cortex-m7 or ``toolchain``), then ``more`` (UP_TO_CORE: fx_core alone)."""
    return run_uros(*fixture_build_args(ws, *more, meta=meta, toolchain=toolchain), check=check, env=env)


def once_then_restored(snapshot: Path, live: Path) -> Path:
    """A fresh copy of ``snapshot`` at ``live`` (removed first), where the snapshot was made from:
    a module's build made once, restored for each test that changes it. copytree keeps every
    mtime, and the paths are the built ones, so its next build of the same inputs is up to date."""
    if live.exists():
        shutil.rmtree(live)
    return Path(shutil.copytree(snapshot, live, symlinks=True))


def run_uros_here(
    *args: str, cwd: Path | None = None, check: bool = True, env: dict[str, str | None] | None = None
) -> subprocess.CompletedProcess[str]:
    """The real `uros` CLI in this process, for a case that starts no process (bad input answered
    before anything runs): ``uros_build.cli.main``, the path a user's command takes, whose one
    handler turns errors into the line and the exit code a user sees; click's CliRunner isolation
    swaps stdin, stdout, stderr and the environment (``env``: variables to set, None to unset).
    Starting a process is refused: such a case belongs to :func:`run_uros`."""
    import signal

    from click.testing import CliRunner

    from uros_build import cli, console, proc

    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)}  # main sets its own
    refused = pytest.MonkeyPatch()
    refused.setattr(subprocess, "Popen", _no_process)
    if cwd is not None:
        refused.chdir(cwd)
    try:
        with CliRunner().isolation(env=env) as (out, err, _):
            try:
                cli.main(list(args))
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
            done = subprocess.CompletedProcess(
                ["uros", *args], code, out.getvalue().decode(), err.getvalue().decode()
            )
    finally:
        refused.undo()
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
        console.record_to(None)
        proc._current_log = None
    if check and done.returncode != 0:
        raise AssertionError(
            f"uros {' '.join(args)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}"
        )
    return done


def _no_process(*args: object, **kwargs: object) -> None:
    raise AssertionError(f"run_uros_here: this case starts a process ({args[0]!r}); use run_uros")


class Background:
    """`uros ARGS` started in the background, its stderr lines collected as they come."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uros_build", *args],
            stderr=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            text=True,
        )
        self.lines: list[str] = []
        assert self.proc.stderr is not None
        self.reader = threading.Thread(target=lambda: self.lines.extend(self.proc.stderr))  # type: ignore[arg-type]
        self.reader.start()

    def wait_for(self, text: str, seconds: float = 60) -> None:
        """Until a line holds ``text``; fails if uros ends or ``seconds`` pass first."""
        deadline = time.monotonic() + seconds
        while not any(text in line for line in self.lines):
            assert self.proc.poll() is None and time.monotonic() < deadline, "".join(self.lines)
            time.sleep(0.2)

    def end(self, seconds: float = 120) -> int:
        code = self.proc.wait(timeout=seconds)
        self.reader.join()
        return code


def running(marker: str) -> list[str]:
    """The processes whose command line holds ``marker`` (pgrep -f)."""
    done = subprocess.run(["pgrep", "-af", marker], capture_output=True, text=True)
    return [line for line in done.stdout.splitlines() if "pgrep" not in line]


def until(condition: Callable[[], object], what: str, seconds: float = 60) -> None:
    """Wait for ``condition`` (polled every 0.1 s), not for a fixed time: a loaded machine is late;
    fails naming ``what`` if ``seconds`` pass first."""
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, f"{what}: not within {seconds} s"
        time.sleep(0.1)


def sleeping_build(args: list[str], marker: str) -> subprocess.Popen[str]:
    """`uros ARGS` of the fixture with fx_core's configure running `sleep <marker>` (FX_SLEEP: a
    process a test finds by its unique argument, and whose seconds the marker is), Ctrl-C at its
    default; returns once that sleep runs (its stderr a pipe)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "uros_build", *args, "--set", f"fx_core.FX_SLEEP={marker}"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint,
    )  # fmt: skip

    def started() -> bool:
        assert proc.poll() is None, proc.communicate()[1]
        return bool(running(f"sleep {marker}"))

    until(started, "the configure step's sleep", 120)
    return proc


def build_firmware_project(source: Path, package: Path, build: Path, *cmake_args: str) -> Path:
    """Configure and build a firmware CMake project against a `uros build` output (its firmware
    toolchain file and its CMake package), as a user would; returns the ELF."""
    subprocess.run(
        ["cmake", "-S", str(source), "-B", str(build), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={package / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={package}",
         "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", *cmake_args],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    done = subprocess.run(["cmake", "--build", str(build)], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"firmware build failed:\n{done.stdout}\n{done.stderr}")
    return build / "firmware.elf"


def env_without(programs: tuple[str, ...], shadow: Path) -> dict[str, str]:
    """The environment with ``programs`` gone from PATH: every PATH folder holding one of them is
    replaced by a folder of links to everything else in it (made under ``shadow``)."""
    env = os.environ.copy()
    folders = []
    for i, entry in enumerate(p for p in env.get("PATH", "").split(os.pathsep) if p):
        folder = Path(entry)
        if not any((folder / p).exists() for p in programs):
            folders.append(entry)
            continue
        copy = shadow / f"path{i}"
        copy.mkdir(parents=True, exist_ok=True)
        for item in folder.iterdir():
            if item.name not in programs and not (copy / item.name).exists():
                (copy / item.name).symlink_to(item)
        folders.append(str(copy))
    env["PATH"] = os.pathsep.join(folders)
    return env


def defined_globals(lib: Path) -> Counter[str]:
    """The global symbols an ARM archive defines, with how many members define each."""
    out = subprocess.run(
        ["arm-none-eabi-nm", "-g", "--defined-only", "--format=posix", str(lib)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "LC_ALL": "C"},
    ).stdout
    return Counter(line.split()[0] for line in out.splitlines() if line and not line.endswith(":"))


def git_out(*args: str, cwd: Path) -> str:
    """git's stdout, with a fixed identity and no user configuration."""
    return subprocess.run(
        ["git", *args],
        cwd=cwd,
        check=True,
        capture_output=True,
        text=True,
        env={
            "GIT_AUTHOR_NAME": "t",
            "GIT_AUTHOR_EMAIL": "t@t",
            "GIT_COMMITTER_NAME": "t",
            "GIT_COMMITTER_EMAIL": "t@t",
            "PATH": "/usr/bin:/bin",
        },
    ).stdout.strip()


def git_commit(repo: Path, message: str) -> str:
    """One more commit on the checked-out branch of ``repo`` (a line in HISTORY); its sha."""
    history = repo / "HISTORY"
    history.write_text((history.read_text() if history.exists() else "") + message + "\n")
    git_out("add", "-A", cwd=repo)
    git_out("commit", "-q", "-m", message, cwd=repo)
    return git_out("rev-parse", "HEAD", cwd=repo)


def fake_upstream(root: Path, distro_names: tuple[str, ...]) -> Path:
    """<root>/<owner>+<repo>: a real git repository per repository of these distros' manifests,
    with the branch each asks for (as west's tests serve repositories from file paths), the first
    distro's checked out (where git_commit adds a commit)."""
    root.mkdir(parents=True, exist_ok=True)
    first: dict[Path, str] = {}
    for name in distro_names:
        d = distros.load_distro(name)
        for repo in (*d.dev, *d.mcu):
            key = distros.owner_repo(repo.url)
            assert key
            path = root / key.replace("/", "+")
            if not path.exists():
                path.mkdir()
                # no sample hooks: fewer files to copy for each test
                git_out("init", "-q", "--template=", "-b", repo.version, cwd=path)
                (path / "README").write_text(f"fake {key}\n")
                git_commit(path, "initial")
            elif repo.version not in git_out("branch", "--format=%(refname:short)", cwd=path).split():
                git_out("checkout", "-q", "-b", repo.version, cwd=path)
                git_commit(path, f"{repo.version} starts")
            first.setdefault(path, repo.version)
    for path, version in first.items():
        git_out("checkout", "-q", version, cwd=path)
    return root


def upstream_mirror(upstream: Path) -> list[str]:
    """create-firmware's mirror flags that point every repository at ``fake_upstream``'s."""
    return [
        "--mirror",
        f"https://github.com/{{owner}}/{{repo}}={upstream}/{{owner}}+{{repo}}",
        "--mirror-override",
        f"uros/tracetools={upstream}/ros_tracing+ros2_tracing",
    ]


def need(*programs: str) -> None:
    missing = [p for p in programs if shutil.which(p) is None]
    if missing:
        message = f"not installed: {', '.join(missing)} (.ci/run installs them)"
        # .ci/run sets this after installing them: there a missing program is a broken CI, not a skip
        if os.environ.get("UROS_TEST_TOOLS_REQUIRED") == "1":
            pytest.fail(message)
        pytest.skip(message)


def humble_mirror_args(mirror: str) -> list[str]:
    """create-firmware's mirror options for humble from a local mirror of the upstream clones
    (<owner>+<repo>/repo, UROS_MIRROR): the substitutions such a mirror needs (docs/real-humble.md)."""

    def git_dir(name: str) -> str:
        base = Path(mirror) / name / "repo"
        return str(base / ".git") if (base / ".git").is_dir() else str(base)

    return [
        "--mirror",
        f"https://github.com/{{owner}}/{{repo}}={mirror}/{{owner}}+{{repo}}/repo",
        # humble branch missing from ament/googletest: its ros2 branch stands in
        "--mirror-override",
        f"ament/googletest={git_dir('ament+googletest')}@ros2",
        # micro-ROS' humble fork of rosidl_typesupport, as carried by fictionlab's clone
        "--mirror-override",
        f"uros/rosidl_typesupport={git_dir('fictionlab+rosidl_typesupport')}",
        # the gitlab fork of tracetools is not mirrored: upstream ros2_tracing's humble branch
        "--mirror-override",
        f"uros/tracetools={git_dir('ros2+ros2_tracing')}",
    ]


# -- mount namespaces: outputs on mount points (docker -v, CI volumes) -------------------------


def mount_namespace(tmp_path: Path) -> list[str]:
    """The command prefix that runs a shell in a mount namespace of its own (root: `unshare -m`;
    others: a user namespace too, `unshare -rm`), where `mount --bind` and tmpfs work; skipped where
    the system allows neither (containers without CAP_SYS_ADMIN)."""
    if shutil.which("unshare") is None:
        pytest.skip("no unshare (util-linux)")
    probe = tmp_path / "probe"
    probe.mkdir()
    for prefix in (["unshare", "-m"], ["unshare", "-rm"]):
        done = subprocess.run(
            [*prefix, "sh", "-c", f"mount -t tmpfs -o size=1m tmpfs {probe} && mount --bind {probe} {probe}"],
            capture_output=True,
        )
        if done.returncode == 0:
            probe.rmdir()
            return prefix
    pytest.skip("mount namespaces are not allowed here (unshare -m / -rm failed)")


def in_namespace(prefix: list[str], script: str) -> subprocess.CompletedProcess[str]:
    """``script`` run by bash in the namespace :func:`mount_namespace` gives (``set -u``)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run(
        [*prefix, "bash", "-c", "set -u\n" + script], capture_output=True, text=True, env=env
    )


def uros_build_line(ws: Path, log: Path, *more: str) -> str:
    """A shell line running `uros build` of the fixture's fx_core for cortex-m7 into ``log``.{out,err,rc}
    (build_fixture's command)."""
    args = " ".join([sys.executable, "-m", "uros_build", *fixture_build_args(ws, *UP_TO_CORE, *more)])
    return f"{args} >{log}.out 2>{log}.err; echo $? >{log}.rc\n"


def line_result(log: Path) -> tuple[int, str]:
    """The exit status and stderr of a :func:`uros_build_line` (no traceback in it)."""
    err = Path(f"{log}.err").read_text()
    assert "Traceback" not in err, err
    return int(Path(f"{log}.rc").read_text()), err


def humble_copy(fw: Path, built: str | None, mirror: str | None) -> Path:
    """A Humble workspace at ``fw`` of a test module's own: a copy of ``built`` (UROS_HUMBLE_WS, never
    built in itself), else a new one from ``mirror`` (UROS_MIRROR)."""
    if built:
        subprocess.run(["cp", "-a", built, str(fw)], check=True)
    else:
        assert mirror
        run_uros("create-firmware", "--distro", "humble", "-w", str(fw), *humble_mirror_args(mirror))
    return fw


def s3_compiler_skip(prefix: str, scratch: Path) -> str | None:
    """Why a test of real ESP32-S3 code cannot run with `<prefix>gcc` (absent, or it makes lx106 code:
    the stand-in of tests/esp32s3-compat-env.sh), or None when it makes Espressif-core code."""
    from uros_build.target import abi

    if not shutil.which(prefix + "gcc"):
        return f"no {prefix}gcc on PATH (tests/esp32s3-real-env.sh makes one)"
    env = {**os.environ, "LC_ALL": "C"}
    (scratch / "probe.c").write_text(abi.XTENSA_CODE_PROBE, encoding="utf-8")
    compile_probe = [
        prefix + "gcc",
        "-mlongcalls",
        "-O2",
        "-c",
        str(scratch / "probe.c"),
        "-o",
        str(scratch / "probe.o"),
    ]
    subprocess.run(compile_probe, capture_output=True, text=True, check=True, env=env)
    dump = [prefix + "objdump", "-dr", str(scratch / "probe.o")]
    code = abi.xtensa_code(subprocess.run(dump, capture_output=True, text=True, check=True, env=env).stdout)
    return None if code.startswith("makes Espressif-core code") else f"{prefix}gcc {code}"
