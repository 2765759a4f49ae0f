"""`uros size` through the real CLI: the fixture build's library per package, and what a firmware
(examples/cmake-firmware, built as in test_example_firmware) really keeps of it."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from uros_helpers import REPO, build_firmware_project, run_uros

pytestmark = pytest.mark.integration

# calls fx_core_add and fx_flat_sum only: fx_time's and fx_core's util.c objects stay in the archive
APP = """\
#include <fx_core/core.h>
#include <fxflat/flat.h>
int counter = 7;
static int buffer[16];
int main(void) { buffer[1] = counter; return fx_core_add(buffer[1], 2) + fx_flat_sum(); }
"""


def test_size_per_package_and_after_linking(m7_build: Path, tmp_path: Path) -> None:
    out = m7_build / "build" / "cortex-m7"
    data = json.loads(run_uros("size", "--toolchain", "cortex-m7", "-w", str(m7_build), "--json").stdout)
    rows = {r["package"]: r for r in data["packages"]}
    assert set(rows) == {"fx_core", "fx_dup", "fx_flat", "fx_time", "fx_util"}
    assert rows["fx_dup"]["objects"] == 2 and rows["fx_time"]["library"]["text"] > 0
    built = json.loads((out / "build-info.json").read_text())["library"]["size"]
    assert data["total"] == built  # the packages add up to size -t's totals

    (tmp_path / "app.c").write_text(APP)
    elf = build_firmware_project(
        REPO / "examples" / "cmake-firmware", out, tmp_path / "fw", f"-DAPP_SOURCES={tmp_path / 'app.c'}"
    )
    map_file = tmp_path / "fw" / "firmware.map"  # the example links with -Wl,-Map=firmware.map
    proc = run_uros("size", str(out), "--elf", str(elf), "--map", str(map_file), "--json")
    linked = {r["package"]: r for r in json.loads(proc.stdout)["packages"]}
    assert linked["fx_time"]["linked"] == {"text": 0, "data": 0, "bss": 0}  # never pulled in
    assert linked["fx_core"]["linked_objects"] == 1 and linked["fx_core"]["objects"] == 2
    assert linked["fx_flat"]["linked"]["text"] == linked["fx_flat"]["library"]["text"]
    whole = json.loads(proc.stdout)["elf"]
    nm = subprocess.run(["arm-none-eabi-size", str(elf)], capture_output=True, text=True, check=True).stdout
    assert str(whole["text"]) == nm.splitlines()[1].split()[0]

    text = run_uros(
        "size", str(out / "libmicroros.a"), "--elf", str(elf), "--map", str(map_file), "--objects"
    ).stdout
    assert text.splitlines()[1].split()[:2] == ["PACKAGE", "OBJECTS"] and "LINKED TEXT" in text
    assert "libfx_time__time.c.obj" in text and "micro-ROS:" in text

    alone = run_uros("size", str(out), "--elf", str(elf), check=False)
    assert alone.returncode == 2 and "--map" in alone.stderr


DEAD = 2**22 + 1000  # above the largest pid_max Linux allows: a run that is gone


def test_size_after_a_killed_swap_of_entries_reads_the_whole_output(m7_build: Path, tmp_path: Path) -> None:
    """Issue 34, item 7: an output swapped entry by entry (a mount point, a folder with the user's
    files), cut by SIGKILL after libmicroros.a was moved aside (the journal in the output): `uros
    size` found no library. It finishes or undoes the swap as the next build would."""
    ws = m7_build
    out = ws / "build" / "cortex-m7"
    expected = json.loads(run_uros("size", str(out), "--json").stdout)
    new, old = out / f".uros-new-{DEAD}", out / f".uros-old-{DEAD}"
    new.mkdir()
    (new / "libmicroros.a").write_text("the new library, never put in place")
    old.mkdir()
    (out / "libmicroros.a").rename(old / "libmicroros.a")
    moves = [
        {"dest": "libmicroros.a", "new": f"{new.name}/libmicroros.a", "old": f"{old.name}/libmicroros.a"}
    ]
    journal = {"pid": DEAD, "moves": moves, "cleanup": [new.name, old.name]}
    (out / ".uros-swap").write_text(json.dumps(journal))
    proc = run_uros("size", str(out), "--json", check=False)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == expected
    assert "rolled back the swap of a uros run" in proc.stderr
    assert not new.exists() and not old.exists() and not (out / ".uros-swap").exists()
