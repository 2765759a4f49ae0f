"""Real ESP32-S3 code (issue 42, item 1): micro-ROS Humble built with a compiler that emits the S3 core's
instructions, proven with objdump over the library, not with uros's own check alone.

The compiler: `xtensa-esp32s3-elf-*` on PATH that makes Espressif-core code, e.g. the wrappers
tests/esp32s3-real-env.sh makes around Debian 13's gcc-xtensa-lx106 13.3 + the ESP32-S3 dynconfig plugin
(or Espressif's own). The stand-in of tests/esp32s3-compat-env.sh (Debian 12's GCC 12: lx106 code) is
told apart by compiling a probe and skipped. No ESP-IDF here: the library is the bare-metal build of the
S3 (picolibc's headers, the custom transport; the profile is esp8266.yaml's with the S3's prefix and the
windowed ABI); tests/integration/test_esp32s3_proof.py is the ESP-IDF side. Needs UROS_MIRROR (and
UROS_HUMBLE_WS for an already-built Humble workspace, as test_probe_cores.py); skips without them.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest
from uros_helpers import REPO, humble_mirror_args, run_uros, s3_compiler_skip

from uros_build.target import abi

pytestmark = pytest.mark.integration

PREFIX = "xtensa-esp32s3-elf-"
MIRROR = os.environ.get("UROS_MIRROR")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")


def _tool(name: str, *args: str) -> str:
    env = {**os.environ, "LC_ALL": "C"}
    return subprocess.run([PREFIX + name, *args], capture_output=True, text=True, check=True, env=env).stdout


@pytest.fixture(scope="module")
def real_s3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not MIRROR:
        pytest.skip("set UROS_MIRROR (upstream clones)")
    tmp = tmp_path_factory.mktemp("s3real")
    why = s3_compiler_skip(PREFIX, tmp)
    if why:
        pytest.skip(why)
    return tmp


def _profile(tmp: Path) -> Path:
    text = (REPO / "toolchains" / "esp8266.yaml").read_text(encoding="utf-8")
    text = text.replace("name: esp8266", "name: esp32s3-real")
    text = text.replace("compiler_prefix: xtensa-lx106-elf-", f"compiler_prefix: {PREFIX}")
    text = text.replace('xtensa_abi: "1"', 'xtensa_abi: "0"')
    # ESP-IDF defines no 1/2/4-byte atomics on the S3: the check reports any left undefined
    text = text.replace(
        "native_64bit_atomics: false", 'native_64bit_atomics: false\nmissing_atomics: ["1", "2", "4"]'
    )
    path = tmp / "esp32s3-real.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_humble_for_the_s3_holds_fpu_s32c1i_and_the_windowed_abi_everywhere(real_s3: Path) -> None:
    ws = Path(HUMBLE_WS) if HUMBLE_WS else real_s3 / "fw"
    if not HUMBLE_WS:
        run_uros("create-firmware", "--distro", "humble", "-w", str(ws), *humble_mirror_args(str(MIRROR)))
    run_uros("build", "--profile", str(_profile(real_s3)), "-w", str(ws), "--packages", "std_msgs")
    out = ws / "build" / "esp32s3-real"
    lib = out / "libmicroros.a"
    info = json.loads((out / "build-info.json").read_text(encoding="utf-8"))
    assert info["abi_check"]["result"] == "pass" and "undefined_atomics" not in info["abi_check"]
    # every member: .xtensa.info ABI=0 (windowed), read with readelf, not with uros
    dump = _tool("readelf", "--string-dump=.xtensa.info", str(lib))
    members = re.findall(r"^File: .*\((.*)\)$", _tool("readelf", "-h", str(lib)), re.M)
    abis = re.findall(r"^File: .*\((.*)\)$\n(?:.*\n)*?.*\bABI=(\d)", dump, re.M)
    assert len(members) > 300 and sorted(m for m, a in abis if a == "0") == sorted(members)
    # the instructions: the S3's FPU and S32C1I; windowed calls and returns only
    text = _tool("objdump", "-d", str(lib))
    mnemonics: dict[str, int] = {}
    for found in abi.XTENSA_MNEMONIC.findall(text):
        mnemonics[found] = mnemonics.get(found, 0) + 1
    # (Humble std_msgs has no a*b+c in float: madd.s is in the doctor's probe, not here; measured
    # 2026-11-28: float.s, ufloat.s, trunc.s, oeq.s, wfr, rfr, 2 s32c1i, quou/remu, muluh/mulsh, loop)
    for insn in ("entry", "wfr", "rfr", "s32c1i", "quou", "muluh", "loop"):
        assert mnemonics.get(insn, 0) > 0, (insn, sorted(mnemonics))
    fpu = sorted(m for m in mnemonics if m.endswith(".s"))
    assert len(fpu) >= 3, fpu  # single-precision FPU operations (float.s, trunc.s, oeq.s, ...)
    assert not any(mnemonics.get(insn) for insn in ("ret", "ret.n", "callx0", "call0")), mnemonics
    # every member with code enters its functions windowed
    chunks = re.split(r"^(\S+):\s+file format \S+$", text, flags=re.M)
    with_code = 0
    for name, body in zip(chunks[1::2], chunks[2::2], strict=True):
        insns = abi.XTENSA_MNEMONIC.findall(body)
        if insns:
            with_code += 1
            assert "entry" in insns, name
    assert with_code > 300
    # no atomic routine of 1, 2 or 4 bytes left for the firmware: they are inline s32c1i loops
    undefined = set(re.findall(r"^\s+U (\S+)$", _tool("nm", str(lib)), re.M))
    atomics = sorted(s for s in undefined if (m := abi.ATOMIC_ROUTINE.fullmatch(s)) and m["size"] != "8")
    assert atomics == []
    (real_s3 / "counts.json").write_text(json.dumps(mnemonics, sort_keys=True), encoding="utf-8")
