"""What a cold `uros build` of the fixture costs uros itself, for two checkouts side by side
(recorded in docs/benchmarks.md; benchmarks/startup.py does the same for starts that build nothing).

    python benchmarks/cold_build.py /work/main /work/wt/NAME [-n 7] [--dir DIR]

Each checkout gets its own fixture workspace (tests/fixture_ws.py, the checkout's) and runs as
`python -m uros_build` with this interpreter and the checkout first on PYTHONPATH, compiled modules
kept in a pycache prefix of its own, as tests/conftest.py keeps them. Each round removes the
workspace's `.uros` and `build` folders (a first build: every package configured and compiled,
every lock file and the toolchain's render made) and builds, the two checkouts interleaved (the
machine is shared: only their ratio counts). Measured per build: the uros process's own CPU (user +
system, read by the process itself at its exit) and that of everything it started (colcon, CMake,
the compilers, ...).

Prints a Markdown table of the medians, and whether the two checkouts' libraries are the same bytes
and their build-info.json the same once the build key (uros's code is in it) is set aside; exits 1
when they are not.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

from startup import make_workspace, run_env, side_by_side_args

# Runs uros in this process and writes its own CPU and its children's at the exit.
_WRAPPER = """
import atexit, resource, runpy, sys
out = sys.argv.pop(1)
def report():
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(out, "w") as f:
        f.write(f"{s.ru_utime + s.ru_stime} {c.ru_utime + c.ru_stime}")
atexit.register(report)
sys.argv = ["uros_build", *sys.argv[1:]]
runpy.run_module("uros_build", run_name="__main__", alter_sys=True)
"""


def cold_build(ws: Path, build: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    for folder in (ws / ".uros", ws / "build"):
        shutil.rmtree(folder, ignore_errors=True)
    out = cwd / "cpu.txt"
    proc = subprocess.run(
        [sys.executable, "-c", _WRAPPER, str(out), *build], env=env, cwd=cwd, capture_output=True, text=True
    )
    if proc.returncode != 0 or "==> built " not in proc.stderr:
        sys.exit(f"{ws}: the cold build failed ({proc.returncode}):\n{proc.stdout}{proc.stderr}")
    own, children = (float(x) for x in out.read_text().split())
    return own, children


def built(ws: Path) -> tuple[bytes, dict[str, object]]:
    out = ws / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    info.pop("build_key", None)
    text = json.dumps(info, sort_keys=True).replace(str(ws), "WS")
    return (out / "libmicroros.a").read_bytes(), json.loads(text)


def main() -> int:
    args, root = side_by_side_args(__doc__, 7, "uros-cold-")
    setups = {}
    for name, checkout in (("before", args.before.resolve()), ("after", args.after.resolve())):
        ws = root / name / "ws"
        build = make_workspace(checkout, ws)
        env = run_env(checkout, root / name / "pycache")
        cold_build(ws, build, env, root / name)  # compiled modules written, ccache and the caches warm
        setups[name] = (ws, build, env)
    own: dict[str, list[float]] = {"before": [], "after": []}
    children: dict[str, list[float]] = {"before": [], "after": []}
    for _ in range(args.n):
        for name, (ws, build, env) in setups.items():
            o, c = cold_build(ws, build, env, root / name)
            own[name].append(o)
            children[name].append(c)
    print(
        f"{args.n} rounds, CPU s (user + system), median; {os.uname().machine}, {os.cpu_count()} cores, "
        f"load {os.getloadavg()[0]:.1f}, Python {sys.version.split()[0]}"
    )
    print()
    print("| cold `uros build` of the fixture | before | after | after/before |")
    print("|---|---|---|---|")
    rows = {
        "uros itself": (own["before"], own["after"]),
        "what it started": (children["before"], children["after"]),
        "both": (
            [o + c for o, c in zip(own["before"], children["before"], strict=True)],
            [o + c for o, c in zip(own["after"], children["after"], strict=True)],
        ),
    }
    for label, (b_values, a_values) in rows.items():
        b, a = statistics.median(b_values), statistics.median(a_values)
        print(f"| {label} | {b:.3f} | {a:.3f} | {a / b:.2f} |")
    same = built(setups["before"][0]) == built(setups["after"][0])
    print(f"\nthe same library bytes and build-info.json (build key aside): {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
