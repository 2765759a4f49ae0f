"""Per-call costs inside a built target, side by side (recorded in docs/benchmarks.md).

    python benchmarks/call_costs.py WORKSPACE/.uros/targets/TARGET [--package std_msgs] [--rounds 2]

Prints, for one built package of the target: its compiles run one after another without ccache, with
ccache in its usual mode and in its depend mode (each ccache mode with an empty cache of its own, so
every compile misses, as on a new target); and the cost of one Python start as CMake's FindPython asks
it, through the target's uros-python (answered by the shell) and through the interpreter itself; and
the start of a call uros-python sends to uros's caches, with its modules compiled each time
(PYTHONDONTWRITEBYTECODE=1) and kept in a pycache_prefix folder (what the shim does). --rounds 0 skips
the compiles.
Objects are written beside the package's own with a .bench suffix and removed after.
"""

from __future__ import annotations

import argparse
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from uros_build.shim import pyshim  # noqa: E402


def compile_commands(build: Path) -> list[list[str]]:
    out = subprocess.run(
        ["ninja", "-C", str(build), "-t", "commands"], capture_output=True, text=True, check=True
    )
    commands = []
    for line in out.stdout.splitlines():
        argv = shlex.split(line)
        if "-c" in argv and any(a.endswith((".obj", ".o")) for a in argv):
            commands.append(argv)
    return commands


def run_all(commands: list[list[str]], build: Path, mode: str) -> float:
    env = dict(os.environ)
    for name in ("CCACHE_DEPEND", "CCACHE_DISABLE"):
        env.pop(name, None)
    if mode != "none":
        env["CCACHE_DIR"] = tempfile.mkdtemp(prefix="uros-bench-ccache-")
    if mode == "ccache depend":
        env["CCACHE_DEPEND"] = "true"
    written = []
    started = time.monotonic()
    for argv in commands:
        argv = [a for a in argv]
        if argv[0].endswith("ccache"):
            argv = argv[1:]
        if mode != "none":
            argv = ["ccache", *argv]
        o = argv.index("-o")
        argv[o + 1] += ".bench"
        written.append(build / argv[o + 1])
        subprocess.run(argv, cwd=build, env=env, check=True, capture_output=True)
    took = time.monotonic() - started
    for path in written:
        path.unlink(missing_ok=True)
    return took


def start_cost(argv: list[str], n: int = 15, env: dict[str, str] | None = None) -> float:
    times = []
    for _ in range(n):
        started = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True, env=env)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("target", type=Path, help="a built target's folder: WORKSPACE/.uros/targets/TARGET")
    parser.add_argument("--package", default="std_msgs")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    build = args.target / "build" / args.package
    commands = compile_commands(build)
    print(f"machine: {os.cpu_count()} cores; {len(commands)} compiles of {args.package}, one after another")
    print("| round | without ccache | ccache, usual mode (all miss) | ccache, depend mode (all miss) |")
    print("|---|---|---|---|")
    for i in range(args.rounds):
        row = [run_all(commands, build, m) for m in ("none", "ccache usual", "ccache depend")]
        print(f"| {i + 1} | " + " | ".join(f"{t:.2f} s" for t in row) + " |")
    shim = args.target / "uros-python"
    python = shim.read_text().rstrip().splitlines()[-1].split()[1]
    question = pyshim.FINDPYTHON_QUESTIONS[0]
    print()
    print("| one Python start (median of 15) | seconds |")
    print("|---|---|")
    print(f"| `python -c pass` | {start_cost([python, '-c', 'pass']):.4f} |")
    print(f"| FindPython's version question, interpreter | {start_cost([python, '-c', question]):.4f} |")
    print(f"| FindPython's version question, uros-python | {start_cost([str(shim), '-c', question]):.4f} |")
    # what each call uros-python sends to uros's caches does first: start and import the cache modules
    # (PYTHONDONTWRITEBYTECODE=1, as on this machine: compiled each time, or kept in a pycache_prefix)
    entry = f"import sys; sys.path.append({str(HERE.parent)!r}); import uros_build.shim.pyshim"
    plain = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    kept = {**os.environ, "PYTHONDONTWRITEBYTECODE": ""}
    prefix = tempfile.mkdtemp(prefix="uros-bench-pycache-")
    subprocess.run([python, "-X", f"pycache_prefix={prefix}", "-c", entry], env=kept, check=True)
    print(
        f"| a cache call's start, modules compiled each time | {start_cost([python, '-c', entry], env=plain):.4f} |"
    )
    with_prefix = [python, "-X", f"pycache_prefix={prefix}", "-c", entry]
    print(
        f"| a cache call's start, compiled modules kept (pycache_prefix) | {start_cost(with_prefix, env=kept):.4f} |"
    )


if __name__ == "__main__":
    main()
