"""Every error uros reports, with a fixed exit code each.

Only ``cli.main`` formats them: one line saying what is wrong, one line saying what to do.
Modeled on cibuildwheel's errors module: the exit code is a class attribute, so scripts that
call uros can tell a bad flag (2) from a missing compiler (3) from a failed build (4).
"""

from __future__ import annotations

import io
import shutil
import signal
from collections.abc import Iterable, Mapping
from pathlib import Path, PurePath
from types import TracebackType


class UrosError(Exception):
    """Base: a message that names the file or flag, and a hint that names the fix."""

    exit_code = 1

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.hint = hint


class ConfigError(UrosError):
    """Bad input: a flag, a profile, a meta file, a workspace that is not what it should be."""

    exit_code = 2


class MissingToolError(UrosError):
    """A program uros needs is not installed."""

    exit_code = 3


class StepFailed(UrosError):
    """An external command failed; the message names the step and the log to read."""

    exit_code = 4

    def __init__(
        self,
        message: str,
        hint: str | None = None,
        output: tuple[str, ...] = (),
        code: int | None = None,
        cause: str = "",
    ) -> None:
        super().__init__(message, hint)
        self.output = output  # what the command printed, for a caller that can explain it better
        self.code = code  # the command's exit status (None: it did not start)
        self.cause = cause  # the command's own error line (tooltext.first_error), for a caller to quote


class VerifyError(UrosError):
    """The output does not hold what the inputs had (lost archive members, wrong ABI)."""

    exit_code = 5


class DiskFull(UrosError):
    """No space left on a disk (ENOSPC) or over a quota (EDQUOT), anywhere: a failed step like any
    other, named for what it is, with where and how much space is left."""

    exit_code = 4

    @classmethod
    def at(cls, path: Path | str, what: str) -> DiskFull:
        """The error for ``what`` failing on the disk holding ``path`` (asks that disk how much
        space is left)."""
        where = Path(path)
        while not where.exists() and where != where.parent:
            where = where.parent
        try:
            free: int | None = shutil.disk_usage(where).free
        except OSError:
            free = None
        error = cls(disk_full_message(what, str(path), free), DISK_FULL_HINT)
        error.free = free
        return error

    free: int | None = None  # bytes left on that disk, when it could be asked


def file_being_written(tb: TracebackType | None) -> str | None:
    """The file a failed write was writing, read off the traceback: in the innermost frame that holds
    one, the last file object open for writing (pathlib's ``write_text``/``write_bytes`` hold theirs).

    Python sets ``OSError.filename`` only where a path is passed (``open``, ``rename``); a write,
    flush or close that hits a full disk raises ENOSPC without one
    (https://docs.python.org/3/library/exceptions.html#OSError.filename), and guessing the run's
    log instead blamed a disk with 73 GiB free for a full tmpfs (tests/integration/test_faults.py).
    """
    found: str | None = None
    while tb is not None:  # outermost to innermost: the last match is the innermost
        # a file opened for writing (its name and mode stay readable once it is closed, and a
        # failed close closes it too): the last one the function names, the one opened latest
        for value in tb.tb_frame.f_locals.values():
            name, mode = getattr(value, "name", None), str(getattr(value, "mode", ""))
            if isinstance(value, io.IOBase) and isinstance(name, str | PurePath) and set(mode) & set("wax+"):
                found = str(name)
        tb = tb.tb_next
    return found


def written_path(exc: OSError) -> str | None:
    """The file a failed write was writing: a copy's or rename's destination (``filename2``: shutil's
    sendfile copy puts the *source* in ``filename`` and the destination there,
    https://github.com/python/cpython/blob/3.11/Lib/shutil.py `_fastcopy_sendfile`), else the path
    the call named, else the file off the traceback (a write names none)."""
    for name in (exc.filename2, exc.filename):
        if isinstance(name, str | bytes | PurePath) and str(name):
            return name.decode() if isinstance(name, bytes) else str(name)
    return file_being_written(exc.__traceback__)


DISK_FULL_HINT = (
    "free some space (or build on a larger disk) and run the same command again: "
    "uros repairs what the full disk cut short"
)


def disk_full_message(what: str, path: str, free: int | None) -> str:
    """One line: what failed, where, and the space left there (pure)."""
    left = "unknown space" if free is None else _size(free)
    return f"no space left on device: {what} ({left} free on the disk of {path})"


def _size(n: int) -> str:
    if n < 1024:
        return f"{n} bytes"
    value = n / 1024
    for unit in ("KiB", "MiB", "GiB"):
        if value < 1024:
            return f"{value:.1f} {unit}"
        value /= 1024
    return f"{value:.1f} TiB"


class Interrupted(UrosError):
    """Ctrl-C (SIGINT): the previous good output was left in place."""

    exit_code = 130
    signal_name = "Ctrl-C"


class Terminated(Interrupted):
    """SIGTERM (`timeout`, a CI job cancelled, `docker stop`): stopped like Ctrl-C; 128 + 15."""

    exit_code = 143
    signal_name = "SIGTERM"


class HungUp(Interrupted):
    """SIGHUP (the terminal closed): stopped like Ctrl-C; 128 + 1."""

    exit_code = 129
    signal_name = "SIGHUP"


class Signalled(KeyboardInterrupt):
    """SIGTERM or SIGHUP raised where uros is, like Python raises KeyboardInterrupt for SIGINT, so
    that every place that stops the tools on Ctrl-C stops them on these too."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


_BY_SIGNAL: Mapping[int, type[Interrupted]] = {signal.SIGTERM: Terminated, signal.SIGHUP: HungUp}


def interrupted(cause: BaseException | None, what: str, hint: str) -> Interrupted:
    """The error for ``what`` stopped by the signal behind ``cause`` (Ctrl-C when it names none)."""
    cls = _BY_SIGNAL.get(getattr(cause, "signum", signal.SIGINT), Interrupted)
    return cls(f"{what} ({cls.signal_name})", hint)


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """`` (did you mean X or Y?)`` for the names closest to a typo, else ``""``."""
    import difflib  # on a typo only: every start imports this module (start-up cost)

    near = difflib.get_close_matches(name, list(choices), n=3, cutoff=0.6)
    if not near:
        return ""
    return (
        f" (did you mean {', '.join(near[:-1])} or {near[-1]}?)"
        if len(near) > 1
        else f" (did you mean {near[0]}?)"
    )
