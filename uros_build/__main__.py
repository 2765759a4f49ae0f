"""The `uros` program: `python -m uros_build` and the console script both start here.

Importing the CLI (click, rich, jinja2, every command) takes a noticeable fraction of a second; a
Ctrl-C in that window raised KeyboardInterrupt before `cli.main` could catch anything and printed
a traceback (issue 16). So this module imports nothing heavy until it stands guard, and runs as
little as it can before: no import at all at its top (a `from __future__` import there is a real
import, and a Ctrl-C landing in it under load was a traceback naming this file).
"""


def run() -> None:
    try:
        from uros_build.cli import main
    except KeyboardInterrupt:
        _interrupted()
    except RuntimeError as exc:
        # A Ctrl-C inside a class body's __set_name__ (a cached_property of a module being
        # imported: ipaddress, functools) reaches us wrapped in RuntimeError (Python 3.11).
        if isinstance(exc.__cause__, KeyboardInterrupt):
            _interrupted()
        raise
    main()


def _interrupted() -> None:
    import sys

    sys.stderr.write("error: interrupted\n")
    sys.exit(130)


if __name__ == "__main__":
    run()
