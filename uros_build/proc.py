"""The only module that starts processes.

Every command is found with ``shutil.which`` first (a missing program is a one-line error
naming the package that provides it), echoed as ``+ argv``, and its output is streamed line
by line into the per-run log (and to the console with ``--verbose``). A failure raises
:class:`StepFailed` carrying the first error line and the log path. The design follows
colcon-core's: one place owns subprocesses, everything else builds argv lists as data.
"""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import shutil
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from uros_build import console
from uros_build.errors import Interrupted, MissingToolError, StepFailed

# Where a missing program comes from, by name pattern. Target compilers carry their own hint
# in the target profile (toolchains/*.yaml); this covers the host tools.
_HOST_TOOL_HINTS: tuple[tuple[str, str], ...] = (
    (r"^cmake$", "install CMake: apt-get install cmake (or pip install cmake)"),
    (r"^git$", "install git: apt-get install git"),
    (r"^ninja$", "install ninja: pip install ninja (or apt-get install ninja-build)"),
    (r"^colcon$", "install colcon: pip install colcon-common-extensions"),
    (r"^arm-none-eabi-", "install the Arm GCC: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi"),
    (r"^riscv64-unknown-elf-", "install the RISC-V GCC: apt-get install gcc-riscv64-unknown-elf"),
    (r"^xtensa-lx106-elf-", "install the Xtensa GCC: apt-get install gcc-xtensa-lx106"),
)

# The most telling line of a failed build, best first: a compiler diagnostic (file:line: error:),
# a CMake error, any other "error:", then ninja's/make's own failure lines.
_ERROR_PATTERNS = tuple(
    re.compile(p)
    for p in (
        r":\d+:(\d+:)? (fatal )?error: ",
        # rosidl rejecting an interface file: its own message names the file and the line, which
        # is what a user needs rather than the CMake stack around it
        r"^\s*Error processing '|^\s*([\w.]+\.)?(Invalid\w+|\w+Error): ",
        r"CMake Error",
        r"\berror: |\bError: |^fatal: ",
        r"^FAILED: |\*\*\* ",
    )
)


def first_error(lines: Sequence[str]) -> str | None:
    for pattern in _ERROR_PATTERNS:
        for line in lines:
            if pattern.search(line):
                text = line.strip()
                # ninja's FAILED lines list every output of the step: keep the message one line
                return text if len(text) <= 300 else text[:297] + "..."
    return lines[-1].strip() if lines else None


def install_hint(program: str) -> str:
    name = Path(program).name
    for pattern, hint in _HOST_TOOL_HINTS:
        if re.search(pattern, name):
            return hint
    return f"install {name} or put it on PATH"


def format_argv(argv: Sequence[str]) -> str:
    return "+ " + shlex.join(argv)


@dataclass
class Runner:
    """Runs commands for one uros invocation, all logged into ``log_path``."""

    log_path: Path
    verbose: bool = False
    _resolved: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)

    def which(self, program: str, hint: str | None = None, path: str | None = None) -> str:
        """Absolute path of ``program``; MissingToolError naming the fix when absent."""
        key = f"{program}\0{path}"
        if key not in self._resolved:
            found = shutil.which(program, path=path)
            if found is None:
                raise MissingToolError(f"'{program}' was not found on PATH", hint or install_hint(program))
            self._resolved[key] = found
        return self._resolved[key]

    def _log(self, text: str) -> None:
        with self.log_path.open("a", encoding="utf-8") as log:
            log.write(text if text.endswith("\n") else text + "\n")

    def run(
        self,
        argv: Sequence[str],
        *,
        step: str,
        cwd: Path | None = None,
        env: Mapping[str, str] | None = None,
        hint: str | None = None,
        quiet: bool = False,
    ) -> list[str]:
        """Run ``argv`` to completion, streaming its output; return the output lines.

        ``quiet`` keeps the ``+ argv`` echo out of the console (it is always in the log):
        used for the many small queries of the archive check.
        """
        argv = [self.which(argv[0], hint, path=(env or os.environ).get("PATH")), *argv[1:]]
        echo = format_argv(argv)
        self._log(f"\n{echo}" + (f"   (in {cwd})" if cwd else ""))
        if not quiet:
            console.info(echo)
        started = time.monotonic()
        lines: list[str] = []
        try:
            # A new session: Ctrl-C reaches uros first, which then stops the whole tool tree.
            proc = subprocess.Popen(
                list(argv),
                cwd=cwd,
                env=dict(env) if env is not None else None,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                text=True,
                errors="replace",
                start_new_session=True,
            )
        except OSError as exc:
            raise StepFailed(f"{step}: could not start {argv[0]}: {exc}", log=self.log_path) from exc
        try:
            assert proc.stdout is not None
            with self.log_path.open("a", encoding="utf-8") as log:
                for line in proc.stdout:
                    log.write(line)
                    lines.append(line.rstrip("\n"))
                    if self.verbose:
                        console.tool_line(line.rstrip("\n"))
            code = proc.wait()
        except KeyboardInterrupt:
            _stop(proc)
            self._log(f"interrupted after {time.monotonic() - started:.1f} s")
            raise Interrupted(f"{step} was interrupted", "the previous output was left untouched") from None
        self._log(f"exit {code} after {time.monotonic() - started:.1f} s")
        if code != 0:
            cause = first_error(lines)
            detail = f": {cause}" if cause else ""
            raise StepFailed(
                f"{step} failed (exit {code}){detail}",
                hint or f"the full output is in {self.log_path}",
                log=self.log_path,
            )
        return lines


def _stop(proc: subprocess.Popen[str]) -> None:
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
