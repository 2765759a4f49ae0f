"""Issue 19's rows, side by side in one invocation on real micro-ROS Humble: SET (micro_ros_setup's
flow by hand, as benchmarks/side_by_side.py runs it) and uros for a cold build, a second target from
the same workspace, a fresh workspace with a warm team cache, a fresh workspace with only a warm
ccache, and one with a warm ccache and the user's warm generation cache (what a developer's second
checkout has). Prints a Markdown table with uros/SET and checks that the libraries are the same bytes.

    python benchmarks/build_once.py --mirror /work/.mirror [--dir /tmp/empty-folder]

The machine is shared and its speed moves 2-4x between runs: only the ratios within one invocation
mean something. ccache and uros's generation cache get their own empty folders under the work
folder (CCACHE_DIR, UROS_GEN_CACHE_DIR); the cold rows each start with an empty generation cache.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path

from side_by_side import (
    EXAMPLE,
    EXTRA_PACKAGE,
    SECOND_TARGET,
    SETUP_GIT,
    TARGET,
    Bench,
    colcon_steps,
    humble_mirror_args,
    machine_facts,
    mirror_parser,
    sample_load,
)

GOALS = {
    "uros cold": ("set cold", 0.6),
    "uros cold, --no-ccache": ("set cold", 0.6),
    "uros second target": ("set second target", 0.35),
    "uros fresh, warm team cache": ("set cold", 0.05),
    "uros fresh, warm ccache only": ("set cold", 0.4),
    "uros fresh, warm ccache + generation cache": ("set cold", 0.4),
}


def fresh_copy(ws: Path, where: Path) -> Path:
    """Another checkout of the same workspace: its sources, dev_ws, uros.yaml and lock; no trees."""
    where.mkdir(parents=True)
    for name in ("mcu_ws", "dev_ws", "uros.yaml", "uros.lock", "colcon.meta", "COLCON_IGNORE"):
        source = ws / name
        if source.is_dir():
            shutil.copytree(source, where / name, symlinks=True)
        elif source.exists():
            shutil.copy2(source, where / name)
    shutil.rmtree(where / "mcu_ws" / "build", ignore_errors=True)
    return where


def main() -> None:
    args = mirror_parser(__doc__).parse_args()
    if not args.mirror:
        sys.exit("needs --mirror or UROS_MIRROR")
    root = (args.dir or Path(tempfile.mkdtemp(prefix="uros-once-"))).resolve()
    root.mkdir(parents=True, exist_ok=True)
    os.environ["CCACHE_DIR"] = str(root / "ccache")
    gen_cache = root / "gen-cache"  # the user's generation cache of every row but the two below

    def with_gen_cache(folder: Path) -> None:
        os.environ["UROS_GEN_CACHE_DIR"] = str(folder)

    with_gen_cache(gen_cache)
    bench = Bench(root, args.mirror, SETUP_GIT)
    facts = machine_facts(SETUP_GIT)
    print("\n".join(facts), flush=True)
    threading.Thread(target=sample_load, args=(bench.loads,), daemon=True).start()

    pkg = root / EXTRA_PACKAGE
    bench.uros("interface new", "interface", "new", EXTRA_PACKAGE,
               "--msg", str(EXAMPLE / "interfaces/CmdVel.msg"), "--srv", str(EXAMPLE / "interfaces/GetTime.srv"),
               "--output", str(pkg))  # fmt: skip
    bench.uros("uros create-firmware", "create-firmware", "generate_lib", "--distro", "humble",
               "--workspace", str(bench.ws), "--toolchain", TARGET, "--extra-package", str(pkg),
               *humble_mirror_args(args.mirror))  # fmt: skip
    bench.set_dev()
    r = bench.results
    r["set cold"] = bench.set_mcu("cold", TARGET)
    r["uros cold"] = bench.uros_build("uros cold")
    # create-firmware leaves dev_ws (the host tools, once per workspace) to the first build, and SET
    # built its dev_ws above, outside its cold row: the same here
    dev = sum(s for w, s in colcon_steps(bench.logs / f"{len(bench.runs):02d}-uros-run.log") if w == "dev_ws")
    r["uros cold"] -= dev
    print(f"  (uros cold: {dev:.1f} s of dev_ws build subtracted)", flush=True)

    def fresh_build(name: str, folder: str, *more: str) -> float:
        """`uros build` of the target in a new checkout of the workspace (see fresh_copy)."""
        ws = fresh_copy(bench.ws, root / folder)
        return bench.uros(name, "build", "--toolchain", TARGET, "--workspace", str(ws), *more)

    # the same cold build without ccache (a cold ccache costs its misses), in a fresh checkout with
    # an empty generation cache
    with_gen_cache(root / "gen-cache no ccache")
    r["uros cold, --no-ccache"] = fresh_build("uros cold, --no-ccache", "no ccache", "--no-ccache")
    with_gen_cache(gen_cache)
    r["set second target"] = bench.set_mcu("second target", SECOND_TARGET)
    r["uros second target"] = bench.uros_build("uros second target", target=SECOND_TARGET)
    store = (root / "team cache").as_uri()
    bench.uros_build("uros upload to the team cache", "--cache", store, "--cache-upload")
    teammate, other, third = root / "teammate", root / "other checkout", root / "third checkout"
    r["uros fresh, warm team cache"] = fresh_build(
        "uros fresh, warm team cache", teammate.name, "--cache", store
    )
    took = bench.said("from the cache")
    with_gen_cache(root / "gen-cache empty")
    r["uros fresh, warm ccache only"] = fresh_build(
        "uros fresh, warm ccache only", other.name, "--cache", "none"
    )
    ccache_line = next((ln for ln in bench.runs[-1].log.read_text().splitlines() if "ccache:" in ln), "")
    with_gen_cache(gen_cache)
    r["uros fresh, warm ccache + generation cache"] = fresh_build(
        "uros fresh, warm ccache + generation cache", third.name, "--cache", "none"
    )
    gen_lines = [
        ln.strip()
        for ln in bench.runs[-1].log.read_text().splitlines()
        if ln.startswith(("interface code:", "configure:"))
    ]

    lib = Path("build") / TARGET / "libmicroros.a"
    libraries = [(ws / lib).read_bytes() for ws in (bench.ws, teammate, other, third, root / "no ccache")]
    same = all(data == libraries[0] for data in libraries)
    print("\n| row | seconds | SET row | SET seconds | uros/SET | goal |")
    print("|---|---|---|---|---|---|")
    for row, (set_row, goal) in GOALS.items():
        ratio = r[row] / r[set_row]
        print(f"| {row} | {r[row]:.1f} | {set_row} | {r[set_row]:.1f} | {ratio:.2f} | <= {goal} "
              f"{'met' if ratio <= goal else 'NOT met'} |")  # fmt: skip
    print(f"\nteam cache used: {took}; {ccache_line.strip()}; third checkout: {'; '.join(gen_lines)}")
    print(f"libraries of the five {TARGET} workspaces byte-identical: {same}")
    loads = bench.loads or [0.0]
    print(f"load average during the run: min {min(loads):.1f}, max {max(loads):.1f}; work folder {root}")


if __name__ == "__main__":
    main()
