"""Figures of the house (issue 30): how uros_build is laid out and how far one `uros build` travels.

    python benchmarks/house_metrics.py                      # layout figures only
    python benchmarks/house_metrics.py --build -- ARGS...   # also: the modules one `uros ARGS` passes through
    python benchmarks/house_metrics.py --fixture DIR        # ... of a cold cortex-m7 build of the test fixture in DIR

The trip is taken in-process with sys.setprofile: every uros_build module whose code runs during the
command, in first-visit order, and how many times control moved from one module to another.
"""

from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "uros_build"


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
    parser.add_argument("--fixture", type=Path)
    parser.add_argument("argv", nargs="*")
    args = parser.parse_args()
    layout()
    if args.fixture:
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
        from fixture_ws import fixture_build_args, make_fixture_workspace

        ws = make_fixture_workspace(args.fixture)
        args.build = True
        args.argv = fixture_build_args(ws)
    if args.build:
        trip(args.argv)
