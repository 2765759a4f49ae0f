"""What colcon costs in a `uros build` of the fixture, for two checkouts side by side (recorded in
docs/benchmarks.md).

    python benchmarks/colcon_cpu.py /work/wt/BEFORE /work/wt/AFTER [-n 5] [--dir DIR]

Each checkout runs as `python -m uros_build` with this interpreter and the checkout first on
PYTHONPATH (so both use the same installed colcon and its extensions), compiled modules kept in a
pycache prefix of the run's own (one untimed build each fills it first). N rounds, the two checkouts interleaved (A B, then B A: the machine
is shared, only their ratio counts); in each, for each checkout:

* a cold `uros build` of a new fixture workspace (tests/fixture_ws.py, this checkout's) and the same
  build again with only its output folder removed (colcon runs again over its trees: "rebuilt"),
  each timed as the CPU of everything it started (user + system, resource.getrusage of children);
* colcon alone: the command and the environment that build's colcon ran with, read from its run log,
  run again under a small wrapper that reports colcon's own CPU (its Python: RUSAGE_SELF) and that of
  what it started (cmake, ninja, sh: RUSAGE_CHILDREN), over trees removed first ("cold") and over the
  trees it left ("rebuilt").

Prints a Markdown table of the medians, and after/before. Each cold build's library must have the
same bytes for both checkouts, else the run says so and exits 1.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from startup import run_env  # the checkout first on PYTHONPATH, its own pycache prefix

# run as `python - ARGS...`: colcon_core's main with its own CPU and its children's reported last
WRAPPER = """
import atexit, resource, sys
def report():
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    sys.__stderr__.write(f"COLCON-CPU {own.ru_utime + own.ru_stime} {kids.ru_utime + kids.ru_stime}\\n")
atexit.register(report)
from colcon_core.command import main
sys.argv = ["colcon", *sys.argv[1:]]
sys.exit(main())
"""


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def uros_build(checkout: Path, ws: Path, env: dict[str, str]) -> float:
    """One `uros build` of the fixture workspace ``ws``: the CPU of it and all it started."""
    argv = [sys.executable, "-m", "uros_build", "build", "--toolchain", "cortex-m7", "--workspace", str(ws)]
    argv += ["--meta", str(ws / "fixture.meta")]
    before = children_cpu()
    # in the workspace: `python -m` puts the working folder first on sys.path, before PYTHONPATH
    subprocess.run(argv, env=env, cwd=ws, check=True, capture_output=True)
    return children_cpu() - before


def colcon_command(ws: Path) -> tuple[list[str], dict[str, str], Path]:
    """The target's colcon command, its environment and its folder, from the build's run log (the
    environment as proc.py logs it: the difference from uros's own, under the command)."""
    lines = (ws / ".uros" / "log" / "latest.log").read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("+ ") and " build --base-paths " in line)
    command, _, cwd = lines[at][2:].rpartition("   (in ")
    env = dict(os.environ)
    for line in lines[at + 1 :]:
        if not line.startswith("  export "):
            break
        name, _, value = line.removeprefix("  export ").partition("=")
        env[name] = value
    env["PYTHONUNBUFFERED"] = "1"  # as uros's colcon_setup.environment sets it
    return shlex.split(command), env, Path(cwd.rstrip(")"))


def colcon_alone(ws: Path, cold: bool) -> tuple[float, float]:
    """colcon's own CPU and its children's, its command run again (over removed trees if ``cold``)."""
    argv, env, cwd = colcon_command(ws)
    target = Path(argv[argv.index("--log-base") + 1]).parent
    if cold:
        for tree in ("build", "install", "log"):
            shutil.rmtree(target / tree, ignore_errors=True)
    python = Path(argv[0]).with_name("python3")  # the colcon script's own interpreter
    done = subprocess.run(
        [str(python), "-", *argv[1:]],
        input=WRAPPER,
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        check=True,
    )
    own, kids = done.stderr.strip().splitlines()[-1].split()[1:]
    return float(own), float(kids)


def _fixture(checkout: Path, root: Path) -> None:
    """The checkout's fixture workspace (tests/fixture_ws.py) in ``root``."""
    sys.path.insert(0, str(checkout / "tests"))
    try:
        from fixture_ws import make_fixture_workspace
    finally:
        sys.path.pop(0)
    make_fixture_workspace(root)


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


ROWS = (
    ("cold `uros build`: everything it started", "cold"),
    ("rebuilt `uros build` (output folder removed): everything it started", "rebuilt"),
    ("colcon alone, cold trees: colcon's own Python", "colcon cold own"),
    ("colcon alone, cold trees: what colcon started", "colcon cold children"),
    ("colcon alone, over its trees: colcon's own Python", "colcon warm own"),
    ("colcon alone, over its trees: what colcon started", "colcon warm children"),
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("-n", type=int, default=5)
    parser.add_argument("--dir", type=Path, default=None)
    args = parser.parse_args()
    top = args.dir or Path(tempfile.mkdtemp(prefix="uros-colcon-cpu-"))
    top.mkdir(parents=True, exist_ok=True)
    checkouts = {"before": args.before.resolve(), "after": args.after.resolve()}
    times: dict[str, dict[str, list[float]]] = {k: {key: [] for _, key in ROWS} for k in checkouts}
    libraries: dict[str, set[str]] = {k: set() for k in checkouts}
    for name, checkout in checkouts.items():  # untimed: each checkout's modules compiled into its pycache
        root = top / name / "warm-up"
        shutil.rmtree(root, ignore_errors=True)
        _fixture(checkout, root)
        uros_build(checkout, root, run_env(checkout, top / name / "pycache"))
    for round_ in range(args.n):
        order = list(checkouts) if round_ % 2 == 0 else list(reversed(checkouts))
        for name in order:
            checkout = checkouts[name]
            root = top / name / f"round{round_}"
            shutil.rmtree(root, ignore_errors=True)
            _fixture(checkout, root)
            env = run_env(checkout, top / name / "pycache")
            got = times[name]
            got["cold"].append(uros_build(checkout, root, env))
            libraries[name].add(sha256(root / "build" / "cortex-m7" / "libmicroros.a"))
            shutil.rmtree(root / "build" / "cortex-m7")
            got["rebuilt"].append(uros_build(checkout, root, env))
            own, kids = colcon_alone(root, cold=True)
            got["colcon cold own"].append(own)
            got["colcon cold children"].append(kids)
            own, kids = colcon_alone(root, cold=False)
            got["colcon warm own"].append(own)
            got["colcon warm children"].append(kids)
            print(
                f"round {round_ + 1} {name}: " + ", ".join(f"{k} {v[-1]:.2f}" for k, v in got.items()),
                flush=True,
            )
    print(
        f"\nCPU seconds (user + system), median of {args.n}; {checkouts['before']} vs {checkouts['after']}\n"
    )
    print("| what | before | after | after/before |")
    print("|---|---|---|---|")
    for label, key in ROWS:
        a, b = statistics.median(times["before"][key]), statistics.median(times["after"][key])
        print(f"| {label} | {a:.2f} s | {b:.2f} s | {b / a:.2f} |")
    print(f"\nlibraries: before {sorted(libraries['before'])}, after {sorted(libraries['after'])}")
    if len(libraries["before"] | libraries["after"]) != 1:
        print("the libraries differ")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
