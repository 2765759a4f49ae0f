"""The one home of how uros writes, replaces, removes and locks files, and asks whether a process
is still there (issue 30, item 5).

- A file is written whole or not at all (:func:`write_atomic`): written beside itself, in the same
  folder (a rename never crosses a file system), under a hidden name that says uros and the writer's
  process id (:func:`temp_path`: two writers never share one, and what a killed writer left is found
  by its pid, :func:`leftover_temps`), then renamed into place. A reader sees the old file, none, or
  the new one.
- A generated file is written only when its content differs (:func:`write_if_changed`), so CMake and
  ninja see no change and rebuild nothing.
- A tree uros wrote is removed even where read-only folders are in it (:func:`remove_tree`).
- One run at a time holds a folder's lock (:func:`locked`), and says whom a waiting run waits for.

The Python shim imports this module on every generator run (shim/gencache.py), where each import
costs time: at the top only os and sys (Python's start imports them; contextlib it does not, in a
virtual environment: it brings collections and functools), the rest inside the functions that need it.
"""

from __future__ import annotations

import os
import sys

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from contextlib import AbstractContextManager
    from pathlib import Path
    from typing import Any, TypeAlias

    StrPath: TypeAlias = "str | os.PathLike[str]"

# The middle of every temporary name: `.<name>.uros-<pid>`.
TEMP_INFIX = ".uros-"
LOCK_FILE = ".lock"
LOCK_OWNER = ".lock.owner"


def temp_path(path: StrPath, pid: int | None = None) -> str:
    """Where ``path`` is written before it is renamed into place (pure): ``.<name>.uros-<pid>`` in
    the same folder."""
    folder, name = os.path.split(os.fspath(path))
    return os.path.join(folder, f".{name}{TEMP_INFIX}{os.getpid() if pid is None else pid}")


def temp_pid(path: StrPath, name: str) -> int | None:
    """The writer's pid when ``name`` is one of ``path``'s temporary names (pure)."""
    prefix = f".{os.path.basename(os.fspath(path))}{TEMP_INFIX}"
    pid = name[len(prefix) :] if name.startswith(prefix) else ""
    return int(pid) if pid.isdigit() else None


def leftover_temps(path: StrPath) -> list[str]:
    """``path``'s temporary files whose writers are gone (a run killed before its rename)."""
    folder = os.path.dirname(os.fspath(path)) or "."
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    return [
        os.path.join(folder, name)
        for name in names
        if (pid := temp_pid(path, name)) is not None and not pid_alive(pid)
    ]


def write_atomic(path: StrPath, data: str | bytes, *, sync: bool = False) -> None:
    """Write ``path`` whole or not at all, making its folder; text as UTF-8. ``sync``: the data is on
    the disk before the rename, for a file a crash must not leave empty (the swap's journal). The
    temporary file is removed when the write fails."""
    target = os.fspath(path)
    folder = os.path.dirname(target)
    if folder:
        os.makedirs(folder, exist_ok=True)
    tmp = temp_path(target)
    try:
        with open(tmp, "wb") as handle:
            # text as Path.write_text writes it (newlines as the platform writes them)
            handle.write(data if isinstance(data, bytes) else data.replace("\n", os.linesep).encode("utf-8"))
            if sync:
                handle.flush()
                os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        try:  # noqa: SIM105 (contextlib would cost the shim an import)
            os.unlink(tmp)
        except OSError:
            pass
        raise


def write_if_changed(path: StrPath, data: str | bytes) -> bool:
    """Write ``path`` (atomically) only when its content differs; whether it was written."""
    try:
        if isinstance(data, bytes):
            with open(path, "rb") as handle:
                same = handle.read() == data
        else:
            with open(path, encoding="utf-8") as handle:
                same = handle.read() == data
    except (OSError, UnicodeDecodeError):
        same = False
    if same:
        return False
    write_atomic(path, data)
    return True


def _open_regular(path: StrPath, limit: int) -> int:
    """A descriptor of ``path`` opened for reading, only when it is a regular file of at most
    ``limit`` bytes: O_NONBLOCK, so that a FIFO put in its place opens at once and is refused, never
    waits for a writer; /dev/zero (a device) never ends, so it is refused too. FileNotFoundError
    when it is not there; another OSError, with a reason as its strerror, when it cannot be read."""
    import errno
    import stat

    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise OSError(errno.EINVAL, "not a regular file")
        if info.st_size > limit:
            raise OSError(errno.EFBIG, f"{info.st_size:,} bytes, more than the {limit:,} expected")
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_regular(path: StrPath, limit: int) -> bytes:
    """The bytes of ``path``, a regular file of at most ``limit`` bytes (the one bounded reader of
    files others can put there: a team cache's entries, a probe's report): OSError otherwise (see
    :func:`_open_regular`; a file that grows past ``limit`` while read is refused too)."""
    import errno

    fd = _open_regular(path, limit)
    try:
        with open(fd, "rb", closefd=False) as handle:
            data = handle.read(limit + 1)
    finally:
        os.close(fd)
    if len(data) > limit:
        raise OSError(errno.EFBIG, f"more than the {limit:,} bytes expected")
    return data


def sha256_regular(path: StrPath, limit: int) -> str:
    """The sha256 of ``path``'s content, read as :func:`read_regular` reads (a regular file of at
    most ``limit`` bytes), in pieces: a library of hundreds of MB is never held whole."""
    import errno
    import hashlib

    fd = _open_regular(path, limit)
    digest, seen = hashlib.sha256(), 0
    try:
        with open(fd, "rb", closefd=False) as handle:
            while chunk := handle.read(1 << 20):
                seen += len(chunk)
                if seen > limit:
                    raise OSError(errno.EFBIG, f"more than the {limit:,} bytes expected")
                digest.update(chunk)
    finally:
        os.close(fd)
    return digest.hexdigest()


def reason(exc: BaseException) -> str:
    """An OSError's reason as a message says it (its strerror), else the exception's text."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return str(exc) or type(exc).__name__


def link_atomic(path: StrPath, target: str) -> None:
    """Make ``path`` a symbolic link to ``target``, replacing what was there in one rename.
    OSError where the folder holds no links (some mounts)."""
    tmp = temp_path(path)
    try:  # noqa: SIM105 (contextlib would cost the shim an import)
        os.unlink(tmp)
    except FileNotFoundError:
        pass
    os.symlink(target, tmp)
    os.replace(tmp, path)


def remove_tree(path: StrPath) -> str | None:
    """Remove a file or folder uros wrote, making read-only folders in it writable first (an
    output copied from a read-only store); the reason when some of it could not be removed."""
    import contextlib
    import shutil
    import stat

    def retry(func: Callable[..., Any], name: str, _exc: BaseException) -> None:
        parent = os.path.dirname(name)
        with contextlib.suppress(OSError):
            os.chmod(parent, os.stat(parent).st_mode | stat.S_IWUSR | stat.S_IXUSR)
        func(name)

    target = os.fspath(path)
    try:
        if os.path.isdir(target) and not os.path.islink(target):
            if sys.version_info >= (3, 12):
                shutil.rmtree(target, onexc=retry)
            else:
                shutil.rmtree(target, onerror=lambda func, name, info: retry(func, name, info[1]))
        elif os.path.lexists(target):
            os.unlink(target)
    except OSError as exc:
        return f"{exc.filename or target} ({exc.strerror or exc})"
    return None


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` is still there (this process is; another user's is)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    return True


def lock_holder(text: str) -> int | None:
    """The process id a lock's owner file names (pure)."""
    first = text.split("\n", 1)[0].strip()
    return int(first) if first.isdigit() else None


def locked(folder: StrPath, what: str, command: str = "uros build") -> AbstractContextManager[None]:
    """One uros run at a time holds ``folder``'s lock (a target's trees, the host stage, an output's
    writers); a second waits. filelock takes an OS lock on ``<folder>/.lock`` (flock on POSIX, msvcrt
    on Windows), which the OS releases when the process ends, however it ends. The holder writes its
    process id beside it (filelock truncates the lock file itself), so that a waiting run can say
    whom it waits for. The folder is made when there is none."""
    import contextlib

    return contextlib.contextmanager(_held)(folder, what, command)


def _flock_free(lock_path: str) -> int | None:
    """The lock taken with one flock, when it is free and nothing about its file is unusual: a
    regular file of this user's, opened without following a link, or made here as filelock makes
    one where flock works (O_EXCL, mode 0o666 less the umask). None (nothing held): filelock takes
    it, with all its care (a symlink, another user's file, a file system without flock, waiting).
    Both flock the same file, so a run that takes it here and one that takes it through filelock
    exclude each other; this spares a start importing filelock (~0.03 s of CPU, a tenth of it)."""
    if sys.platform == "win32":
        return None
    import fcntl
    import stat

    flags = os.O_RDWR | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        try:
            fd = os.open(lock_path, flags)
        except FileNotFoundError:
            fd = os.open(lock_path, flags | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        found = os.fstat(fd)
        if stat.S_ISREG(found.st_mode) and found.st_nlink > 0 and found.st_uid == os.geteuid():
            return fd
    except OSError:
        pass
    os.close(fd)  # closing the file releases a flock it holds
    return None


def _held(folder: StrPath, what: str, command: str) -> Iterator[None]:
    from pathlib import Path

    from uros_build.errors import ConfigError

    base = Path(folder)
    base.mkdir(parents=True, exist_ok=True)
    lock_path = base / LOCK_FILE
    if lock_path.is_dir() and not lock_path.is_symlink():
        raise ConfigError(
            f"{lock_path}: is a folder, where uros keeps the lock file of {what}",
            "move it away (uros does not remove what it did not write), then run the command again",
        )
    owner = base / LOCK_OWNER
    fd = _flock_free(str(lock_path))
    if fd is not None:
        try:
            owner.write_text(f"{os.getpid()}\n", encoding="utf-8")
            yield
        finally:
            os.close(fd)  # the flock goes with the file's last descriptor
        return
    yield from _held_by_filelock(lock_path, owner, what, command)


def _held_by_filelock(lock_path: Path, owner: Path, what: str, command: str) -> Iterator[None]:
    import filelock

    from uros_build import console

    lock = filelock.FileLock(str(lock_path))
    try:
        lock.acquire(timeout=0)
    except filelock.Timeout:
        try:
            holder = lock_holder(owner.read_text(encoding="utf-8"))
        except OSError:
            holder = None
        who = f" (pid {holder})" if holder else ""
        console.info(f"waiting for another {command} of {what}{who} to finish (lock: {lock_path})")
        lock.acquire()
    try:
        owner.write_text(f"{os.getpid()}\n", encoding="utf-8")
        yield
    finally:
        lock.release()
