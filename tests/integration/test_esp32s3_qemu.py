"""An ESP32-S3 core in QEMU (issue 42, item 3): real ESP32-S3 code, built with a compiler that emits the
S3's instructions, runs on QEMU's lx60 board with the S3 core imported (`-M lx60-nommu -cpu esp32s3`).

Needs (each test skips cleanly without it):
- UROS_ESP32S3_QEMU: a qemu-system-xtensa whose `-cpu help` lists esp32s3 (tests/esp32s3-qemu-env.sh);
- xtensa-esp32s3-elf-gcc on PATH that makes Espressif-core code (tests/esp32s3-real-env.sh), with the
  windowed picolibc of tests/esp32s3-picolibc-env.sh (its specs give the headers in the bare-metal test,
  which links nothing from it);
- for `uros probe --toolchain esp32s3-bare`: UROS_MIRROR (upstream clones) and UROS_AGENT (a
  MicroXRCEAgent); UROS_HUMBLE_WS names a Humble workspace (a copy: the probe writes into it) so that
  only the esp32s3-bare library is built.

The bare-metal firmware is the probe board's own start-up (templates/probe/xtensa/board.c, windowed:
register window, overflow/underflow vectors, CPENABLE, ATOMCTL), its 16550 driver and a main() that uses
the S3's FPU (madd.s), 32-bit divide (quos), s32c1i and 100 nested windowed calls; QEMU's exit status
is main()'s return value through the simulator call, and the UART's bytes land in a file.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from uros_helpers import humble_mirror_args, run_uros, s3_compiler_skip

from uros_build.run import machines
from uros_build.target import abi

pytestmark = pytest.mark.integration

PREFIX = "xtensa-esp32s3-elf-"
QEMU = os.environ.get("UROS_ESP32S3_QEMU", "")
SPECS = "--specs=picolibc-esp32s3.specs"

MAIN = r"""
#include <stdint.h>
#include "probe.h"

extern uint32_t probe_data_image, probe_data_start, probe_data_end, probe_bss_start, probe_bss_end;
void probe_memory_init(const uint8_t *sp) { /* picolibc.c's, without the C library */
  (void)sp;
  uint32_t *from = &probe_data_image, *to = &probe_data_start;
  while (to < &probe_data_end) *to++ = *from++;
  for (to = &probe_bss_start; to < &probe_bss_end;) *to++ = 0u;
}

static void say(const char *text, int link) {
  for (; *text; text++) link ? probe_link_put((uint8_t)*text) : probe_console_put((uint8_t)*text);
}

volatile float fa = 1.5f, fb = 2.25f, fc = 0.5f;
volatile int32_t n = -1000003, d = 7;
volatile uint64_t big = 1795838795990442123ull; /* nanoseconds: the clock's 64-bit arithmetic */
volatile int shift = 37;
static uint32_t atom = 5u;

__attribute__((noinline)) static int32_t deep(int32_t k) { /* a register window per call */
  volatile int32_t pad[4] = {k, k + 1, k + 2, k + 3};
  return k == 0 ? 0 : deep(k - 1) + pad[3] - pad[0] - 2;
}

int main(void) {
  say("uros-s3: uart\r\n", 1);
  float r = fa * fb + fc;                                     /* madd.s: 3.875 */
  int32_t q = n / d;                                          /* quos: -142857 */
  uint32_t old = __atomic_exchange_n(&atom, 9u, __ATOMIC_SEQ_CST); /* s32c1i loop */
  int32_t depth = deep(100);                                  /* window overflows and underflows */
  if (r != 3.875f) return 11;
  if (q != -142857) return 12;
  if (old != 5u || atom != 9u) return 13;
  if (depth != 100) return 14;
  if (probe_millis() > 1000u) return 15;
  /* the board's windowed libgcc helpers (no libgcc.a: Debian's is call0) */
  if (big / 1000000u != 1795838795990ull || big % 1000000u != 442123u) return 16; /* __udivmoddi4 */
  if (-(int64_t)big % 1000 != -123) return 17;                                    /* __moddi3 */
  if ((big << shift) != 0x9c04116000000000ull || (big >> shift) != 0xc760ceu) return 18;
  if ((-(int64_t)big >> shift) != -0xc760cfll) return 19;                         /* __ashrdi3 */
  if (fa / fb * 9.0f != 6.0f) return 20;                                          /* __divsf3 */
  say("uros-s3: fpu quos s32c1i windows libgcc ok\n", 0);
  return 42;
}
"""


def _tool(name: str, *args: str) -> str:
    env = {**os.environ, "LC_ALL": "C"}
    return subprocess.run([PREFIX + name, *args], capture_output=True, text=True, check=True, env=env).stdout


@pytest.fixture(scope="module")
def s3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not (QEMU and Path(QEMU).is_file()):
        pytest.skip(
            "set UROS_ESP32S3_QEMU to a qemu-system-xtensa with the esp32s3 CPU (tests/esp32s3-qemu-env.sh)"
        )
    listed = subprocess.run([QEMU, "-cpu", "help"], capture_output=True, text=True, check=False).stdout
    if "esp32s3" not in listed.split():
        pytest.skip(f"{QEMU} -cpu help lists no esp32s3")
    tmp = tmp_path_factory.mktemp("s3qemu")
    why = s3_compiler_skip(PREFIX, tmp)
    if why:
        pytest.skip(why)
    if not Path(_tool("gcc", f"-print-file-name={SPECS.split('=')[1]}").strip()).is_absolute():
        pytest.skip("no windowed picolibc for the S3 compiler (tests/esp32s3-picolibc-env.sh)")
    return tmp


def test_bare_metal_s3_code_runs_on_the_lx60_board_with_the_s3_core(s3: Path) -> None:
    machine = machines.machine_for("esp32s3-bare", machines.load_machines())
    board = s3 / "board"
    board.mkdir()
    for name, text in machines.board_files(machine).items():
        if name.endswith((".ld", ".h")) or name in {
            "board.c",
            "uart_ns16550.c",
            "libgcc_lx106.c",
            "libgcc_windowed.c",
        }:
            (board / name).write_text(text, encoding="utf-8")
    for name in ("probe.h",):
        shutil.copy(machines.firmware_sources() / name, board / name)
    (s3 / "main.c").write_text(MAIN, encoding="utf-8")
    elf = s3 / "fw.elf"
    _tool(
        "gcc", "-mlongcalls", "-O2", "-fno-tree-loop-distribute-patterns", SPECS, "-nostdlib", "-nostartfiles",
        f"-I{board}",
        *(str(board / c) for c in ("board.c", "uart_ns16550.c", "libgcc_lx106.c", "libgcc_windowed.c")),
        str(s3 / "main.c"),
        f"-L{board}", f"-T{board / 'probe.ld'}", "-Wl,--gc-sections", "-o", str(elf),
    )  # fmt: skip
    text = _tool("objdump", "-d", str(elf))
    found = set(abi.XTENSA_MNEMONIC.findall(text))
    assert {"entry", "retw.n", "callx4", "madd.s", "wfr", "quos", "s32c1i", "rfwo", "rfwu"} <= found, found
    uart = s3 / "uart.txt"
    argv = [
        QEMU, "-M", "lx60-nommu", "-cpu", "esp32s3", "-nographic", "-monitor", "none",
        "-semihosting-config", "enable=on,target=native", "-serial", f"file:{uart}", "-kernel", str(elf),
    ]  # fmt: skip
    run = subprocess.run(argv, capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 42, (run.returncode, run.stdout, run.stderr)
    assert "uros-s3: fpu quos s32c1i windows libgcc ok" in run.stdout  # the console: simcall write
    assert uart.read_bytes() == b"uros-s3: uart\r\n"  # the 16550 at 0x7d050020


def test_uros_probe_passes_every_stage_on_the_s3_core(s3: Path) -> None:
    """The real ESP32-S3 library (Humble std_msgs) in the probe firmware on the S3 core, against a real
    agent, through the CLI: QEMU starts paused until the agent holds the pty (machines.yaml
    start_paused), and the restart stage stops and starts the agent under the running firmware."""
    mirror, agent = os.environ.get("UROS_MIRROR"), os.environ.get("UROS_AGENT")
    if not (mirror and agent):
        pytest.skip("set UROS_MIRROR (upstream clones) and UROS_AGENT (a MicroXRCEAgent)")
    ws = Path(os.environ.get("UROS_HUMBLE_WS") or s3 / "fw")
    if not os.environ.get("UROS_HUMBLE_WS"):
        run_uros("create-firmware", "--distro", "humble", "-w", str(ws), *humble_mirror_args(mirror))
    run_uros("build", "--toolchain", "esp32s3-bare", "-w", str(ws), "--packages", "std_msgs")
    proc = run_uros("probe", "--json", "--toolchain", "esp32s3-bare", "-w", str(ws), check=False)
    assert proc.stdout.strip(), proc.stderr
    data = json.loads(proc.stdout)
    assert proc.returncode == 0 and data["status"] == 0, proc.stderr
    assert data["machine"] == "lx60-nommu" and f"qemu: {QEMU} (UROS_ESP32S3_QEMU)" in proc.stderr
    passed = ("session", "samples", "limits", "fragmentation", "time", "restart")
    results = {name: stage["result"] for name, stage in data["stages"].items()}
    assert {name: results[name] for name in passed} == dict.fromkeys(passed, "pass"), results
    assert data["limits"] == {"nodes": 1, "publishers": 1, "subscriptions": 1}
    console = Path(str(data["console_log"])).read_text()
    assert "uros-probe: PASS" in console and "10 came back" in console
    assert "QEMU started paused" in Path(str(data["run_log"])).read_text()
