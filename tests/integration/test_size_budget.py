"""`uros size --ram N --flash N` through the real CLI: does a library fit a chip, the options that
cost most RAM measured from the library's own pools (built twice with another value), the heap and
stack of the last passed `uros probe` of that very library, bad sizes, and a profile's chip as the
default budget. The fixture workspaces are real cross-compiled libraries (arm-none-eabi-gcc)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from fixture_ws import add_plain_package, fixture_build_args, make_fixture_workspace
from uros_helpers import need, run_uros, run_uros_here

from uros_build.run.report import REPORT, probe_base, probe_work

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

# rmw_microxrcedds' static pools in their shape (rmw_microxrcedds_c/src/types.c): arrays of
# RMW_UXRCE_MAX_HISTORY input buffers (MTU x history + 64 bytes of bookkeeping: 2,112 B each at
# 512 x 4) and one session. The fixture's values, not upstream's code.
POOLS = """\
typedef struct { unsigned char buffer[512 * 4]; void *mem[16]; } fx_static_buffer_t;
fx_static_buffer_t custom_static_buffers[RMW_UXRCE_MAX_HISTORY];
unsigned char custom_sessions[5544];
int fx_rmw_history(void) { return RMW_UXRCE_MAX_HISTORY + custom_sessions[0]; }
"""
SLOT = 512 * 4 + 16 * 4
# the pools' package alone is built: the fixture's own packages hold no RAM (code only), so every
# figure of RAM is the same with them, and the builds are cheaper without
POOLS_ALONE = ("--packages-up-to", "rmw_microxrcedds")


def _pools_workspace(root: Path) -> Path:
    ws = make_fixture_workspace(root)
    folder = add_plain_package(ws / "mcu_ws" / "src" / "rmw_microxrcedds", "rmw_microxrcedds", POOLS)
    with (folder / "CMakeLists.txt").open("a", encoding="utf-8") as cmake:
        cmake.write(
            'set(RMW_UXRCE_MAX_HISTORY "8" CACHE STRING "input buffers")\n'
            "target_compile_definitions(rmw_microxrcedds PRIVATE RMW_UXRCE_MAX_HISTORY=${RMW_UXRCE_MAX_HISTORY})\n"
            # the configured header a library carries, as rmw_microxrcedds_c/config.h.in does upstream
            'file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/config.h "#define RMW_UXRCE_MAX_HISTORY ${RMW_UXRCE_MAX_HISTORY}\\n")\n'
            "install(FILES ${CMAKE_CURRENT_BINARY_DIR}/config.h DESTINATION include/rmw_microxrcedds_c)\n"
        )
    return ws


@pytest.fixture(scope="module")
def pools_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    need("arm-none-eabi-gcc", "cmake")
    ws = _pools_workspace(tmp_path_factory.mktemp("pools"))
    run_uros(*fixture_build_args(ws, *POOLS_ALONE, "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=4"))
    return ws


def _size(ws: Path, *more: str, target: str = "cortex-m7") -> subprocess.CompletedProcess[str]:
    return run_uros("size", "--toolchain", target, "-w", str(ws), *more, check=False)


def test_fits_and_does_not_fit_by_how_much_naming_the_costly_options(pools_ws: Path) -> None:
    # cortex-m7 is a core of many chips: no default budget, the table alone as before
    plain = _size(pools_ws)
    assert plain.returncode == 0 and "budget:" not in plain.stdout and "fits" not in plain.stdout
    fits = _size(pools_ws, "--ram", "1M", "--flash", "512KB")
    assert fits.returncode == 0, fits.stderr
    last = fits.stdout.splitlines()[-1]
    assert last.startswith("fits: RAM ") and "of 1,048,576 B" in last and "of 524,288 B" in last
    # no probe ran: never a number for heap and stack
    assert last.endswith("(static RAM only; heap and stack not measured: run uros probe)")
    assert "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=4 8,448 B (custom_static_buffers)" in fits.stdout

    over = _size(pools_ws, "--ram", "4K", "--json")
    assert over.returncode == 5, over.stderr
    data = json.loads(over.stdout)["budget"]
    ram_need = data["need"]["ram"]
    assert ram_need == data["need"]["static_ram"] >= 4 * SLOT + 5544 and data["heap"] is None
    assert data["over"] == {"ram": ram_need - 4096} and data["fits"] is False
    error = over.stderr.splitlines()
    assert f"does not fit: RAM needs {ram_need:,} B: {ram_need - 4096:,} B over 4 KB (4,096 B)" in error[0]
    # the hint: the options that cost most RAM, by the library's own pools (the session's MTU and
    # stream history size both pools; the upstream defaults count where the meta sets nothing)
    assert "microxrcedds_client.UCLIENT_CUSTOM_TRANSPORT_MTU=512 13,992 B" in over.stderr
    costs = {c["option"]: c for c in data["options"]}
    history = costs["RMW_UXRCE_MAX_HISTORY"]
    assert (history["bytes"], history["value"], history["each"]) == (4 * SLOT, "4", SLOT)
    assert history["value_from"] == "header"  # the library's own rmw_microxrcedds_c/config.h
    assert data["would_fit"] == []  # no option alone frees ~10 KB here
    # 2 KB over: one input buffer fewer alone would fit, and uros says so
    near = _size(pools_ws, "--ram", str(ram_need - 2048), "--json")
    assert near.returncode == 5
    assert json.loads(near.stdout)["budget"]["would_fit"] == [
        {"package": "rmw_microxrcedds", "option": "RMW_UXRCE_MAX_HISTORY", "value": "3", "frees": SLOT}
    ]
    assert "alone enough: --set rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=3 (frees 2,112 B)" in near.stderr


def test_an_option_cost_is_measured_from_the_library_built_twice(pools_ws: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shutil.copytree(pools_ws, ws, symlinks=True)
    before = json.loads(_size(ws, "--ram", "1M", "--json").stdout)
    run_uros(*fixture_build_args(ws, *POOLS_ALONE, "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=2"))
    after = json.loads(_size(ws, "--ram", "1M", "--json").stdout)
    cost = {c["option"]: c for c in after["budget"]["options"]}["RMW_UXRCE_MAX_HISTORY"]
    assert (cost["value"], cost["bytes"]) == ("2", 2 * SLOT)
    assert cost["value_from"] == "header"
    # what the option costs is what the library lost: two slots less of zeroed RAM
    assert before["total"]["bss"] - after["total"]["bss"] == 2 * SLOT


@pytest.mark.parametrize("flag", ["--ram", "--flash"])
@pytest.mark.parametrize("value", ["12X", "0", "1.5M", "-4K", "5000M", "9" * 5000])
def test_a_bad_size_is_refused_in_one_line_naming_the_flag(flag: str, value: str, tmp_path: Path) -> None:
    """5000 digits were an internal error (round 5): at most 12 digits and 4 GB, said in one line
    (before any process starts: in process)."""
    proc = run_uros_here("size", str(tmp_path / "libmicroros.a"), flag, value, check=False)
    assert proc.returncode == 2
    shown = value if len(value) < 24 else "99999999999999999999... (5,000 characters)"
    assert proc.stderr.splitlines() == [
        f"error: {flag} {shown}: not a size more than 0: a whole number of bytes, or with K, KB, M or MB "
        "(1024-based), e.g. 256K or 2MB, up to 4 GB"
    ]


def _write_report(ws: Path, target: str, **report: object) -> Path:
    out = (ws / "build" / target).resolve()
    work = probe_work(probe_base(out, target), target, out)
    work.mkdir(parents=True, exist_ok=True)
    (work / REPORT).write_text(json.dumps(report))
    return work / REPORT


def test_the_heap_and_stack_of_a_passed_probe_of_this_library_count(pools_ws: Path, tmp_path: Path) -> None:
    """The report `uros probe` writes (its ProbeReport as JSON, with the library's sha256) is read
    back; written here, as the probe of a fixture library cannot run (it is no micro-ROS)."""
    ws = tmp_path / "ws"
    shutil.copytree(pools_ws, ws, symlinks=True)
    sha = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())["library"]["sha256"]
    passed = {"status": 0, "verdict": "pass", "heap_bytes": 2920, "stack_bytes": 2112}
    _write_report(ws, "cortex-m7", **passed, library_sha256=sha, map_sha256=None)
    data = json.loads(_size(ws, "--ram", "1M", "--json").stdout)["budget"]
    assert (data["heap"], data["stack"]) == (2920, 2112)
    assert data["need"]["ram"] == data["need"]["static_ram"] + 2920 + 2112
    text = _size(ws, "--ram", "1M").stdout
    assert "+ heap 2,920 B + stack 2,112 B (uros probe, bare metal)" in text
    assert "static RAM only" not in text.splitlines()[-1]

    _write_report(ws, "cortex-m7", **passed, library_sha256="0" * 64, map_sha256=None)
    other = json.loads(_size(ws, "--ram", "1M", "--json").stdout)["budget"]
    assert other["heap"] is None and other["probe"].startswith("not measured for this library")


def test_a_profile_that_names_its_chip_is_the_default_budget(tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path)
    # fx_util and fx_core (34 B of code): a library to size, not the whole fixture
    run_uros(*fixture_build_args(ws, "--packages-up-to", "fx_util", toolchain="rp2040"))
    proc = _size(ws, target="rp2040")
    assert proc.returncode == 0, proc.stderr
    assert "budget: RAM 264 KB, flash 2 MB (the RP2040 of the target's profile)" in proc.stdout
    assert proc.stdout.splitlines()[-1].startswith("fits: RAM ")
    assert "of 270,336 B" in proc.stdout.splitlines()[-1]
    # a flag overrides its half of the chip's budget; the other half stays the chip's
    small = _size(ws, "--flash", "16", "--json", target="rp2040")  # fx_util and fx_core have 34 B of code
    assert small.returncode == 5
    data = json.loads(small.stdout)["budget"]
    assert (data["ram"], data["flash"], data["chip"]) == (264 * 1024, 16, None)
    assert data["over"] == {"flash": data["need"]["flash"] - 16}


@pytest.mark.skipif(
    not (os.environ.get("UROS_AGENT") and os.environ.get("UROS_HUMBLE_WS")),
    reason="needs UROS_AGENT and UROS_HUMBLE_WS (a built humble workspace)",
)
def test_real_humble_probe_then_size(tmp_path: Path) -> None:
    """The real library: `uros probe` writes report.json, `uros size` counts its heap and stack and
    what the probe firmware linked of the library (its map file)."""
    need("qemu-system-arm", "arm-none-eabi-gcc", "cmake")
    ws = tmp_path / "ws"
    shutil.copytree(os.environ["UROS_HUMBLE_WS"], ws, symlinks=True)
    out = ws / "build" / "cortex-m7"
    probe = json.loads(run_uros("probe", str(out), "--json").stdout)
    data = json.loads(run_uros("size", str(out), "--ram", "256K", "--flash", "1M", "--json").stdout)
    budget = data["budget"]
    assert (budget["heap"], budget["stack"]) == (probe["heap_bytes"], probe["stack_bytes"])
    assert budget["library"]["counted"].startswith("linked by the probe firmware")
    whole = data["total"]["data"] + data["total"]["bss"]
    assert 0 < budget["library"]["data"] + budget["library"]["bss"] < whole
    assert budget["fits"] is True and budget["options"][0]["bytes"] > 0
