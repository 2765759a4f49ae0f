"""What one `uros` start costs, for two checkouts side by side (recorded in docs/benchmarks.md).

    python benchmarks/startup.py /work/main /work/wt/NAME [-n 20] [--dir DIR]

Each checkout runs as `python -m uros_build` with this interpreter and the checkout first on
PYTHONPATH (so both use the same installed click, rich, jinja2 and PyYAML), compiled modules kept in
a pycache prefix of the run's own (as the test suite keeps them: tests/conftest.py). Each gets its
own fixture workspace (tests/fixture_ws.py, the checkout's), built once for cortex-m7 before timing
(uros's own code is in the build key, so one checkout's build is not up to date for the other).

Timed, N rounds, the two checkouts interleaved in each round (the machine is shared: only their
ratio counts), the CPU of the child (user + system, resource.getrusage of children, which includes
what uros starts: the shim's answers, ccache, ...):

* `uros --version`;
* `uros build` of the fixture, up to date (the run fails unless it says so);
* `uros info OUTPUT`;
* `uros export pkg-config --from OUTPUT -o DIR`;
* `uros size OUTPUT` and `uros check OUTPUT/libmicroros.a --toolchain cortex-m7` (with the tools they
  run: size, nm, readelf).

Prints a Markdown table: the median CPU and the median wall of each command for each checkout, and
after/before of the medians. Each command's output must be the same for both checkouts (the
workspace's path, the run log's name and the build key aside), else the run says so and exits 1.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run_env(checkout: Path, pycache: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(checkout)
    env["PYTHONPYCACHEPREFIX"] = str(pycache)
    env["NO_COLOR"] = "1"
    return env


def make_workspace(checkout: Path, folder: Path) -> list[str]:
    """The checkout's fixture workspace in ``folder`` and its `uros build` arguments."""
    code = (
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]);"
        "from fixture_ws import make_fixture_workspace, fixture_build_args;"
        "print('\\n'.join(fixture_build_args(make_fixture_workspace(Path(sys.argv[2])))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(checkout / "tests"), str(folder)],
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.splitlines()


def timed(argv: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float, str, int]:
    """CPU seconds (user + system of the child and what it started), wall seconds, output, exit code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, proc.stdout + proc.stderr, proc.returncode


def normalised(text: str, ws: Path, tmp: Path) -> str:
    text = text.replace(str(ws), "WS").replace(str(tmp), "TMP")
    text = re.sub(r"\d{8}-\d{6}-[\w.-]+-\d+\.log", "RUN.log", text)  # the run log's name
    text = re.sub(r"\b[0-9a-f]{64}\b", "KEY", text)  # the build key: uros's own code is in it
    return re.sub(r"\(\d+(\.\d+)? s\)", "(T s)", text)


def side_by_side_args(doc: str | None, rounds: int, prefix: str) -> tuple[argparse.Namespace, Path]:
    """The command line of a two-checkout comparison (this one, cold_build.py) and its folder."""
    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path, help="the checkout measured first (e.g. /work/main)")
    parser.add_argument("after", type=Path, help="the checkout compared with it")
    parser.add_argument("-n", type=int, default=rounds, help=f"rounds (default {rounds})")
    parser.add_argument("--dir", type=Path, help="where the workspaces go (default: a temporary folder)")
    args = parser.parse_args()
    return args, args.dir or Path(tempfile.mkdtemp(prefix=prefix))


def main() -> int:
    args, root = side_by_side_args(__doc__, 20, "uros-startup-")
    checkouts = {"before": args.before.resolve(), "after": args.after.resolve()}
    setups = {}
    for name, checkout in checkouts.items():
        ws = root / name / "ws"
        build = make_workspace(checkout, ws)
        env = run_env(checkout, root / name / "pycache")
        out = ws / "build" / "cortex-m7"
        uros = [sys.executable, "-m", "uros_build"]
        commands = {
            "uros --version": [*uros, "--version"],
            "uros build (up to date)": [*uros, *build],
            "uros info OUTPUT": [*uros, "info", str(out)],
            "uros export pkg-config": [
                *uros,
                "export",
                "pkg-config",
                "--from",
                str(out),
                "-o",
                str(root / name / "pc"),
            ],
            "uros size OUTPUT": [*uros, "size", str(out)],
            "uros check LIBRARY": [*uros, "check", str(out / "libmicroros.a"), "--toolchain", "cortex-m7"],
        }
        cpu, wall, text, code = timed(commands["uros build (up to date)"], env, root)
        if code != 0:
            sys.exit(f"{name}: the fixture's first build failed ({code}):\n{text}")
        print(f"{name}: {checkout}: fixture built ({cpu:.1f} s CPU, {wall:.1f} s)", file=sys.stderr)
        for argv in commands.values():  # compiled modules written, the build's caches warm
            timed(argv, env, root)
        setups[name] = (env, commands, ws)
    cpu: dict[tuple[str, str], list[float]] = {}
    wall: dict[tuple[str, str], list[float]] = {}
    seen: dict[str, dict[str, str]] = {}
    for _ in range(args.n):
        for command in setups["before"][1]:
            for name, (env, commands, ws) in setups.items():
                c, w, text, code = timed(commands[command], env, root)
                if code != 0 or (command.startswith("uros build") and "up to date" not in text):
                    sys.exit(f"{name}: {command} failed or was not up to date ({code}):\n{text}")
                cpu.setdefault((name, command), []).append(c)
                wall.setdefault((name, command), []).append(w)
                seen.setdefault(command, {})[name] = normalised(text, ws, root / name)
    print(
        f"{args.n} rounds, CPU (user + system, with what uros starts) and wall, median; {os.uname().machine}, "
        f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}, Python {sys.version.split()[0]}"
    )
    print()
    print("| command | before CPU s | after CPU s | after/before | before wall s | after wall s |")
    print("|---|---|---|---|---|---|")
    for command in setups["before"][1]:
        b, a = (statistics.median(cpu[(n, command)]) for n in ("before", "after"))
        bw, aw = (statistics.median(wall[(n, command)]) for n in ("before", "after"))
        print(f"| `{command}` | {b:.3f} | {a:.3f} | {a / b:.2f} | {bw:.3f} | {aw:.3f} |")
    differ = [c for c, outs in seen.items() if outs["before"] != outs["after"]]
    for command in differ:
        print(
            f"\n{command}: the output differs:\n--- before\n{seen[command]['before']}--- after\n{seen[command]['after']}"
        )
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
