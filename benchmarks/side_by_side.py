"""micro_ros_setup's humble generate_lib flow, run by hand ("SET"), and uros, side by side on one
copy of real micro-ROS Humble sources, in one invocation; prints a Markdown table with uros/SET.

    UROS_MIRROR=/work/.mirror python benchmarks/side_by_side.py --dir /tmp/sbs   # ~30-45 min, 2 cores

What runs (every time is time.monotonic() around one subprocess; the logs are kept in --dir):

* one workspace made by `uros create-firmware` from local mirrors (humble, the custom interface
  package of examples/stm32h7-custom-interfaces as an extra package), shared by both tools;
* SET = micro_ros_setup@humble done by hand, as scripts/create_firmware_ws.sh and
  config/generate_lib/generic/build.sh do it:
  - dev_ws: `colcon build` of every package uros cloned into dev_ws (the build, install and log trees
    go to --dir/set/dev instead of dev_ws/ itself, where uros keeps its own);
  - MCU: in mcu_ws, `rm -rf build install log` and build.sh's colcon command verbatim (Makefiles,
    CMAKE_VERBOSE_MAKEFILE=ON), with SET's dev_ws sourced, then build.sh's merge: `ar x` of every
    installed archive into one folder, `ar rc libmicroros.a`, `ranlib`, `cp -R include`;
  - toolchain file: `uros toolchain render TARGET --for micro-ros`; colcon.meta: `uros meta write
    --toolchain TARGET --meta <workspace>/colcon.meta` (what `uros build` merges), so both build the
    same thing (the script compares them with uros's own after its first build);
* uros = `python -m uros_build` of this checkout: create-firmware, build, build again, ...

SET has no incremental mode (build.sh wipes its trees): its "nothing changed", "meta changed", ".msg
changed" and "second target" rows are each a full cold run, measured, not copied.

Rows in order: dev_ws (SET: every dev_ws package; uros: the closure create-firmware builds), cold full,
nothing changed (uros must say `up to date`), one meta value, one .msg field, cold pruned (`--for-firmware
examples/stm32h7-custom-interfaces` by default; library and include tree against the full build's; the
example firmware linked against both), pruned nothing changed, SET + --packages-up-to by hand, a second
target last. The table and the issue-9 goals (no-op <= 2 s, pruned <= 0.35x SET, dev_ws <= 0.5x SET) are
printed at the end, also after a failure (with what was measured). `-j N` passes colcon
--parallel-workers N to both tools' MCU builds and SET's dev_ws; create-firmware's dev_ws build uses
colcon's default (nproc) as build.sh does.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
# the helpers the tests share (tests/: the folder pytest's `pythonpath` names in pyproject.toml)
sys.path.insert(0, str(REPO / "tests"))

from uros_helpers import STM32H7_EXAMPLE as EXAMPLE  # noqa: E402
from uros_helpers import build_firmware_project, humble_mirror_args  # noqa: E402

from uros_build.sources import distros as distros_mod  # noqa: E402
from uros_build.sources import wsfiles as workspace_mod  # noqa: E402

SETUP_GIT = "/work/.mirror/micro-ROS+micro_ros_setup/repo"  # default; --setup-git overrides
TARGET = "cortex-m7"
SECOND_TARGET = "cortex-m4f"
META_CHANGE = "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2"
EXTRA_PACKAGE = "eic_demo_interface"
CLOCK_HEADER = "uros_clock_gettime.h"  # written beside a rendered micro-ROS toolchain file
# what a typical rclc node needs, plus the custom interfaces (docs/benchmarks.md, issue 9)
UP_TO = ("rclc", "micro_ros_utilities", "std_msgs", "rmw_microxrcedds", EXTRA_PACKAGE)
ADDED_FIELD = "float32 added_by_benchmark\n"

# config/generate_lib/generic/build.sh (micro_ros_setup, branch humble), its colcon arguments
SET_COLCON_ARGS = (
    "--merge-install",
    "--packages-ignore-regex=.*_cpp",
)
SET_CMAKE_ARGS = (
    "--no-warn-unused-cli",
    "-DCMAKE_POSITION_INDEPENDENT_CODE:BOOL=OFF",
    "-DTHIRDPARTY=ON",
    "-DBUILD_SHARED_LIBS=OFF",
    "-DBUILD_TESTING=OFF",
    "-DCMAKE_BUILD_TYPE=Release",
)
# build.sh's merge, verbatim but for the three folders (FW_TARGETDIR/mcu_ws/install,
# FW_TARGETDIR/libmicroros, BUILD_DIR), which are variables here
SET_MERGE = r"""
    mkdir -p $MERGE_DIR; cd $MERGE_DIR; \
	for file in $(find $INSTALL_DIR/lib/ -name '*.a'); do \
		folder=$(echo $file | sed -E "s/(.+)\/(.+).a/\2/"); \
		mkdir -p $folder; cd $folder; ar x $file; \
		for f in *; do \
			mv $f ../$folder-$f; \
		done; \
		cd ..; rm -rf $folder; \
	done ; \
	ar rc libmicroros.a $(ls *.o *.obj 2> /dev/null); mkdir -p $BUILD_DIR; cp libmicroros.a $BUILD_DIR; ranlib $BUILD_DIR/libmicroros.a; \
    cp -R $INSTALL_DIR/include $BUILD_DIR/; \
	cd ..; rm -rf $MERGE_DIR;
"""


@dataclass
class Run:
    name: str
    seconds: float
    log: Path
    load: tuple[float, float]  # 1-minute load average before and after


@dataclass
class Bench:
    root: Path
    mirror: str
    setup_git: str
    runs: list[Run] = field(default_factory=list)
    results: dict[str, float] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    sizes: dict[str, dict[str, int]] = field(default_factory=dict)
    jobs: int | None = None  # colcon --parallel-workers for both tools (None: colcon's default, nproc)
    loads: list[float] = field(default_factory=list)  # 1-minute load average every 15 s of the run

    @property
    def ws(self) -> Path:
        return self.root / "firmware"

    @property
    def set_dir(self) -> Path:
        return self.root / "set"

    @property
    def logs(self) -> Path:
        return self.root / "logs"

    def run(
        self, name: str, argv: list[str], *, cwd: Path | None = None, env: dict[str, str] | None = None
    ) -> float:
        """One subprocess, timed; its output goes to logs/NN-name.log (failure: stop, name the log)."""
        self.logs.mkdir(parents=True, exist_ok=True)
        log = self.logs / f"{len(self.runs) + 1:02d}-{re.sub(r'[^A-Za-z0-9_.-]+', '-', name)}.log"
        before = os.getloadavg()[0]
        with log.open("w", encoding="utf-8") as out:
            out.write(f"$ {shlex.join(argv)}\n(in {cwd or Path.cwd()})\n\n")
            out.flush()
            started = time.monotonic()
            done = subprocess.run(argv, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT)
            seconds = time.monotonic() - started
            out.write(f"\nexit {done.returncode} after {seconds:.1f} s\n")
        after = os.getloadavg()[0]
        self.runs.append(Run(name, seconds, log, (before, after)))
        print(f"  {name}: {seconds:.1f} s (load {before:.1f} -> {after:.1f})  {log.name}", flush=True)
        if done.returncode != 0:
            sys.exit(f"{name} failed with exit {done.returncode}: see {log}")
        return seconds

    # -- uros ----------------------------------------------------------------------------------

    def uros(self, name: str, *args: str) -> float:
        # COLUMNS: rich wraps its lines at 80 columns when stderr is not a terminal; the logs are read
        env = dict(os.environ, PYTHONPATH=str(REPO), COLUMNS="250")
        return self.run(name, [sys.executable, "-m", "uros_build", *args], env=env)

    def uros_build(self, name: str, *args: str, target: str = TARGET) -> float:
        jobs = ["--jobs", str(self.jobs)] if self.jobs else []
        seconds = self.uros(name, "build", "--toolchain", target, "--workspace", str(self.ws), *jobs, *args)
        latest = self.ws / ".uros/log/latest.log"
        if latest.exists():  # an up-to-date build keeps no run log (latest.log then points nowhere)
            shutil.copy2(latest, self.logs / f"{len(self.runs):02d}-uros-run.log")
        return seconds

    def said(self, text: str) -> bool:
        """Did the last subprocess print this (its log in logs/)?"""
        return text in self.runs[-1].log.read_text(encoding="utf-8", errors="replace")

    # -- SET -----------------------------------------------------------------------------------

    def set_env(self) -> dict[str, str]:
        """The environment of the hand-run flow: this Python's bin/ first (its colcon, and the
        interpreter with empy and lark that CMake's FindPython3 finds on PATH), and git's
        url.<mirror>.insteadOf for the clones CMake makes during the build (uncrustify, libyaml),
        as uros sets them: nothing is downloaded."""
        env = dict(os.environ)
        env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
        cfg = workspace_mod.load_config(self.ws)
        assert cfg is not None
        distro = distros_mod.load_distro(cfg.distro)
        items = sorted(distros_mod.insteadof(distro.build_time_clones, cfg.mirror).items())
        env["GIT_CONFIG_COUNT"] = str(len(items))
        for i, (key, value) in enumerate(items):
            env[f"GIT_CONFIG_KEY_{i}"] = key
            env[f"GIT_CONFIG_VALUE_{i}"] = value
        return env

    def set_inputs(self, target: str, *sets: str) -> tuple[Path, Path]:
        """uros's rendered micro-ROS toolchain file and merged colcon.meta for SET."""
        folder = self.set_dir / "inputs"
        tag = "-".join([target, *(s.replace("=", "-") for s in sets)])
        toolchain = folder / f"{target}.toolchain.cmake"
        meta = folder / f"{tag}.colcon.meta"
        if not toolchain.is_file():
            self.uros(f"render toolchain {target}", "toolchain", "render", target, "--for", "micro-ros",
                      "-o", str(toolchain))  # fmt: skip
        if not meta.is_file():
            set_args = [a for s in sets for a in ("--set", s)]
            self.uros(f"write meta {tag}", "meta", "write", "--toolchain", target,
                      "--meta", str(self.ws / "colcon.meta"), *set_args, "-o", str(meta))  # fmt: skip
        return toolchain, meta

    def set_mcu(self, name: str, target: str, *sets: str, up_to: tuple[str, ...] = ()) -> float:
        """build.sh: rm -rf build install log; its colcon command; its ar x merge."""
        toolchain, meta = self.set_inputs(target, *sets)
        colcon = ["colcon", "build", *SET_COLCON_ARGS]
        if up_to:  # not in build.sh: what a user of it can add by hand
            colcon += ["--packages-up-to", *up_to]
        if self.jobs:  # build.sh passes none: colcon's default is nproc
            colcon += ["--parallel-workers", str(self.jobs)]
        colcon += ["--metas", str(meta), "--cmake-args", *SET_CMAKE_ARGS,
                   f"-DCMAKE_TOOLCHAIN_FILE={toolchain}", "-DCMAKE_VERBOSE_MAKEFILE=ON"]  # fmt: skip
        script = "\n".join([
            "set -e -o pipefail",
            f". {shlex.quote(str(self.set_dir / 'dev/install/setup.bash'))}  # build_firmware.sh sources dev_ws",
            f"cd {shlex.quote(str(self.ws / 'mcu_ws'))}",
            "rm -rf build install log",
            shlex.join(colcon),
        ])  # fmt: skip
        env = self.set_env()
        colcon_s = self.run(f"SET {name}: colcon", ["bash", "-c", script], env=env)
        # build.sh's merge leaves $BUILD_DIR unquoted: a folder name without spaces
        out = self.set_dir / "out" / re.sub(r"[^A-Za-z0-9_.-]+", "-", name)
        shutil.rmtree(out, ignore_errors=True)  # no stale headers from an earlier run in the sizes
        env.update(
            INSTALL_DIR=str(self.ws / "mcu_ws/install"), MERGE_DIR=str(self.set_dir / "libmicroros"),
            BUILD_DIR=str(out),
        )  # fmt: skip
        merge_s = self.run(f"SET {name}: merge", ["bash", "-c", "set -e\n" + SET_MERGE], env=env)
        self.notes[f"set {name}"] = f"colcon {colcon_s:.1f} s + merge {merge_s:.1f} s"
        if name in ("cold", "pruned by hand"):
            self.sizes[f"SET {name}"] = set_sizes(out, self.ws / "mcu_ws/install")
        return colcon_s + merge_s

    def set_dev(self) -> float:
        dev = self.set_dir / "dev"
        shutil.rmtree(dev, ignore_errors=True)
        argv = ["colcon", "--log-base", str(dev / "log"), "build",
                "--build-base", str(dev / "build"), "--install-base", str(dev / "install")]  # fmt: skip
        if self.jobs:
            argv += ["--parallel-workers", str(self.jobs)]
        return self.run("SET dev_ws: colcon build", argv, cwd=self.ws / "dev_ws", env=self.set_env())


# ---------------------------------------------------------------------------------------------
# reading results


_STEP_END = re.compile(r"^(?:\[[^]]*\] )?exit (-?\d+) after ([\d.]+) s")


def colcon_steps(run_log: Path) -> list[tuple[str, float]]:
    """(which workspace, seconds) of every colcon build in one uros run log ("+ argv" lines,
    each followed by its "exit N after S s")."""
    steps: list[tuple[str, float]] = []
    pending: str | None = None
    for line in run_log.read_text(encoding="utf-8", errors="replace").splitlines():
        if line.startswith("+ ") and "colcon" in line and " build " in line:
            pending = "dev_ws" if re.search(r"--base-paths \S*dev_ws\b", line) else "mcu_ws"
        elif pending and (m := _STEP_END.match(line)):
            steps.append((pending, float(m[2])))
            pending = None
    return steps


def set_sizes(out: Path, install: Path) -> dict[str, int]:
    lib = out / "libmicroros.a"
    members = subprocess.run(["ar", "t", str(lib)], check=True, capture_output=True, text=True).stdout
    # colcon records every package it installed into a merged prefix here
    packages = len(list((install / "share/colcon-core/packages").iterdir()))
    return {
        "bytes": lib.stat().st_size,
        "members": len(members.splitlines()),
        "packages": packages,
        **tree_size(out / "include"),
    }


def tree_size(folder: Path) -> dict[str, int]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return {"include_files": len(files), "include_bytes": sum(p.stat().st_size for p in files)}


def uros_sizes(out: Path) -> dict[str, int]:
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    return {
        "bytes": info["library"]["bytes"],
        "members": info["library"]["members"],
        "include_files": info["include"]["files"],
        "include_bytes": info["include"]["bytes"],
        "packages": len(info.get("packages", ())),
    }


def query(argv: list[str]) -> str:
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"({exc})"
    return (done.stdout or done.stderr).strip()


def machine_facts(setup_git: str) -> list[str]:
    cpu = next(
        (line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
         if line.startswith("model name")), platform.processor(),
    )  # fmt: skip
    mem = next(
        (int(line.split()[1]) // 1024 // 1024 for line in Path("/proc/meminfo").read_text().splitlines()
         if line.startswith("MemTotal")), 0,
    )  # fmt: skip
    os_name = next(
        (line.split("=", 1)[1].strip('"') for line in Path("/etc/os-release").read_text().splitlines()
         if line.startswith("PRETTY_NAME=")), platform.platform(),
    )  # fmt: skip
    colcon_core = query([sys.executable, "-c", "import colcon_core; print(colcon_core.__version__)"])
    uros_rev = query(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"])
    dirty = query(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"])
    return [
        f"date: {time.strftime('%Y-%m-%d %H:%M %Z')}",
        f"machine: {os.cpu_count()} cores (nproc), {cpu}, {mem} GiB, {os_name}, {platform.machine()}",
        f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}",
        f"uros: {REPO} at {uros_rev}{' (with uncommitted changes)' if dirty else ''}",
        f"micro_ros_setup humble: {query(['git', '--git-dir', setup_git, 'rev-parse', '--short', 'humble'])}",
        f"python {platform.python_version()}, colcon-core {colcon_core}, "
        f"{query(['cmake', '--version']).splitlines()[0]}, ninja {query(['ninja', '--version'])}, "
        f"{query(['make', '--version']).splitlines()[0]}",
        f"{query(['arm-none-eabi-gcc', '--version']).splitlines()[0]}, "
        f"host {query(['gcc', '--version']).splitlines()[0]}, {query(['ar', '--version']).splitlines()[0]}",
        f"uname: {' '.join(platform.uname()[:4])}",
        f"command: {shlex.join([sys.executable, *sys.argv])}",
    ]


# ---------------------------------------------------------------------------------------------
# the runs


def pruning_args(mode: str) -> tuple[list[str], str]:
    """The uros arguments of the pruned build, and how to say which they were."""
    help_text = subprocess.run(
        [sys.executable, "-m", "uros_build", "build", "--help"], env=dict(os.environ, PYTHONPATH=str(REPO)),
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    has_for_firmware = "--for-firmware" in help_text
    has_packages = re.search(r"--packages(?![-\w])", help_text) is not None
    if mode == "auto":
        mode = "for-firmware" if has_for_firmware else "packages" if has_packages else "packages-up-to"
    if mode == "for-firmware":
        if not has_for_firmware:
            sys.exit("--pruning for-firmware: this uros has no `uros build --for-firmware`")
        return ["--for-firmware", str(EXAMPLE)], f"`--for-firmware {EXAMPLE.relative_to(REPO)}`"
    if mode == "packages":
        if not has_packages:
            sys.exit("--pruning packages: this uros has no `uros build --packages`")
        return ["--packages", "std_msgs"], "`--packages std_msgs` (+ the core and the extra package)"
    args = [a for p in UP_TO for a in ("--packages-up-to", p)]
    return args, f"`--packages-up-to {' '.join(UP_TO)}` (colcon's, by hand)"


def links(out: Path, build: Path) -> str:
    """Does examples/stm32h7-custom-interfaces link against this output? (its `size` if so)"""
    try:
        elf = build_firmware_project(EXAMPLE, out, build)
    except AssertionError as exc:
        print(f"  the example firmware does not link against {out}: {str(exc)[:2000]}", flush=True)
        return "does not link"
    text, data, bss = query(["arm-none-eabi-size", str(elf)]).splitlines()[-1].split()[:3]
    return f"links: text {int(text):,} / data {int(data):,} / bss {int(bss):,}"


def edit_msg(bench: Bench, pkg: Path, text: str) -> None:
    """Change CmdVel.msg in the package's own folder and in the workspace's copy of it (where SET
    builds it; uros syncs the same content, so it sees the same change)."""
    for folder in (pkg, bench.ws / "mcu_ws" / workspace_mod.EXTRA / EXTRA_PACKAGE):
        (folder / "msg" / "CmdVel.msg").write_text(text, encoding="utf-8")


def toolchain_words(path: Path) -> set[str]:
    """The words of a toolchain file's non-comment lines, the clock header's folder left out."""
    out: set[str] = set()
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.lstrip().startswith("#"):
            words = line.replace(")", " ").replace('"', " ").split()
            out |= {re.sub(r"\S*/" + re.escape(CLOCK_HEADER), CLOCK_HEADER, w) for w in words}
    return out


def compare_inputs(bench: Bench) -> list[str]:
    """Does SET get the toolchain file and meta uros's own build used?"""
    lines = []
    target_dir = bench.ws / ".uros/targets" / TARGET
    toolchain, meta = bench.set_inputs(TARGET)
    ours = target_dir / "colcon.meta"
    if ours.is_file():
        a = json.loads(meta.read_text())["names"]
        b = json.loads(ours.read_text())["names"]
        lines.append("colcon.meta: " + ("the same names and arguments as uros build's" if a == b
                                        else f"DIFFERS from uros build's ({ours})"))  # fmt: skip
    uros_tc = target_dir / "toolchain.cmake"
    if uros_tc.is_file():
        set_words, uros_words = toolchain_words(toolchain), toolchain_words(uros_tc)
        extra = [f"uros build's adds {w}" for w in sorted(uros_words - set_words)]
        extra += [f"SET's adds {w}" for w in sorted(set_words - uros_words)]
        header = (toolchain.parent / CLOCK_HEADER).read_bytes() == (target_dir / CLOCK_HEADER).read_bytes()
        lines.append(
            "toolchain file: the same words as uros build's"
            + (f" but: {', '.join(extra)}" if extra else "")
            + f"; the force-included {CLOCK_HEADER} {'is the same' if header else 'DIFFERS'}"
        )
    return lines


def mirror_parser(doc: str) -> argparse.ArgumentParser:
    """The options every real-Humble benchmark takes: the mirror and the work folder."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument(
        "--mirror", default=os.environ.get("UROS_MIRROR"), help="folder of <owner>+<repo>/repo"
    )
    parser.add_argument("--dir", type=Path, help="work folder (default: a new one under /tmp, kept)")
    return parser


def main() -> None:
    parser = mirror_parser(__doc__)
    parser.add_argument("--setup-git", default=SETUP_GIT, help="micro_ros_setup's git dir (facts only)")
    parser.add_argument(
        "--pruning", choices=("auto", "for-firmware", "packages", "packages-up-to"), default="auto",
        help="how uros prunes (auto: --for-firmware, else --packages, else --packages-up-to)",
    )  # fmt: skip
    parser.add_argument(
        "-j", "--jobs", type=int,
        help="colcon --parallel-workers of both tools' MCU builds and SET's dev_ws (uros build --jobs); "
        "default: colcon's (nproc), as build.sh and create-firmware",
    )  # fmt: skip
    parser.add_argument("--no-set-pruned", action="store_true", help="skip SET + --packages-up-to by hand")
    parser.add_argument("--no-second-target", action="store_true", help=f"skip the {SECOND_TARGET} rows")
    args = parser.parse_args()
    if not args.mirror:
        sys.exit("needs --mirror or UROS_MIRROR (a folder of <owner>+<repo>/repo clones)")
    root = (args.dir or Path(tempfile.mkdtemp(prefix="uros-sbs-"))).resolve()
    if root.exists() and any(root.iterdir()):
        sys.exit(f"--dir {root}: not empty")
    root.mkdir(parents=True, exist_ok=True)
    bench = Bench(root, args.mirror, args.setup_git, jobs=args.jobs)
    facts = machine_facts(args.setup_git)
    print("\n".join(facts), flush=True)
    prune_args, prune_text = pruning_args(args.pruning)
    print(f"pruned build: {prune_text}\nwork folder: {root}", flush=True)
    threading.Thread(target=sample_load, args=(bench.loads,), daemon=True).start()
    inputs: list[str] = []
    try:
        run_all(bench, args, prune_args, inputs)
    finally:  # a failed or interrupted run still prints what it measured
        report(bench, facts, prune_text, inputs)


def sample_load(into: list[float]) -> None:
    while True:
        into.append(os.getloadavg()[0])
        time.sleep(15)


def run_all(bench: Bench, args: argparse.Namespace, prune_args: list[str], inputs: list[str]) -> None:
    """The rows, the issue-9 goals first (dev_ws, cold, nothing changed, meta, pruned), the second
    target last."""
    root = bench.root
    # -- the one workspace -------------------------------------------------------------------
    pkg = root / EXTRA_PACKAGE
    bench.uros("interface new", "interface", "new", EXTRA_PACKAGE,
               "--msg", str(EXAMPLE / "interfaces/CmdVel.msg"), "--srv", str(EXAMPLE / "interfaces/GetTime.srv"),
               "--output", str(pkg))  # fmt: skip
    original_msg = (pkg / "msg/CmdVel.msg").read_text(encoding="utf-8")
    create_s = bench.uros("uros create-firmware (clones + dev_ws)", "create-firmware", "generate_lib",
                          "--distro", "humble", "--workspace", str(bench.ws), "--toolchain", TARGET,
                          "--extra-package", str(pkg), *humble_mirror_args(args.mirror))  # fmt: skip
    create_log = bench.logs / f"{len(bench.runs):02d}-uros-run.log"
    shutil.copy2(bench.ws / ".uros/log/latest.log", create_log)
    dev_steps = [s for w, s in colcon_steps(create_log) if w == "dev_ws"]
    said = re.search(
        r"dev_ws\):\s+(\d+)\s+of\s+its\s+(\d+)\s+packages", bench.runs[-1].log.read_text(encoding="utf-8")
    )
    if said:
        bench.notes["uros dev packages"] = f"{said[1]} of {said[2]}"
    # what colcon did build (--packages-up-to also follows test dependencies): its console_start_end lines
    bench.notes["uros dev built"] = str(len(finished_packages(create_log)))

    # -- dev_ws ------------------------------------------------------------------------------
    bench.results["set dev"] = bench.set_dev()
    bench.notes["set dev built"] = str(len(finished_packages(bench.runs[-1].log)))
    if dev_steps:
        bench.results["uros dev"] = dev_steps[0]
        bench.notes["uros dev"] = (
            f"the closure, {bench.notes.get('uros dev packages', '?')} packages asked for, colcon built "
            f"{bench.notes['uros dev built']}: colcon step inside "
            f"create-firmware ({create_s:.1f} s with the clones)"
        )

    # -- cold full, nothing changed ----------------------------------------------------------
    bench.results["set cold"] = bench.set_mcu("cold", TARGET)
    seconds = bench.uros_build("uros cold full")
    run_log = bench.logs / f"{len(bench.runs):02d}-uros-run.log"
    bench.notes["live view"] = live_view(bench.runs[-1].log)
    steps = colcon_steps(run_log)
    in_build_dev = sum(s for w, s in steps if w == "dev_ws")
    if in_build_dev and "uros dev" not in bench.results:  # create-firmware left dev_ws to the first build
        bench.results["uros dev"] = in_build_dev
        bench.notes["uros dev"] = "colcon step inside the first uros build (subtracted from its cold row)"
    bench.results["uros cold"] = seconds - in_build_dev
    full_out = bench.ws / "build" / TARGET
    bench.sizes["uros full"] = uros_sizes(full_out)
    bench.notes["slowest"] = slowest_packages(bench.ws)
    bench.notes["elf full"] = links(full_out, root / "elf-full")
    inputs += compare_inputs(bench)
    for line in inputs:
        print(f"  {line}", flush=True)

    bench.results["set noop"] = bench.set_mcu("nothing changed", TARGET)
    bench.results["uros noop"] = bench.uros_build("uros nothing changed")
    bench.notes["uros noop"] = up_to_date(bench)

    # -- one meta value, one .msg field ------------------------------------------------------
    bench.results["set meta"] = bench.set_mcu("meta changed", TARGET, META_CHANGE)
    bench.results["uros meta"] = bench.uros_build("uros meta changed", "--set", META_CHANGE)
    edit_msg(bench, pkg, original_msg + ADDED_FIELD)
    bench.results["set msg"] = bench.set_mcu("msg field added", TARGET, META_CHANGE)
    bench.results["uros msg"] = bench.uros_build("uros msg field added", "--set", META_CHANGE)

    # -- cold pruned (the first target's trees removed; the original .msg and meta) -----------
    edit_msg(bench, pkg, original_msg)
    shutil.rmtree(bench.ws / ".uros/targets" / TARGET)
    shutil.rmtree(full_out)
    bench.results["uros pruned"] = bench.uros_build("uros cold pruned", *prune_args)
    bench.notes["uros pruned"] = selection_said(bench.runs[-1].log)
    pruned_out = bench.ws / "build" / TARGET
    bench.sizes["uros pruned"] = uros_sizes(pruned_out)
    bench.notes["elf pruned"] = links(pruned_out, root / "elf-pruned")
    bench.results["uros pruned noop"] = bench.uros_build("uros pruned, nothing changed", *prune_args)
    bench.notes["uros pruned noop"] = up_to_date(bench)
    if not args.no_set_pruned:
        bench.results["set pruned"] = bench.set_mcu("pruned by hand", TARGET, up_to=UP_TO)

    # -- a second target from the same workspace (cold for both) ------------------------------
    if not args.no_second_target:
        bench.results["set m4f"] = bench.set_mcu(f"second target {SECOND_TARGET}", SECOND_TARGET)
        bench.results["uros m4f"] = bench.uros_build(
            f"uros second target {SECOND_TARGET}", target=SECOND_TARGET
        )


def finished_packages(log: Path) -> set[str]:
    """The packages colcon finished in a log (its console_start_end event handler's lines)."""
    text = log.read_text(encoding="utf-8", errors="replace")
    return set(re.findall(r"Finished <<< (\S+)", text))


def up_to_date(bench: Bench) -> str:
    """What uros said of a build with nothing changed (from its own output)."""
    return "said `up to date`" if bench.said("up to date: ") else "did NOT say `up to date` (it built)"


def selection_said(log: Path) -> str:
    """uros's own lines about what the firmware uses and what it builds."""
    keep = ("the firmware uses", "building ")
    lines = [line.strip() for line in log.read_text(encoding="utf-8", errors="replace").splitlines()]
    return "; ".join(line for line in lines if line.startswith(keep) and "host tools" not in line)


def live_view(log: Path) -> str:
    """The plain progress (stderr is the log file, not a terminal): one `[n/N] built pkg (s)` line each."""
    text = log.read_text(encoding="utf-8", errors="replace")
    lines = re.findall(r"^\[\d+/\d+\] (?:built|FAILED|stopped) \S+ \([\d.]+ s\)$", text, re.M)
    summary = re.search(r"^colcon built \d+ packages in .*$", text, re.M)
    return f"{len(lines)} per-package progress lines" + (f"; `{summary[0]}`" if summary else "")


def slowest_packages(ws: Path, count: int = 5) -> str:
    """From the target's timings.json (the last colcon build's; build-info.json holds no times)."""
    timings = json.loads((ws / ".uros" / "targets" / TARGET / "timings.json").read_text(encoding="utf-8"))
    seconds: dict[str, float] = timings.get("package_seconds", {})
    top = sorted(seconds.items(), key=lambda kv: -kv[1])[:count]
    return f"{len(seconds)} package timings in timings.json; slowest " + ", ".join(
        f"{name} {value:.1f} s" for name, value in top
    )


def ratio(uros: float | None, set_: float | None) -> str:
    return f"{uros / set_:.2f}x" if uros is not None and set_ else "-"


def secs(value: float | None) -> str:
    return f"{value:.1f} s" if value is not None else "not measured"


def goal(name: str, value: float | None, limit: float, unit: str, detail: str) -> str:
    if value is None:
        return f"- {name}: not measured"
    met = "MET" if value <= limit else "MISSED"
    return f"- {name}: {met}, {value:.2f}{unit} (goal <= {limit}{unit}; {detail})"


def report(bench: Bench, facts: list[str], prune_text: str, inputs: list[str]) -> None:
    r = bench.results
    n = bench.notes
    rows = [
        ("host tools workspace (dev_ws)", r.get("set dev"), r.get("uros dev"),
         f"SET: every dev_ws package (colcon built {n.get('set dev built', '?')}); uros: {n.get('uros dev', 'not found in its log')}"),
        ("cold full MCU build + merge", r.get("set cold"), r.get("uros cold"), f"SET: {n.get('set cold', '')}"),
        ("same command again, nothing changed", r.get("set noop"), r.get("uros noop"),
         f"SET wipes and rebuilds: {n.get('set nothing changed', '')}; uros {n.get('uros noop', '')}"),
        (f"one meta value changed (`--set {META_CHANGE}`)", r.get("set meta"), r.get("uros meta"),
         f"SET: {n.get('set meta changed', '')}"),
        (f"one .msg field added ({EXTRA_PACKAGE}/CmdVel.msg)", r.get("set msg"), r.get("uros msg"),
         f"SET: {n.get('set msg field added', '')}"),
        (f"cold pruned: uros {prune_text}", r.get("set cold"), r.get("uros pruned"),
         f"against SET's cold full build (micro_ros_setup has no pruning); uros: {n.get('uros pruned', '')}"),
        ("pruned, nothing changed", r.get("set noop"), r.get("uros pruned noop"),
         f"uros {n.get('uros pruned noop', '')}"),
        (f"SET + `--packages-up-to {' '.join(UP_TO)}` by hand, cold", r.get("set pruned"),
         r.get("uros pruned"), f"uros pruned against it; SET: {n.get('set pruned by hand', '')}"),
        (f"second target ({SECOND_TARGET}) from the same workspace, cold", r.get("set m4f"), r.get("uros m4f"),
         f"SET: {n.get(f'set second target {SECOND_TARGET}', '')}; uros: new target trees, dev_ws reused"),
    ]  # fmt: skip
    print("\n## results\n")
    for line in facts:
        print(f"- {line}")
    if bench.loads:
        loads = bench.loads
        print(f"- 1-minute load average during the run ({len(loads)} samples, every 15 s): "
              f"min {min(loads):.2f}, mean {sum(loads) / len(loads):.2f}, max {max(loads):.2f}")  # fmt: skip
    for line in inputs:
        print(f"- {line}")
    print("\n| step | SET | uros | uros/SET | notes |\n|---|---|---|---|---|")
    for name, set_s, uros_s, note in rows:
        print(f"| {name} | {secs(set_s)} | {secs(uros_s)} | {ratio(uros_s, set_s)} | {note} |")
    print(
        "\n| output | libmicroros.a bytes | members | packages | include files | include bytes | example ELF |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, s in bench.sizes.items():
        elf = n.get("elf full" if name == "uros full" else "elf pruned" if name == "uros pruned" else "", "-")
        print(f"| {name} | {s['bytes']:,} | {s['members']:,} | {s.get('packages', '-')} | "
              f"{s['include_files']:,} | {s['include_bytes']:,} | {elf} |")  # fmt: skip
    full, pruned = bench.sizes.get("uros full"), bench.sizes.get("uros pruned")
    if full and pruned:
        print(f"\nuros pruned / full: library {pruned['bytes'] / full['bytes']:.2f}x, "
              f"include tree {pruned['include_bytes'] / full['include_bytes']:.2f}x (bytes), "
              f"{pruned['include_files'] / full['include_files']:.2f}x (files), "
              f"packages {pruned['packages']} of {full['packages']}")  # fmt: skip
    print("\nissue 9 goals:")
    noop = r.get("uros noop")
    print(goal("no-op <= 2 s", noop, 2.0, " s", n.get("uros noop", "")))
    pr = r["uros pruned"] / r["set cold"] if "uros pruned" in r and r.get("set cold") else None
    print(goal("cold pruned <= 0.35x SET's cold full", pr, 0.35, "x", secs(r.get("uros pruned"))))
    dv = r["uros dev"] / r["set dev"] if "uros dev" in r and r.get("set dev") else None
    print(goal("dev_ws <= 0.5x SET's", dv, 0.5, "x", n.get("uros dev packages", "?") + " packages"))
    print(
        f"- live view (stderr not a terminal: plain lines): {n.get('live view', 'not measured')}; "
        f"{n.get('slowest', '')}"
    )
    print("\nevery subprocess (seconds, 1-min load average before -> after):")
    for run in bench.runs:
        print(f"- {run.name}: {run.seconds:.1f} s (load {run.load[0]:.1f} -> {run.load[1]:.1f})")
    print(f"logs: {bench.logs}")


if __name__ == "__main__":
    main()
