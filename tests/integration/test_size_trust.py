"""Trust, round 5 (issue 43, items 3, 4 and 6 and the "Also" list's size parts), through the real
CLI on the fixture workspace (a real cross-compiled library): `uros size` counts a probe's heap and
stack only for the library file's own bytes and the run of its own variant (bare metal or FreeRTOS),
says which run they come from, and reads report.json as the team cache reads its entries (regular
files only, bounded, typed and ranged values); `uros info` says when the library file changed;
`uros size --elf` takes only a linked firmware of the library's target; `uros doctor` sees a changed
FreeRTOSConfig.h; `--set` values out of meta/options.yaml's ranges are refused before building.
The reports are written here as `uros probe` writes them (the fixture library is no micro-ROS and
cannot be probed)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixture_rtos import make_standin_kernel, write_config
from fixture_ws import add_plain_package, fixture_build_args, make_fixture_workspace
from uros_helpers import need, run_uros, run_uros_here

from uros_build.run.report import REPORT, probe_base, probe_work, report_name

pytestmark = pytest.mark.integration

PASSED = {"status": 0, "passed": True, "verdict": "pass", "heap_bytes": 2920, "stack_bytes": 2112,
          "machine": "mps2-an500", "rtos": None, "map_sha256": None}  # fmt: skip


@pytest.fixture
def ws(m7_build: Path) -> Path:
    """The built fixture workspace, fresh for this test (reports written into its .uros/probe)."""
    return m7_build


def _out(ws: Path) -> Path:
    return (ws / "build" / "cortex-m7").resolve()


def _work(ws: Path) -> Path:
    out = _out(ws)
    work = probe_work(probe_base(out, "cortex-m7"), "cortex-m7", out)
    work.mkdir(parents=True, exist_ok=True)
    return work


def _sha(ws: Path) -> str:
    sha: str = json.loads((_out(ws) / "build-info.json").read_text())["library"]["sha256"]
    return sha


def _size(ws: Path, *more: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "uros_build", "size", str(_out(ws)), "--ram", "64K", *more]
    try:
        return subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"uros size did not end within {timeout} s")


def _budget(ws: Path) -> dict[str, object]:
    done = _size(ws, "--json")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    budget: dict[str, object] = json.loads(done.stdout)["budget"]
    return budget


def test_a_replaced_library_is_not_judged_on_the_old_runs_figures(ws: Path) -> None:
    """round 5, item 3: the report was matched to build-info.json's sha256, so a libmicroros.a
    replaced in the output still "fit" on the old run's heap and stack, and `uros info` printed the
    old file's size and objects."""
    (_work(ws) / REPORT).write_text(json.dumps({**PASSED, "library_sha256": _sha(ws)}))
    text = _size(ws).stdout
    assert "+ heap 2,920 B + stack 2,112 B (uros probe, bare metal in QEMU mps2-an500)" in text
    # another library in its place: one of the fixture's own package archives
    other = next((ws / ".uros" / "targets" / "cortex-m7" / "install").rglob("*.a"))
    shutil.copy(other, _out(ws) / "libmicroros.a")
    done = _size(ws, "--json")
    assert done.returncode == 0, done.stderr
    assert "not the library its build-info.json describes" in done.stderr
    data = json.loads(done.stdout)
    assert data["matches_build_info"] is False
    assert data["budget"]["heap"] is None
    assert data["budget"]["probe"].startswith("not measured for this library")
    assert data["budget"]["verdict"].endswith("(static RAM only; heap and stack not measured for this library: "
                                              "the last probe ran another build of it (run uros probe))")  # fmt: skip
    info = run_uros("info", str(_out(ws)))
    assert "library    libmicroros.a: CHANGED since the build: its sha256 is " in info.stdout
    assert "not the library build-info.json describes" in info.stderr
    assert (
        json.loads(run_uros("info", "--json", str(_out(ws))).stdout)["library"]["matches_build_info"] is False
    )


@pytest.fixture(scope="module")
def reports_ws(m7_snapshot: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the built fixture workspace of this module's own (copied once: `uros size` only reads
    it), for the cases that write nothing but a report into its probe folder (each its own: the
    folder is emptied first)."""
    return Path(shutil.copytree(m7_snapshot, tmp_path_factory.mktemp("reports") / "ws", symlinks=True))


def test_a_freertos_run_never_stands_for_the_bare_metal_one(reports_ws: Path) -> None:
    """round 5, item 3: a --freertos probe of a bare-metal library overwrote its report.json, and
    `uros size` counted the FreeRTOS heap saying only "(uros probe)"."""
    ws = reports_ws
    shutil.rmtree(_work(ws))  # no report of another case: this test's alone
    work = _work(ws)
    # a report.json of a FreeRTOS run (as main's probe wrote it): not this library's variant
    (work / REPORT).write_text(json.dumps({**PASSED, "rtos": "freertos", "library_sha256": _sha(ws)}))
    budget = _budget(ws)
    assert budget["heap"] is None
    assert budget["probe"] == (
        "not measured on bare metal: the probe's report.json is of a run on FreeRTOS (run uros probe)"
    )
    # the FreeRTOS run keeps its own report; the bare-metal one stays apart
    (work / REPORT).unlink()
    (work / report_name("freertos")).write_text(
        json.dumps({**PASSED, "rtos": "freertos", "heap_bytes": 40000, "library_sha256": _sha(ws)})
    )
    budget = _budget(ws)
    assert budget["heap"] is None
    assert budget["probe"] == "not measured on bare metal: the probe ran only on FreeRTOS (run uros probe)"
    (work / REPORT).write_text(json.dumps({**PASSED, "library_sha256": _sha(ws)}))
    budget = _budget(ws)
    assert budget["heap"] == 2920 and isinstance(budget["probe"], dict)
    assert budget["probe"]["run"] == "uros probe, bare metal in QEMU mps2-an500"
    assert budget["probe"]["rtos"] is None


@pytest.mark.parametrize(
    "case", ["fifo", "dev-zero", "not-utf8", "negative-heap", "true-stack", "passed-string", "huge", "nested"]
)
def test_a_hostile_report_is_not_measured_in_one_line(reports_ws: Path, case: str) -> None:
    """round 5, item 4: a FIFO hung `uros size`, a link to /dev/zero grew to 11 GB, non-UTF-8 was
    an internal error, heap_bytes -100000 gave negative RAM, true counted as 1 B, "false" passed."""
    ws = reports_ws
    shutil.rmtree(_work(ws))  # the last case's report gone: this case's alone
    path = _work(ws) / REPORT
    good = {**PASSED, "library_sha256": _sha(ws)}
    if case == "fifo":
        os.mkfifo(path)
    elif case == "dev-zero":
        path.symlink_to("/dev/zero")
    elif case == "not-utf8":
        path.write_bytes(json.dumps(good).encode().replace(b'"pass"', b'"\xff\xfe"'))
    elif case == "huge":
        path.write_bytes(b" " * (2 * 1024 * 1024) + json.dumps(good).encode())
    elif case == "nested":
        path.write_bytes(b"[" * 200_000)
    else:
        change = {"negative-heap": {"heap_bytes": -100000}, "true-stack": {"stack_bytes": True},
                  "passed-string": {"passed": "false"}}[case]  # fmt: skip
        path.write_text(json.dumps({**good, **change}))
    done = _size(ws, "--json", timeout=60)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert "internal error" not in done.stderr.lower()
    budget = json.loads(done.stdout)["budget"]
    assert budget["heap"] is None and budget["stack"] is None
    assert budget["probe"].startswith("not measured"), budget["probe"]
    assert budget["need"]["ram"] == budget["need"]["static_ram"] >= 0
    why = {"fifo": "not a regular file", "dev-zero": "not a regular file", "not-utf8": "is not UTF-8 text",
           "negative-heap": "has heap_bytes -100000, not a byte count", "huge": "more than the 1,048,576",
           "true-stack": "has stack_bytes true, not a byte count", "passed-string": "did not pass",
           "nested": "is not JSON"}[case]  # fmt: skip
    assert why in budget["probe"], budget["probe"]


def _link(tmp: Path, *flags: str) -> Path:
    (tmp / "main.c").write_text("int main(void) { return 0; }\n")
    elf = tmp / f"fw{len(list(tmp.glob('fw*')))}.elf"
    subprocess.run(
        ["arm-none-eabi-gcc", *flags, "--specs=nosys.specs", str(tmp / "main.c"), "-o", str(elf)], check=True
    )
    return elf


def test_elf_takes_only_a_linked_firmware_of_the_librarys_target(reports_ws: Path, tmp_path: Path) -> None:
    """round 5: `uros size --elf` accepted an archive or another target's firmware."""
    ws = reports_ws  # only read here
    need("arm-none-eabi-gcc")
    map_file = tmp_path / "app.map"
    map_file.write_text("")
    riscv = tmp_path / "riscv.elf"  # an ELF header of a RISC-V executable (e_machine 243)
    riscv.write_bytes(
        b"\x7fELF\x01\x01\x01"
        + bytes(9)
        + (2).to_bytes(2, "little")
        + (243).to_bytes(2, "little")
        + bytes(44)
    )
    cases = {
        _out(ws) / "libmicroros.a": "an archive (ar), not a linked firmware",
        riscv: "a firmware for RISC-V (ELF32), not for the library's ARM (ELF32)",
        _link(tmp_path, "-mcpu=cortex-m0plus", "-mthumb"): "its float ABI is soft-float, the library's is hard-float: another target's firmware",
    }  # fmt: skip
    for elf, why in cases.items():  # refused before any process starts: in process
        done = run_uros_here("size", str(_out(ws)), "--elf", str(elf), "--map", str(map_file), check=False)
        assert done.returncode == 2, done.stderr
        assert done.stderr.splitlines()[0] == f"error: --elf {elf}: {why}", done.stderr
    # a FIFO or /dev/zero as --map or --elf: one line, never read
    fifo = tmp_path / "map.fifo"
    os.mkfifo(fifo)
    (tmp_path / "zero.map").symlink_to("/dev/zero")
    for flag, path in (("--map", fifo), ("--map", tmp_path / "zero.map"), ("--elf", fifo)):
        other = str(riscv if flag == "--map" else map_file)
        argv = ["size", str(_out(ws)), flag, str(path), "--elf" if flag == "--map" else "--map", other]
        done = run_uros_here(*argv, check=False)
        assert (
            done.returncode == 2
            and done.stderr.splitlines()[0] == f"error: {flag} {path}: not a regular file"
        )
    # the library's own target's firmware is taken (and its map read)
    fw_map = tmp_path / "fw.map"
    good = _link(
        tmp_path, "-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard", f"-Wl,-Map={fw_map}"
    )
    done = run_uros("size", str(_out(ws)), "--elf", str(good), "--map", str(fw_map), check=False)
    assert "--elf" not in done.stderr, done.stderr


@pytest.mark.parametrize(
    ("item", "why"),
    [
        ("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=0", "RMW_UXRCE_MAX_NODES must be 1 or more, got 0"),
        ("microxrcedds_client.UCLIENT_CUSTOM_TRANSPORT_MTU=0", "UCLIENT_CUSTOM_TRANSPORT_MTU must be 28 or more, got 0"),
        ("rmw_microxrcedds.RMW_UXRCE_MAX_HISTORY=" + "9" * 5000, "a number of 5,000 digits"),
    ],
)  # fmt: skip
def test_set_values_out_of_range_are_refused_before_building(tmp_path: Path, item: str, why: str) -> None:
    """round 5: --set took MAX_NODES=0 and an MTU of 0; 5000 digits were an internal error."""
    ws = make_fixture_workspace(tmp_path)
    done = run_uros_here(*fixture_build_args(ws, "--set", item), check=False)  # refused before any process
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert lines[0].startswith("error: --set ") and why in lines[0], done.stderr
    assert len(lines[0]) < 400 and not (ws / "build").exists()


FX_RTOS_C = '#include "FreeRTOS.h"\nint fx_rtos_tick(void) { return configTICK_RATE_HZ; }\n'


@pytest.mark.colcon
def test_doctor_sees_a_changed_freertos_config(tmp_path: Path) -> None:
    """round 5, item 6: `uros doctor` said "built and up to date" after FreeRTOSConfig.h changed,
    while the next build rebuilt it (the headers are given on the command line here: doctor reads
    their folders from build-info.json)."""
    need("arm-none-eabi-gcc", "cmake", "ninja")
    ws = tmp_path / "ws"
    add_plain_package(ws / "mcu_ws" / "src" / "fx_rtos", "fx_rtos", FX_RTOS_C)
    kernel = make_standin_kernel(tmp_path / "FreeRTOS-Kernel")
    config = write_config(tmp_path / "app")
    build = ["build", "--toolchain", "cortex-m7", "-w", str(ws), "--rtos", "freertos",
             "--rtos-dir", str(kernel), "--rtos-config", str(config)]  # fmt: skip
    run_uros(*build)

    def target_check() -> dict[str, str]:
        done = run_uros("doctor", "-w", str(ws), "--json", check=False)
        checks = json.loads(done.stdout)["checks"]
        found: dict[str, str] = next(c for c in checks if c["name"] == "target cortex-m7")
        return found

    assert target_check()["detail"] == "built and up to date"
    write_config(config, "#define configTICK_RATE_HZ 500\n")
    stale = target_check()
    assert stale["status"] != "ok" and "the FreeRTOS headers (FreeRTOSConfig.h in" in stale["detail"], stale
    assert "changed since the last build: RTOS" in run_uros(*build).stderr
    assert target_check()["detail"] == "built and up to date"
