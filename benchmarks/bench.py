"""Wall-clock figures of uros builds, printed as a Markdown table (recorded in docs/benchmarks.md).

    python benchmarks/bench.py                    # the generated fixture workspace (any machine)
    UROS_MIRROR=/work/.mirror python benchmarks/bench.py --real   # real micro-ROS humble, ~6 min

Each figure is one run of the real `uros` CLI; say the machine's core count next to it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
# the helpers the tests share (tests/: the folder pytest's `pythonpath` names in pyproject.toml)
sys.path.insert(0, str(HERE.parent / "tests"))

from fixture_ws import fixture_build_args, make_fixture_workspace  # noqa: E402
from uros_helpers import STM32H7_EXAMPLE as EXAMPLE  # noqa: E402
from uros_helpers import build_firmware_project, humble_mirror_args  # noqa: E402


def uros(*args: str) -> float:
    started = time.monotonic()
    subprocess.run([sys.executable, "-m", "uros_build", *args], check=True, capture_output=True, text=True)
    return time.monotonic() - started


def size_totals(path: Path) -> str:
    out = subprocess.run(
        ["arm-none-eabi-size", "-t", str(path)], check=True, capture_output=True, text=True
    ).stdout
    total = out.strip().splitlines()[-1].split()
    return f"text {int(total[0]):,} / data {int(total[1]):,} / bss {int(total[2]):,}"


def fixture(rows: list[tuple[str, str]]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        ws = make_fixture_workspace(Path(tmp) / "ws")
        build = fixture_build_args(ws)
        rows.append(("fixture: cold `uros build` (5 packages)", f"{uros(*build):.1f} s"))
        rows.append(("fixture: same command again, nothing changed", f"{uros(*build):.1f} s"))
        src = ws / "mcu_ws/src/fx_util/src/scale.c"
        src.write_text(src.read_text() + "\n/* touched */\n")
        rows.append(("fixture: one source file changed", f"{uros(*build):.1f} s"))
        lib = ws / "build/cortex-m7/libmicroros.a"
        rows.append(("fixture: libmicroros.a", f"{lib.stat().st_size:,} bytes"))


def real(rows: list[tuple[str, str]], mirror: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        fw = Path(tmp) / "firmware"
        pkg = Path(tmp) / "eic_demo_interface"
        uros(
            "interface",
            "new",
            "eic_demo_interface",
            "--msg",
            str(EXAMPLE / "interfaces/CmdVel.msg"),
            "--srv",
            str(EXAMPLE / "interfaces/GetTime.srv"),
            "--output",
            str(pkg),
        )
        t = uros(
            "create-firmware",
            "--workspace",
            str(fw),
            "--no-dev-build",
            "--extra-package",
            str(pkg),
            *humble_mirror_args(mirror),
        )
        rows.append(("humble: create-firmware (32 clones from local mirrors)", f"{t:.1f} s"))
        t = uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw))
        rows.append(("humble: first `uros build` (dev_ws + mcu_ws cold + merge)", f"{t:.1f} s"))
        t = uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw))
        rows.append(("humble: same command again, nothing changed", f"{t:.1f} s"))
        out = fw / "build/cortex-m7"
        info = json.loads((out / "build-info.json").read_text())
        rows.append(
            (
                "humble: libmicroros.a",
                f"{info['library']['bytes']:,} bytes, {info['library']['members']} objects",
            )
        )
        rows.append(("humble: libmicroros.a `arm-none-eabi-size -t`", size_totals(out / "libmicroros.a")))
        rows.append(
            (
                "humble: include tree",
                f"{info['include']['files']:,} files, {info['include']['bytes']:,} bytes",
            )
        )
        elf = build_firmware_project(EXAMPLE, out, Path(tmp) / "elf")
        rows.append(("humble: stm32h7-custom-interfaces firmware.elf `size`", size_totals(elf)))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument(
        "--real", action="store_true", help="also build real micro-ROS humble (needs UROS_MIRROR)"
    )
    args = parser.parse_args()
    rows: list[tuple[str, str]] = []
    fixture(rows)
    if args.real:
        mirror = os.environ.get("UROS_MIRROR")
        if not mirror:
            sys.exit("--real needs UROS_MIRROR (a folder of <owner>+<repo>/repo clones)")
        real(rows, mirror)
    print(f"machine: {os.cpu_count()} cores, {os.uname().machine}, {time.strftime('%Y-%m-%d')}")
    print("| figure | value |\n|---|---|")
    for name, value in rows:
        print(f"| {name} | {value} |")


if __name__ == "__main__":
    main()
