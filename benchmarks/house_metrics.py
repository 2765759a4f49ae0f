"""Figures of the house (issues 30, 38): how uros_build is laid out, how long its tests take and how far
one `uros build` travels.

    python benchmarks/house_metrics.py                      # layout figures only
    python benchmarks/house_metrics.py --tests              # also: run the README's test command, its time
    python benchmarks/house_metrics.py --tests-log FILE     # ... or the time a saved pytest output reports
    python benchmarks/house_metrics.py --costs DIR          # the costliest tests, files and the serial tests
    python benchmarks/house_metrics.py --costs DIR --write-module-cpu   # ... and tests/module_cpu.json
    python benchmarks/house_metrics.py --build -- ARGS...   # also: the modules one `uros ARGS` passes through
    python benchmarks/house_metrics.py --fixture DIR        # ... of a cold cortex-m7 build of the test fixture in DIR

The test time is the wall clock and the CPU seconds (user + system of every process the suite started,
which a loaded machine inflates less than the wall clock) of `python -m pytest -q` in the repository.

--tests also records each test's CPU seconds (benchmarks/cpu_per_test.py) in a temporary folder, and
--costs DIR ranks a folder of such records (one run's: `UROS_TEST_COSTS=DIR PYTHONPATH=benchmarks
python -m pytest -q -p cpu_per_test`): a session fixture's build counts in the first test that asks for it.

The trip is taken in-process with sys.setprofile: every uros_build module whose code runs during the
command, in first-visit order, and how many times control moved from one module to another.
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import resource
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "uros_build"
MODULE_CPU = REPO / "tests" / "module_cpu.json"  # tests/conftest.py orders the modules by it
README_TEST = [sys.executable, "-m", "pytest", "-q"]  # README.md's test command (.ci/run checks it)


def layout() -> None:
    files = sorted(PACKAGE.rglob("*.py"))
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    lines = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in files}
    total = sum(lines.values())
    top_lines = sum(lines[PACKAGE / n] for n in top)
    print(f"modules: {len(files)}, lines: {total}")
    print(f"top-level modules: {len(top)} ({top_lines} lines, {100 * top_lines // total}% of the code)")
    big = sorted(((n, p) for p, n in lines.items() if n > 400), reverse=True)
    print(f"modules over 400 lines: {len(big)}")
    for n, p in big:
        print(f"  {n:5d} {p.relative_to(PACKAGE)}")
    funcs = []
    for p in files:
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.end_lineno:
                funcs.append((node.end_lineno - node.lineno + 1, f"{p.relative_to(PACKAGE)}:{node.name}"))
    print("longest functions:")
    for n, name in sorted(funcs, reverse=True)[:10]:
        print(f"  {n:4d} {name}")
    parameters()
    most_imported()


def parameters(limit: int = 6) -> None:
    """Functions with ``limit`` or more named parameters (self and cls not counted)."""
    many = []
    for p in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                a = node.args
                names = [
                    x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs) if x.arg not in ("self", "cls")
                ]
                if len(names) >= limit:
                    many.append((len(names), f"{p.relative_to(PACKAGE)}:{node.name}"))
    print(f"functions with {limit}+ parameters: {len(many)}")
    for n, name in sorted(many, reverse=True):
        print(f"  {n:4d} {name}")


def most_imported(top: int = 10) -> None:
    """The modules most uros_build modules import, with how many they import (tests/import_graph.py)."""
    sys.path.insert(0, str(REPO / "tests"))
    from import_graph import imports

    graph = imports()
    importers = Counter(dep for deps in graph.values() for dep in deps)
    print(f"most-imported modules (imported by / imports), of {len(graph)}:")
    for name, count in importers.most_common(top):
        print(f"  {count:4d} / {len(graph.get(name, ())):2d} {name}")


def tests(extra: list[str]) -> None:
    """Run the README's test command in the repository: its wall clock and CPU seconds, then the
    costliest tests (each test's CPU seconds recorded by benchmarks/cpu_per_test.py)."""
    import os
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="uros-test-costs-"))
    env = {**os.environ, "UROS_TEST_COSTS": str(folder), "PYTHONPATH": str(REPO / "benchmarks")}
    started = time.monotonic()
    done = subprocess.run(
        [*README_TEST, "-p", "cpu_per_test", *extra], cwd=REPO, capture_output=True, text=True, env=env
    )
    wall = time.monotonic() - started
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"test command: {' '.join(['python', '-m', 'pytest', '-q', *extra])} (exit {done.returncode})")
    print(f"  {_summary(done.stdout)}")
    print(
        f"  wall {wall:.0f} s, CPU {usage.ru_utime + usage.ru_stime:.0f} s (user {usage.ru_utime:.0f} + sys {usage.ru_stime:.0f})"
    )
    costs(folder)


def costs(folder: Path, top: int = 15, write_module_cpu: bool = False) -> None:
    """The records of benchmarks/cpu_per_test.py in ``folder``, ranked: the ``top`` tests and files by
    CPU seconds, and every test marked serial (the time the other workers wait for); with
    ``write_module_cpu`` each module's CPU seconds into tests/module_cpu.json."""
    records = [json.loads(line) for f in sorted(folder.glob("*costs-*.jsonl")) for line in f.open()]
    if not records:
        print(f"no per-test records in {folder}")
        return
    total = sum(r["cpu"] for r in records)
    print(f"per-test CPU ({folder}): {len(records)} tests, {total:.0f} s in tests")
    print(f"  costliest {top} tests (CPU s, wall s):")
    for r in sorted(records, key=lambda r: -r["cpu"])[:top]:
        print(f"  {r['cpu']:7.1f} {r['wall']:7.1f}  {r['test']}")
    files: Counter[str] = Counter()
    count: Counter[str] = Counter()
    for r in records:
        files[r["test"].split("::")[0]] += r["cpu"]
        count[r["test"].split("::")[0]] += 1
    print(f"  costliest {top} files (CPU s, tests):")
    for name, cpu in files.most_common(top):
        print(f"  {cpu:7.1f} {count[name]:5d}  {name}")
    if write_module_cpu:
        table = {name: round(cpu, 1) for name, cpu in files.items()}
        MODULE_CPU.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        print(f"  wrote {MODULE_CPU.relative_to(REPO)} (the order tests/conftest.py gives the modules)")
    if all("end" in r for r in records):  # when each worker ended, from the first test's start
        start = min(r["end"] - r["wall"] for r in records)
        last = max(r["end"] for r in records)
        for worker in sorted({r["worker"] for r in records}):
            mine = [r for r in records if r["worker"] == worker]
            end = max(r["end"] for r in mine)
            print(
                f"  worker {worker}: {len(mine)} tests, busy {sum(r['wall'] for r in mine):.0f} s, "
                f"done at {end - start:.0f} s, idle at the end {last - end:.0f} s"
            )
    serial = [r for r in records if r["serial"]]
    print(
        f"  serial tests: {len(serial)}, {sum(r['cpu'] for r in serial):.0f} s CPU, "
        f"{sum(r['wall'] for r in serial):.0f} s wall alone:"
    )
    for r in sorted(serial, key=lambda r: -r["wall"]):
        print(f"  {r['cpu']:7.1f} {r['wall']:7.1f}  {r['test']}")


def _summary(output: str) -> str:
    """pytest's last line: how many passed, failed, skipped, in how many seconds."""
    lines = [line.strip("= ") for line in output.splitlines() if re.search(r" in [0-9.]+s", line)]
    return lines[-1] if lines else "no pytest summary line"


def trip(argv: list[str]) -> None:
    visited: list[str] = []
    moves = 0
    last = [""]

    def prof(frame, event, _arg):  # type: ignore[no-untyped-def]
        nonlocal moves
        if event != "call":
            return
        name = frame.f_globals.get("__name__", "")
        if not name.startswith("uros_build"):
            return
        if name != last[0]:
            moves += 1
            last[0] = name
        if name not in visited:
            visited.append(name)

    from uros_build.cli import main

    sys.setprofile(prof)
    try:
        main(argv)
    except SystemExit as exc:
        print(f"exit status {exc.code}")
    finally:
        sys.setprofile(None)
    print(f"one `uros {' '.join(argv)}` passes through {len(visited)} modules, {moves} moves between them:")
    for name in visited:
        print(f"  {name}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", action="store_true")
    parser.add_argument("--tests", action="store_true", help="run the README's test command and time it")
    parser.add_argument("--tests-log", type=Path, help="a saved pytest output: the time it reports")
    parser.add_argument("--costs", type=Path, help="a folder of per-test CPU records: ranked")
    parser.add_argument("--write-module-cpu", action="store_true", help="with --costs: tests/module_cpu.json")
    parser.add_argument("--fixture", type=Path)
    parser.add_argument("argv", nargs="*")
    args = parser.parse_args()
    if args.costs:
        costs(args.costs, write_module_cpu=args.write_module_cpu)
        sys.exit(0)
    layout()
    if args.tests:
        tests([])
    elif args.tests_log:
        print(f"tests ({args.tests_log}): {_summary(args.tests_log.read_text(errors='replace'))}")
    if args.fixture:
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
        from fixture_ws import fixture_build_args, make_fixture_workspace

        ws = make_fixture_workspace(args.fixture)
        args.build = True
        args.argv = fixture_build_args(ws)
    if args.build:
        trip(args.argv)
