"""The only module that starts processes (tooltext.py reads what they print).

Every command is found with ``shutil.which`` first (a missing program is a one-line error
naming the package that provides it), echoed as ``+ argv`` into the per-run log together with
the environment it runs in *as a difference from uros's own* (so a failed colcon run can be
repeated by hand from the log). Two ways to run:

- :meth:`Runner.run` streams merged stdout/stderr line by line into the log (and to the console
  with ``--verbose``): builds, clones; messages in English (``LC_MESSAGES=C``), since the first
  error line is picked out of them.
- :meth:`Runner.query` returns stdout alone, with stderr kept apart in the log and ``LC_ALL=C``
  set, for tools whose output uros parses (ar, nm, readelf, size, gcc): a warning on stderr or a
  translated "Machine:" line can never reach a parser.

A failure raises :class:`StepFailed` carrying the first error line and the log path. The design
follows colcon-core's (``subprocess.py``, ``event/command.py``, ``location.py``): one place owns
subprocesses and log locations, everything else builds argv lists as data.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, NoReturn

from uros_build import console
from uros_build.errors import DiskFull, MissingToolError, StepFailed, interrupted
from uros_build.files import link_atomic, pid_alive
from uros_build.tooltext import disk_full_line, disk_full_path, first_error, install_hint


def format_argv(argv: Sequence[str]) -> str:
    return "+ " + shlex.join(argv)


# The log of the current uros run: the CLI's catch-all writes an unexpected traceback there.
_current_log: Path | None = None


def current_log() -> Path | None:
    return _current_log


def new_run_log(log_dir: Path, command: str, key: str = "") -> Path:
    """``<log_dir>/<stamp>-<command>[-<key>]-<pid>.log``, with ``<log_dir>/latest.log`` pointing at
    it (colcon-core's ``latest`` link): the one place that names log files."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    name = "-".join(x for x in (stamp, command, key) if x)
    path = log_dir / f"{name}-{os.getpid()}.log"
    log_dir.mkdir(parents=True, exist_ok=True)
    latest = log_dir / "latest.log"
    with contextlib.suppress(OSError):  # a folder without symlinks (some mounts) keeps no link
        link_atomic(latest, path.name)
    return path


def user_log_dir() -> Path:
    """Where commands that have no workspace log (``uros check``, listings)."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(os.environ.get("TMPDIR") or "/tmp") / f"uros-{uid}" / "log"


def messages_in_c(env: Mapping[str, str]) -> dict[str, str]:
    """``env`` with the tools' messages in English, the rest of the user's locale kept: uros picks
    the first error line out of what builds and clones print (gcc's "error:", git's "Remote branch
    ... not found"), and translated messages would hide it. LC_ALL would override LC_MESSAGES, so
    its value moves to LANG, the lowest-priority setting
    (https://www.gnu.org/software/gettext/manual/html_node/Locale-Environment-Variables.html);
    LANGUAGE is ignored where LC_MESSAGES is C."""
    out = dict(env)
    if out.get("LC_ALL"):
        out["LANG"] = out.pop("LC_ALL")
    out["LC_MESSAGES"] = "C"
    return out


def env_difference(env: Mapping[str, str], base: Mapping[str, str]) -> list[str]:
    """``export``/``unset`` lines that turn ``base`` into ``env`` (sorted, shell-quoted)."""
    lines = [f"unset {k}" for k in sorted(set(base) - set(env))]
    lines += [f"export {k}={shlex.quote(v)}" for k, v in sorted(env.items()) if base.get(k) != v]
    return lines


@dataclass
class Runner:
    """Runs commands for one uros invocation, all logged into ``log_path``."""

    log_path: Path
    verbose: bool = False
    # Marks every process this runner starts, and every process those start, with UROS_OWNER=owner
    # in its environment: how a later run finds the leftovers of a killed one (stop_leftovers).
    owner: str = ""
    _resolved: dict[str, str] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def __post_init__(self) -> None:
        global _current_log
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        _current_log = self.log_path
        console.record_to(self.log_path)

    def which(self, program: str, hint: str | None = None, path: str | None = None) -> str:
        """Absolute path of ``program``; MissingToolError naming the fix when absent."""
        key = f"{program}\0{path}"
        if key not in self._resolved:
            found = shutil.which(program, path=path)
            if found is None:
                raise MissingToolError(f"'{program}' was not found on PATH", hint or install_hint(program))
            self._resolved[key] = found
        return self._resolved[key]

    def log(self, text: str) -> None:
        """Append to the run log; safe from several threads (parallel clones)."""
        with self._lock, self.log_path.open("a", encoding="utf-8") as log:
            log.write(text if text.endswith("\n") else text + "\n")

    def _prepare(
        self,
        argv: Sequence[str],
        hint: str | None,
        cwd: Path | None,
        env: Mapping[str, str] | None,
        label: str,
    ) -> list[str]:
        argv = [self.which(argv[0], hint, path=(env or os.environ).get("PATH")), *argv[1:]]
        where = f"   (in {cwd})" if cwd else ""
        diff = env_difference(env, os.environ) if env is not None else []
        self.log("\n".join([f"\n{label}{format_argv(argv)}{where}", *(f"{label}  {d}" for d in diff)]))
        return argv

    def run(
        self,
        argv: Sequence[str],
        *,
        step: str,
        cwd: Path | None = None,
        env: Mapping[str, str] | None = None,
        hint: str | None = None,
        quiet: bool = False,
        label: str = "",
        on_line: Callable[[str], None] | None = None,
        writes_to: Path | None = None,
    ) -> list[str]:
        """Run ``argv`` to completion, streaming its output; return the output lines.

        ``quiet`` keeps the ``+ argv`` echo out of the console (it is always in the log);
        ``label`` prefixes every logged line (``[uros/rclc] ``) when commands run in parallel;
        ``on_line`` sees every line as it arrives (a build's progress); ``writes_to`` is where the
        command writes (default ``cwd``): the disk a full-disk message that names no file is about.
        """
        env = self._marked(messages_in_c(env if env is not None else os.environ))
        argv = self._prepare(argv, hint, cwd, env, label)
        if not quiet:
            console.info(format_argv(argv))
        started = time.monotonic()
        lines: list[str] = []
        proc = self._start(argv, step, cwd, env, subprocess.STDOUT)
        try:
            assert proc.stdout is not None
            for line in proc.stdout:
                text = line.rstrip("\n")
                self.log(label + text)
                lines.append(text)
                if self.verbose:
                    console.tool_line(label + text)
                if on_line is not None:
                    on_line(text)
            code = proc.wait()
        except KeyboardInterrupt as exc:
            self._interrupted(proc, step, started, exc)
        except BaseException:
            # e.g. the log cannot be written (a full disk): the tools must not run on unwatched
            self._stop(proc)
            raise
        self.log(f"{label}exit {code} after {time.monotonic() - started:.1f} s")
        if code != 0:
            self._failed(step, code, lines, hint, writes_to or cwd)
        return lines

    def query(
        self,
        argv: Sequence[str],
        *,
        step: str,
        cwd: Path | None = None,
        env: Mapping[str, str] | None = None,
        hint: str | None = None,
        label: str = "",
    ) -> str:
        """Run a tool whose output uros parses: stdout only, in the C locale; stderr goes to the
        log (and into the error on failure), never into the parsed text. ``label`` prefixes its
        lines in the log when queries run in parallel."""
        base = self._marked(env if env is not None else os.environ)
        base["LC_ALL"] = "C"
        argv = self._prepare(argv, hint, cwd, base, label)
        started = time.monotonic()
        proc = self._start(argv, step, cwd, base, subprocess.PIPE)
        try:
            out, err = proc.communicate()
        except KeyboardInterrupt as exc:
            self._interrupted(proc, step, started, exc)
        except BaseException:
            self._stop(proc)
            raise
        if err:
            self.log(f"{label}stderr:\n" + err)
        self.log(f"{label}exit {proc.returncode} after {time.monotonic() - started:.1f} s ({len(out)} bytes)")
        if proc.returncode != 0:
            self._failed(step, proc.returncode, err.splitlines() or out.splitlines(), hint, cwd)
        return out

    def start(
        self,
        argv: Sequence[str],
        *,
        step: str,
        output: Path,
        hint: str | None = None,
        env: Mapping[str, str] | None = None,
    ) -> Background:
        """Start ``argv`` in the background, its output (stdout and stderr) into the file ``output``
        (a program uros talks to while another runs: QEMU, the agent, a host ROS 2 peer), in ``env``
        (default: uros's own). Stopped like every tool: with uros, or by :meth:`Background.stop`."""
        env = self._marked(messages_in_c(env if env is not None else os.environ))
        argv = self._prepare(argv, hint, None, env, "")
        self.log(f"(in the background; its output: {output})")
        with output.open("w", encoding="utf-8") as sink:
            proc = self._start(argv, step, None, env, subprocess.STDOUT, stdout=sink)
        return Background(proc, self, step)

    def _start(
        self,
        argv: list[str],
        step: str,
        cwd: Path | None,
        env: Mapping[str, str] | None,
        stderr: int,
        stdout: int | IO[str] = subprocess.PIPE,
    ) -> subprocess.Popen[str]:
        try:
            # A new session: Ctrl-C reaches uros first, which then stops the whole tool tree.
            return subprocess.Popen(
                argv,
                cwd=cwd,
                env=dict(env) if env is not None else None,
                stdout=stdout,
                stderr=stderr,
                stdin=subprocess.DEVNULL,
                text=True,
                errors="replace",
                start_new_session=True,
                preexec_fn=_dies_with(os.getpid()),
            )
        except OSError as exc:
            cause = f"could not start {argv[0]}: {exc}"
            raise StepFailed(f"{step}: {cause}", f"the log is {self.log_path}", cause=cause) from exc

    def _marked(self, env: Mapping[str, str]) -> dict[str, str]:
        out = dict(env)
        if self.owner:
            out[OWNER_VARIABLE] = self.owner
        return out

    def _stop(self, proc: subprocess.Popen[str]) -> None:
        """Stop the tool's process group, then whatever it started that left the group (ninja
        runs each command in a group of its own), with further signals held until that is done."""
        with signals_held():
            _stop(proc)
            self.stop_marked()

    def stop_marked(self) -> list[int]:
        """Stop every process still running that this runner started, or that those started (its
        UROS_OWNER mark, inherited): what a program left behind, such as a peer's child or a daemon
        it double-forked. Returns the pids signalled."""
        if not self.owner:
            return []
        with signals_held():
            stopped = stop_processes(marked_processes(self.owner))
        if stopped:
            self.log(f"stopped {len(stopped)} more processes: {' '.join(map(str, stopped))}")
        return stopped

    def _interrupted(
        self, proc: subprocess.Popen[str], step: str, started: float, cause: BaseException
    ) -> NoReturn:
        self._stop(proc)
        self.log(f"interrupted after {time.monotonic() - started:.1f} s")
        hint = "the previous output was left untouched"
        raise interrupted(cause, f"{step} was interrupted", hint) from None

    def _failed(
        self, step: str, code: int, lines: Sequence[str], hint: str | None, writes_to: Path | None = None
    ) -> NoReturn:
        full = disk_full_line(lines)
        if full is not None:
            where = disk_full_path(full) or writes_to or self.log_path.parent
            raise DiskFull.at(where, f"{step} failed: {full}")
        cause = first_error(lines)
        detail = f": {cause}" if cause else ""
        raise StepFailed(
            f"{step} failed (exit {code}){detail}",
            hint or f"the full output is in {self.log_path}",
            output=tuple(lines),
            code=code,
            cause=cause or f"exit {code}",
        )


@dataclass
class Background:
    """A program :meth:`Runner.start` runs beside uros."""

    proc: subprocess.Popen[str]
    runner: Runner
    step: str

    def wait(self, timeout: float) -> int | None:
        """Its exit status, or None when it is still running after ``timeout`` seconds."""
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None
        except KeyboardInterrupt as exc:
            self.stop()
            raise interrupted(exc, f"{self.step} was interrupted", "nothing was changed") from None
        self.runner.log(f"{self.step}: exit {code}")
        return code

    def stop(self) -> None:
        if self.proc.poll() is None:
            with signals_held():
                _stop(self.proc)
            self.runner.log(f"{self.step}: stopped")


def _stop(proc: subprocess.Popen[str]) -> None:
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)


# ---------------------------------------------------------------------------------------------
# signals, and the processes of a uros run that outlive it

OWNER_VARIABLE = "UROS_OWNER"
_HELD = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP wait until the block is done (a second Ctrl-C while the tools
    are being stopped, a signal during the renames of a swap)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def _dies_with(parent: int) -> Callable[[], None] | None:
    """On Linux, the tool uros starts gets SIGKILL when uros dies, even by SIGKILL (the OOM killer,
    `kill -9`, a CI runner): colcon then starts no more packages. The parent-death signal reaches
    that one process only; the cmake and ninja it already started are stopped by the next build of
    the target (stop_leftovers). Only from the main thread: the signal follows the thread that
    started the child, and clones run in worker threads."""
    if not sys.platform.startswith("linux") or threading.current_thread() is not threading.main_thread():
        return None
    import ctypes  # here: a start that runs no tool does not pay for it (start-up cost)

    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None

    def set_parent_death_signal() -> None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:  # uros died before the call took effect
            os._exit(1)

    return set_parent_death_signal


def environ_has(data: bytes, name: str, value: str) -> bool:
    """Whether a /proc/<pid>/environ (NUL-separated NAME=value) holds ``name=value`` (pure)."""
    return f"{name}={value}".encode() in data.split(b"\0")


def marked_processes(owner: str) -> list[int]:
    """Processes (other than uros itself) carrying UROS_OWNER=owner: started by a run for the same
    owner, and their children. Linux only (/proc); elsewhere none are found."""
    found = []
    me = os.getpid()
    proc_dir = Path("/proc")
    if not proc_dir.is_dir():
        return []
    for entry in proc_dir.iterdir():
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        try:
            data = (entry / "environ").read_bytes()
        except OSError:  # gone, or another user's
            continue
        if environ_has(data, OWNER_VARIABLE, owner) and not _zombie(entry):
            found.append(int(entry.name))
    return sorted(found)


def _zombie(entry: Path) -> bool:
    try:
        stat = (entry / "stat").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return True
    return stat.rpartition(")")[2].split()[:1] == ["Z"]


def stop_processes(pids: Sequence[int], grace: float = 5.0) -> list[int]:
    """SIGTERM each, SIGKILL what is still there after ``grace`` seconds; returns those signalled."""
    stopped = []
    for pid in pids:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signal.SIGTERM)
            stopped.append(pid)
    deadline = time.monotonic() + grace
    while stopped and time.monotonic() < deadline:
        if not [p for p in stopped if not _zombie(Path(f"/proc/{p}")) and pid_alive(p)]:
            return stopped
        time.sleep(0.1)
    for pid in stopped:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signal.SIGKILL)
    return stopped


def stop_leftovers(owner: str) -> list[int]:
    """Stop the processes a killed uros run for ``owner`` left running (called with the owner's lock
    held, so none of them belongs to a live uros run). Repeated until none is found: a leftover may
    start another process while the first are being stopped."""
    stopped: list[int] = []
    for _ in range(20):
        pids = [p for p in marked_processes(owner) if p not in stopped]
        if not pids:
            break
        stopped += stop_processes(pids)
    return stopped
