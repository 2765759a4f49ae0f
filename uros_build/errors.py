"""Every error uros reports, with a fixed exit code each.

Only ``cli.main`` formats them: one line saying what is wrong, one line saying what to do.
Modeled on cibuildwheel's errors module: the exit code is a class attribute, so scripts that
call uros can tell a bad flag (2) from a missing compiler (3) from a failed build (4).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


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

    def __init__(self, message: str, hint: str | None = None, output: tuple[str, ...] = ()) -> None:
        super().__init__(message, hint)
        self.output = output  # what the command printed, for a caller that can explain it better


class VerifyError(UrosError):
    """The output does not hold what the inputs had (lost archive members, wrong ABI)."""

    exit_code = 5


class Interrupted(UrosError):
    """Ctrl-C: the previous good output was left in place."""

    exit_code = 130


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """`` (did you mean X or Y?)`` for the names closest to a typo, else ``""``."""
    near = difflib.get_close_matches(name, list(choices), n=3, cutoff=0.6)
    if not near:
        return ""
    return (
        f" (did you mean {', '.join(near[:-1])} or {near[-1]}?)"
        if len(near) > 1
        else f" (did you mean {near[0]}?)"
    )
