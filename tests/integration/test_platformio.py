"""Issue 33, item 1: `uros export platformio` built for real by `pio run` (PlatformIO Core from PyPI),
offline: its one core package, tool-scons, made from the SCons that pip installed, and a local
platform whose builder runs Debian's arm-none-eabi-gcc (as a registry platform would: -mcpu and
-mthumb from the board, on compile and link). Every PlatformIO folder is the test's, and every HTTP(S)
request goes to a proxy of the test's that answers none: the test fails if PlatformIO asked for one."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from uros_helpers import need, run_uros

pytestmark = pytest.mark.integration

_MAIN = '#include "fx_core/core.h"\nint main(void) { return fx_core_add(1, 2) == 3 ? 0 : 1; }\n'

# a registry platform's builder in miniature (platform-ststm32's main.py: the board's CPU on
# compile and link; FPU flags come from frameworks or the user's build_flags)
_BUILDER = """\
from SCons.Script import DefaultEnvironment

env = DefaultEnvironment()
board = env.BoardConfig()
machine = ["-mcpu=%s" % board.get("build.cpu"), "-mthumb"]
env.Replace(
    AR="arm-none-eabi-ar", AS="arm-none-eabi-as", CC="arm-none-eabi-gcc", CXX="arm-none-eabi-g++",
    RANLIB="arm-none-eabi-ranlib", OBJCOPY="arm-none-eabi-objcopy", SIZETOOL="arm-none-eabi-size",
    PROGNAME="firmware", PROGSUFFIX=".elf",
)
env.Append(CCFLAGS=machine + ["-Os"], LINKFLAGS=machine + ["--specs=nosys.specs"])
env.Default(env.BuildProgram())
"""


class _Proxy:
    """A proxy on loopback that records every connection and answers none."""

    def __init__(self) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        self.requests: list[bytes] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            with conn:
                conn.settimeout(2)
                try:
                    self.requests.append(conn.recv(200))
                except OSError:
                    self.requests.append(b"?")


@pytest.fixture(scope="module")
def pio_env(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, str]]:
    """The environment of an offline PlatformIO whose folders are all the test's, with tool-scons."""
    need("pio")
    tmp_path = tmp_path_factory.mktemp("pio")
    proxy = _Proxy()
    env = {
        **os.environ,
        "PLATFORMIO_CORE_DIR": str(tmp_path / "pio-core"),
        "PLATFORMIO_SETTING_ENABLE_TELEMETRY": "no",
        "PLATFORMIO_DISABLE_UPGRADE_CHECK": "true",
        "PLATFORMIO_DISABLE_PROGRESSBAR": "true",
        "PLATFORMIO_NO_ANSI": "true",
        **{name: proxy.url for name in ("HTTP_PROXY", "HTTPS_PROXY", "http_proxy", "https_proxy")},
        "NO_PROXY": "",
        "no_proxy": "",
    }
    env.pop("ALL_PROXY", None)
    env.pop("all_proxy", None)
    # PlatformIO Core pins one tool-scons version (platformio/dependencies.py); SCons 4 from PyPI,
    # under that version, is what it runs
    pio = shutil.which("pio")
    assert pio is not None
    python = Path(pio).resolve().parent / "python"
    asks = subprocess.run(
        [str(python), "-c", "from platformio.dependencies import get_core_dependencies as d\n"
         "import SCons, os\nprint(d()['tool-scons'].lstrip('~^=')); print(os.path.dirname(SCons.__file__))"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert asks.returncode == 0, f"scons (pyproject's test extra) beside platformio: {asks.stderr}"
    version, scons_dir = asks.stdout.split()
    tool = tmp_path / "tool-scons"
    shutil.copytree(scons_dir, tool / "SCons", ignore=shutil.ignore_patterns("__pycache__"))
    (tool / "scons.py").write_text(
        "import os, sys\nsys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))\n"
        "import SCons.Script\nSCons.Script.main()\n"
    )
    (tool / "package.json").write_text(json.dumps({"name": "tool-scons", "version": version}))
    _pio(env, "pkg", "install", "--global", "--tool", f"file://{tool}")
    # a package installed from a folder records no owner; PlatformIO looks for platformio's
    piopm = tmp_path / "pio-core/packages/tool-scons/.piopm"
    meta = json.loads(piopm.read_text())
    meta["spec"]["owner"] = "platformio"
    piopm.write_text(json.dumps(meta))
    yield env
    proxy.sock.close()
    assert proxy.requests == [], f"PlatformIO went to the network: {proxy.requests}"


def _pio(env: dict[str, str], *args: str, cwd: Path | None = None, check: bool = True) -> str:
    proc = subprocess.run(["pio", *args], env=env, cwd=cwd, capture_output=True, text=True, timeout=300)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0 or not check, out
    return out


def _firmware(tmp_path: Path, lib: Path, build_flags: str | None) -> Path:
    """A PlatformIO project on the local platform and a Cortex-M7 board, using the library ``lib``."""
    platform = tmp_path / "platform"
    (platform / "builder").mkdir(parents=True)
    (platform / "platform.json").write_text(
        json.dumps({"name": "uroslocal", "title": "uros local", "version": "0.1.0", "packages": {}})
    )
    (platform / "platform.py").write_text(
        "from platformio.public import PlatformBase\n\n\nclass UroslocalPlatform(PlatformBase):\n    pass\n"
    )
    (platform / "builder/main.py").write_text(_BUILDER)
    project = tmp_path / "firmware"
    (project / "src").mkdir(parents=True)
    (project / "boards").mkdir()
    (project / "boards/m7board.json").write_text(
        json.dumps({
            "build": {"cpu": "cortex-m7", "mcu": "m7", "f_cpu": "216000000L"},
            "frameworks": [], "name": "A Cortex-M7 board", "upload": {"maximum_ram_size": 524288,
            "maximum_size": 2097152}, "url": "https://example.invalid", "vendor": "uros tests",
        })
    )  # fmt: skip
    (project / "src/main.c").write_text(_MAIN)
    ini = [
        "[env:m7board]",
        f"platform = symlink://{platform}",
        "board = m7board",
        f"lib_deps = file://{lib}",
    ]
    (project / "platformio.ini").write_text("\n".join([*ini, *([build_flags] if build_flags else [])]) + "\n")
    return project


def test_pio_run_links_the_exported_library(m7_build: Path, tmp_path: Path, pio_env: dict[str, str]) -> None:
    """The README's platformio.ini lines build a firmware that calls the library, hard-float: the
    export's extra script puts the FPU flags on the link ("uses VFP register arguments,
    firmware.elf does not" without it)."""
    need("arm-none-eabi-gcc", "arm-none-eabi-readelf", "arm-none-eabi-nm")
    lib = tmp_path / "micro_ros"
    run_uros("export", "platformio", "--from", str(m7_build / "build" / "cortex-m7"), "--output", str(lib))
    flags = "build_flags = -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard"
    project = _firmware(tmp_path, lib, flags)
    out = _pio(pio_env, "run", "-v", cwd=project)
    assert "[SUCCESS]" in out, out
    elf = project / ".pio/build/m7board/firmware.elf"
    env = {**os.environ, "LC_ALL": "C"}
    attributes = subprocess.run(
        ["arm-none-eabi-readelf", "-A", str(elf)], capture_output=True, text=True, env=env, check=True
    ).stdout
    assert "Tag_ABI_VFP_args: VFP registers" in attributes, attributes
    assert "Tag_FP_arch: FPv5/FP-D16 for ARMv8" in attributes, attributes
    nm = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, env=env, check=True)
    assert " T fx_core_add" in nm.stdout, nm.stdout


def test_pio_run_names_the_build_flags_a_firmware_lacks(
    m7_build: Path, tmp_path: Path, pio_env: dict[str, str]
) -> None:
    """A firmware compiled soft-float (no build_flags) stops with one line naming the line to add,
    not with the linker's VFP error."""
    need("arm-none-eabi-gcc")
    lib = tmp_path / "micro_ros"
    run_uros("export", "platformio", "--from", str(m7_build / "build" / "cortex-m7"), "--output", str(lib))
    out = _pio(pio_env, "run", cwd=_firmware(tmp_path, lib, None), check=False)
    assert "VFP register arguments" not in out, out
    assert (
        "Error: micro_ros_uros: libmicroros.a is built for cortex-m7 with -mcpu=cortex-m7 -mthumb "
        "-mfpu=fpv5-d16 -mfloat-abi=hard, this firmware compiles without -mfloat-abi, without -mfpu: "
        "add to platformio.ini `build_flags = -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard`"
    ) in out, out
