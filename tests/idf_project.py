"""What the ESP-IDF proofs (tests/integration/test_esp32s3_proof.py, test_esp32_riscv_idf.py) do with a
real ESP-IDF project: configure it with ESP-IDF's own CMake, compile a source with the command ESP-IDF
wrote, and read which identifiers its headers (or sources) name."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

from uros_helpers import REPO, humble_mirror_args, run_uros

# the ESP-IDF example both proofs build: seed 000's node with a custom demo_interfaces/msg/Hsb
EXAMPLE = REPO / "examples" / "esp32s3-idf"


def run(argv: list[str], cwd: Path | None = None, env: dict[str, str] | None = None) -> str:
    """Run a tool (LC_ALL=C: its output is parsed); its stdout, or AssertionError with its output."""
    done = subprocess.run(
        argv, cwd=cwd, env=env or {**os.environ, "LC_ALL": "C"}, capture_output=True, text=True
    )
    if done.returncode != 0:
        raise AssertionError(
            f"{' '.join(argv)} failed ({done.returncode}):\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}"
        )
    return done.stdout


def configure(project: Path, target: str) -> Path:
    """ESP-IDF's own CMake, as `idf.py reconfigure` runs it; the build folder. The compiler checks are
    skipped (a toolchain without ESP-IDF's libraries cannot link their test program); IDF_MAINTAINER
    turns an unknown toolchain version into a warning."""
    env = {**os.environ, "IDF_MAINTAINER": "1", "IDF_COMPONENT_MANAGER": "0", "LC_ALL": "C"}
    build = project / "build"
    run(
        ["cmake", "-S", str(project), "-B", str(build), "-G", "Ninja", f"-DIDF_TARGET={target}",
         "-DPYTHON_DEPS_CHECKED=1", f"-DPYTHON={sys.executable}",
         "-DCMAKE_C_COMPILER_WORKS=1", "-DCMAKE_CXX_COMPILER_WORKS=1"],
        env=env,
    )  # fmt: skip
    return build


def compile_as_idf_does(build: Path, source: str) -> Path:
    """Compile ``source`` (a path ending) with the command ESP-IDF wrote into compile_commands.json;
    the object."""
    entries = json.loads((build / "compile_commands.json").read_text())
    entry = next(e for e in entries if e["file"].endswith(source))
    argv = shlex.split(entry["command"])
    obj = Path(entry["directory"]) / argv[argv.index("-o") + 1]
    obj.parent.mkdir(parents=True, exist_ok=True)
    run(argv, cwd=Path(entry["directory"]))
    return obj


def component_include_dirs(build: Path) -> list[str]:
    """The include folders of every component of the configured project but micro_ros."""
    description = json.loads((build / "project_description.json").read_text())
    return [
        str(Path(c["dir"]) / inc)
        for name, c in description["build_component_info"].items()
        if name != "micro_ros"
        for inc in c.get("include_dirs", [])
    ]


def words(folders: list[str], pattern: str = "*.h") -> set[str]:
    """Every identifier that appears in a file matching ``pattern`` under ``folders``."""
    found: set[str] = set()
    for folder in folders:
        for path in Path(folder).rglob(pattern):
            found.update(re.findall(r"\b[A-Za-z_]\w*\b", path.read_text(encoding="utf-8", errors="replace")))
    return found


def libc_include_dirs(gcc: str) -> list[str]:
    """Where ``gcc`` finds <...> headers (its own and its C library's)."""
    probe = subprocess.run([gcc, "-xc", "-E", "-v", os.devnull], capture_output=True, text=True, check=True)
    block = probe.stderr.split("#include <...> search starts here:")[1].split("End of search list.")[0]
    return [line.strip() for line in block.splitlines() if line.strip()]


def example_firmware(root: Path, mirror: str) -> Path:
    """A humble firmware workspace under ``root`` with the example's demo_interfaces, from ``mirror``."""
    interfaces = root / "demo_interfaces"
    run_uros("interface", "new", "demo_interfaces", "--msg", str(EXAMPLE / "interfaces" / "Hsb.msg"),
             "--output", str(interfaces))  # fmt: skip
    fw = root / "firmware"
    run_uros("create-firmware", "generate_lib", "--distro", "humble", "--workspace", str(fw),
             "--extra-package", str(interfaces), *humble_mirror_args(mirror))  # fmt: skip
    return fw
