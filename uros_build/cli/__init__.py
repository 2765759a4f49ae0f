"""The `uros` command line: option parsing, one call into uros_build.commands per command, and the
one place that turns errors into a message and an exit code.

One vocabulary across commands: the target is ``--toolchain`` (a target name, or for `uros build`
also a profile or a .cmake file), a workspace folder is ``-w/--workspace``, what a command writes
goes to ``-o/--output``. Earlier spellings (``--target``, ``--dir``) still work and are hidden.

Each callback imports its command's module (uros_build.commands.X) when it runs, not at the top: a
start imported every command's modules, about 0.2 s of CPU before anything ran (`uros --version`
0.42 -> 0.21 s CPU, measured side by side on this project's 2-core machine), paid by every shell
completion and by each of the test suite's hundreds of `uros` runs. Only what the options
themselves need (the settings table, the export formats) is imported at the top.
"""

from __future__ import annotations

import errno
import signal
import sys
import traceback
from pathlib import Path

import click

from uros_build import __version__, console, proc
from uros_build.cli.agent import RUN_COMMANDS, agent, agent_build, agent_run
from uros_build.cli.build import build, check, clean, doctor, info, size
from uros_build.cli.common import Group
from uros_build.cli.data import (
    EXPORT_COMMANDS,
    distros,
    distros_show,
    export,
    export_arduino,
    interface,
    interface_new,
    meta,
    meta_options,
    meta_write,
    probe,
    targets,
    targets_show,
    toolchain,
    toolchain_render,
)
from uros_build.cli.sources import add_package, create_firmware, update
from uros_build.errors import DiskFull, Signalled, UrosError, interrupted, written_path


@click.group(cls=Group, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="uros")
@click.option("--debug", is_flag=True, help="Show Python tracebacks on errors.")
def cli(debug: bool) -> None:
    """Cross-compile micro-ROS into libmicroros.a, its include tree and a CMake package."""
    # --debug is read by main() from the command line before click runs: it decides how errors
    # that happen during option parsing print too. Declared here for --help and completion.
    del debug


# The one registry: (group, command), in the order `uros --help` lists them.
_REGISTRY: tuple[tuple[click.Group, click.Command], ...] = (
    (cli, build),
    (cli, create_firmware),
    (cli, update),
    (cli, add_package),
    (cli, check),
    (cli, clean),
    (cli, doctor),
    (cli, info),
    (cli, size),
    (cli, probe),
    (cli, agent),
    (agent, agent_build),
    (agent, agent_run),
    *((agent_run, command) for command in RUN_COMMANDS),
    (cli, targets),
    (targets, targets_show),
    (cli, distros),
    (distros, distros_show),
    (cli, toolchain),
    (toolchain, toolchain_render),
    (cli, meta),
    (meta, meta_write),
    (meta, meta_options),
    (cli, export),
    *((export, command) for command in EXPORT_COMMANDS),
    (export, export_arduino),
    (cli, interface),
    (interface, interface_new),
)
for _group, _command in _REGISTRY:
    _group.add_command(_command)


def _internal_error(exc: BaseException) -> None:
    """An exception uros did not expect: one line on the console, the traceback in the run log."""
    log = proc.current_log() or proc.new_run_log(proc.user_log_dir(), "error")
    try:
        with log.open("a", encoding="utf-8") as handle:
            handle.write("\n" + "".join(traceback.format_exception(exc)))
        where = f"the traceback is in {log}"
    except OSError:
        where = "rerun with --debug for the traceback"
    console.error(f"internal error: {type(exc).__name__}: {exc}", f"{where}; please report it")


def _on_signal(signum: int, _frame: object) -> None:
    raise Signalled(signum)


def main(argv: list[str] | None = None) -> None:
    debug = "--debug" in (argv if argv is not None else sys.argv[1:])
    # SIGTERM (`timeout`, a cancelled CI job, `docker stop`) and SIGHUP stop uros like Ctrl-C: the
    # tools it runs are stopped, the previous output stays, and the exit code is 128 + the signal.
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, _on_signal)
    try:
        cli.main(args=argv, prog_name="uros", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        # click turns KeyboardInterrupt into Abort; the signal is on the original exception
        cause = exc if isinstance(exc, KeyboardInterrupt) else exc.__context__
        stopped = interrupted(cause, "interrupted", "the previous output was left untouched")
        console.error(stopped.message, stopped.hint)
        sys.exit(stopped.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except UrosError as exc:
        if debug:
            traceback.print_exc()
        console.error(exc.message, exc.hint)
        sys.exit(exc.exit_code)
    except OSError as exc:
        if debug:
            traceback.print_exc()
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
            _internal_error(exc)
            sys.exit(1)
        # uros's own writes (the log, a staging folder, build-info.json) on a full disk
        where = written_path(exc) or proc.current_log() or Path.cwd()
        full = DiskFull.at(where, f"writing {where}: {exc.strerror}")
        console.error(full.message, full.hint)
        sys.exit(full.exit_code)
    except Exception as exc:
        if debug:
            traceback.print_exc()
        _internal_error(exc)
        sys.exit(1)
    sys.exit(0)
