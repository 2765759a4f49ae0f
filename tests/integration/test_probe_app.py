"""`uros probe --app DIR` (issue 31, items 1 and 3): a user's rclc application with micro_ros_setup's
`void appMain(void *arg)` runs unchanged on the probe's board in QEMU against a real Micro XRCE-DDS
Agent; the seeds' applications (examples/stm32h7-custom, examples/esp32s3-idf/app) are two of them.

The runs need UROS_AGENT (a MicroXRCEAgent), UROS_HUMBLE_WS (an already built humble workspace whose
cortex-m7 output has eic_demo_interface and demo_interfaces, e.g. a copy of docs/real-humble.md's)
and qemu-system-arm; without them they skip. The error paths before anything is built run in CI,
against the fixture library.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from uros_helpers import REPO, run_uros, run_uros_here

pytestmark = pytest.mark.integration

AGENT = os.environ.get("UROS_AGENT")
FREERTOS = os.environ.get("UROS_FREERTOS")
HUMBLE_WS = os.environ.get("UROS_HUMBLE_WS")
SEED_001 = REPO / "examples" / "stm32h7-custom"
SEED_000 = REPO / "examples" / "esp32s3-idf" / "app"
_RUNS = pytest.mark.skipif(
    not (AGENT and HUMBLE_WS and shutil.which("qemu-system-arm")),
    reason="set UROS_AGENT (a MicroXRCEAgent) and UROS_HUMBLE_WS (a built humble workspace with "
    "eic_demo_interface and demo_interfaces for cortex-m7), and install qemu-system-arm",
)


def _one_error(proc: subprocess.CompletedProcess[str]) -> str:
    assert "Traceback" not in proc.stderr, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


def _app(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "app.c").write_text(text)
    return folder


# -- before anything is built (CI) ------------------------------------------------------------------
# In process (run_uros_here: no process may start) against the built fixture's snapshot itself, read
# in place: a refusal made before anything runs writes nothing beside the output.


def test_an_app_folder_that_is_not_there_or_has_no_appmain(m7_snapshot: Path, tmp_path: Path) -> None:
    out = m7_snapshot / "build" / "cortex-m7"
    proc = run_uros_here("probe", str(out), "--app", str(tmp_path / "nowhere"), check=False)
    assert proc.returncode == 2
    assert f"--app {tmp_path / 'nowhere'}: no such folder" in _one_error(proc)
    app = _app(tmp_path / "plain", "int main(void) { return 0; }\n")
    proc = run_uros_here("probe", str(out), "--app", str(app), check=False)
    assert proc.returncode == 2
    assert "no C file defines void appMain(void *arg) (app.c)" in _one_error(proc)


def test_an_app_using_a_package_the_library_lacks_fails_before_building(
    m7_snapshot: Path, tmp_path: Path
) -> None:
    out = m7_snapshot / "build" / "cortex-m7"
    have = json.loads((out / "build-info.json").read_text())["packages"]
    assert "geometry_msgs" not in have
    app = _app(
        tmp_path / "teleop",
        "#include <rclc/rclc.h>\n#include <geometry_msgs/msg/twist.h>\n"
        "void appMain(void *arg) { (void)arg; }\n",
    )
    env: dict[str, str | None] = {"UROS_AGENT": None}  # checked before any tool
    proc = run_uros_here("probe", str(out), "--app", str(app), env=env, check=False)
    assert proc.returncode == 2, proc.stderr
    line = _one_error(proc)
    assert f"--app {app}: the library {out.resolve()} lacks geometry_msgs (app.c:2)" in line
    assert f"uros build -w {m7_snapshot.resolve()} --packages geometry_msgs" in proc.stderr
    assert "uros add-package" in proc.stderr
    assert not list((m7_snapshot / ".uros").glob("probe/app-*")), "nothing may be built"


def test_duration_and_defines_only_with_an_app(m7_snapshot: Path) -> None:
    out = m7_snapshot / "build" / "cortex-m7"
    proc = run_uros_here("probe", str(out), "--duration", "3", check=False)
    assert proc.returncode == 2 and "--duration: only with --app DIR" in _one_error(proc)
    proc = run_uros_here("probe", str(out), "--app", str(SEED_000), "--duration", "0", check=False)
    assert proc.returncode == 2 and "--duration 0: must be a number of seconds more than 0" in _one_error(
        proc
    )


def test_an_app_folder_that_is_a_symlink_loop_is_one_line(m7_snapshot: Path, tmp_path: Path) -> None:
    """Issue 43: a link loop as --app was an internal error (Path.resolve's RuntimeError)."""
    out = m7_snapshot / "build" / "cortex-m7"
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    proc = run_uros_here("probe", str(out), "--app", str(tmp_path / "a"), check=False)
    assert proc.returncode == 2, proc.stderr
    assert f"--app {tmp_path / 'a'}: cannot be followed" in _one_error(proc)


@pytest.mark.parametrize(
    ("define", "said"),
    [
        ("UROS_APP_DURATION_MS=1", "UROS_APP_DURATION_MS is the probe board's own"),
        ("PROBE_CLOCK_HZ=1", "PROBE_CLOCK_HZ is the probe board's own"),
        ('MSG="a\nb"', "holds the control character '\\n'"),
    ],
)
def test_the_runners_macros_and_line_breaks_are_refused_up_front(
    m7_snapshot: Path, tmp_path: Path, define: str, said: str
) -> None:
    """Issue 43: `-D UROS_APP_DURATION_MS=1` made any app "run for the whole --duration"; a line break
    in a value failed deep in make. Both are one line now, before any process starts."""
    out = m7_snapshot / "build" / "cortex-m7"
    app = _app(tmp_path / "app", "void appMain(void *arg) { (void)arg; }\n")
    env: dict[str, str | None] = {"UROS_AGENT": None}  # refused before any tool is looked for
    proc = run_uros_here("probe", str(out), "--app", str(app), "-D", define, env=env, check=False)
    assert proc.returncode == 2, proc.stderr
    assert said in _one_error(proc)


@pytest.mark.parametrize("name", ["a:b.c", "a$<1:gen>.c", "a\nb.c", "a b.h"])
def test_file_names_the_build_files_cannot_carry_are_refused_up_front(
    m7_snapshot: Path, tmp_path: Path, name: str
) -> None:
    out = m7_snapshot / "build" / "cortex-m7"
    app = _app(tmp_path / "app", "void appMain(void *arg) { (void)arg; }\n")
    (app / name).write_text("int x;\n")
    env: dict[str, str | None] = {"UROS_AGENT": None}
    proc = run_uros_here("probe", str(out), "--app", str(app), env=env, check=False)
    assert proc.returncode == 2, proc.stderr
    assert f"the file name {name!r} cannot be written into the build files" in _one_error(proc)


# -- against the agent (UROS_AGENT, UROS_HUMBLE_WS) -------------------------------------------------


@pytest.fixture(scope="module")
def humble_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the workspace's cortex-m7 output (8 MB; a probe writes its work folder beside the
    output's workspace, so the shared workspace is never written)."""
    assert HUMBLE_WS
    out = tmp_path_factory.mktemp("humble") / "cortex-m7"
    shutil.copytree(Path(HUMBLE_WS) / "build" / "cortex-m7", out, symlinks=True)
    packages = json.loads((out / "build-info.json").read_text())["packages"]
    assert {"eic_demo_interface", "demo_interfaces"} <= set(packages), packages
    return out


def _run_app(out: Path, tmp_path: Path, *args: str) -> tuple[int, str, dict[str, object] | None]:
    env = {**os.environ, "TMPDIR": str(tmp_path)}  # the work folder of an output outside a workspace
    proc = run_uros("probe", str(out), "--json", *args, env=env, check=False)
    data = json.loads(proc.stdout) if proc.stdout.strip() else None
    return proc.returncode, proc.stderr, data


def _console(data: dict[str, object]) -> str:
    return Path(str(data["console_log"])).read_text()


@_RUNS
def test_seed_001_cmdvel_publisher_and_gettime_server(humble_out: Path, tmp_path: Path) -> None:
    """Seed 001's app: CmdVel out and back through the agent intact, GetTime served to its own
    client, rcl's allocator through the board heap (microros_allocate & co)."""
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(SEED_001))
    assert data is not None, err
    assert code == 0 and data["status"] == 0 and data["passed"] is True, err + _console(data)
    assert data["packages"] == ["eic_demo_interface"] and data["machine"] == "mps2-an500"
    assert 50_000 < int(str(data["flash_bytes"])) < 200_000 and int(str(data["ram_bytes"])) > 0
    assert data["heap_bytes"] and data["stack_bytes"]
    assert float(str(data["seconds"])) < 15, _console(data)
    console = _console(data)
    assert "app: PASS 10 CmdVel back, get_time answered" in console
    assert "app: clock synchronised with the agent" in console
    assert "app passed: " in err and "exit(0)" in err and "flash " in err and "heap " in err


@_RUNS
def test_seed_000_hsb_node_hears_its_own_state(humble_out: Path, tmp_path: Path) -> None:
    """Seed 000's node logic (the ESP32-S3 example's own app.c) on a Cortex-M7: the timer publishes
    Hsb on state/led/hsb, the agent routes it back to the node's subscription (HSB_LOOPBACK), the
    state follows the commands."""
    code, err, data = _run_app(
        humble_out, tmp_path, "--app", str(SEED_000),
        "-D", "HSB_LOOPBACK", "-D", "HSB_EXIT_AFTER=3", "-D", "HSB_STATE_PERIOD_MS=200",
    )  # fmt: skip
    assert code == 0, err
    assert data is not None and data["status"] == 0 and data["packages"] == ["demo_interfaces"]
    console = _console(data)
    assert "Created publisher state/led/hsb." in console and "Created subscriber state/led/hsb." in console
    assert console.count("microros_demo: LED now HSB 30,100,50") >= 3
    assert "microros_demo: PASS 3 commands applied" in console


@_RUNS
def test_an_app_that_never_exits_runs_for_the_duration(humble_out: Path, tmp_path: Path) -> None:
    code, err, data = _run_app(
        humble_out, tmp_path, "--app", str(SEED_000), "-D", "HSB_STATE_PERIOD_MS=200", "--duration", "2"
    )
    assert code == 0, err
    assert data is not None and data["status"] == 83 and data["duration"] == 2.0
    assert "ran for the whole --duration (2 s) without exiting or crashing" in err
    assert data["heap_bytes"] and data["stack_bytes"]  # the board measured them when it ended the run


@_RUNS
@pytest.mark.parametrize(
    ("body", "status", "said"),
    [
        ("return;", 82, "appMain returned without exit(status)"),
        ("exit(3);", 3, "the app exited with 3"),
        ("*(volatile int *)0xF0000000u = 1;", 70, "the app crashed (hard fault)"),
    ],
)
def test_an_app_that_returns_fails_or_crashes_gets_its_verdict(
    humble_out: Path, tmp_path: Path, body: str, status: int, said: str
) -> None:
    app = _app(
        tmp_path / "bad",
        "#include <stdlib.h>\n#include <std_msgs/msg/int32.h>\n"
        f"void appMain(void *arg) {{ (void)arg; {body} }}\n",
    )
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app), "--timeout", "30")
    assert code == 5, err
    assert data is not None and data["status"] == status and data["passed"] is False
    assert f"app failed: {app} on cortex-m7 in QEMU mps2-an500: {said}" in _one_error(
        subprocess.CompletedProcess([], code, "", err)
    )


@_RUNS
def test_a_package_the_real_library_lacks(humble_out: Path, tmp_path: Path) -> None:
    app = _app(
        tmp_path / "nav", "#include <nav_msgs/msg/odometry.h>\nvoid appMain(void *arg) { (void)arg; }\n"
    )
    code, err, _ = _run_app(humble_out, tmp_path, "--app", str(app))
    assert code == 2
    assert "lacks nav_msgs (app.c:1)" in err and "--packages nav_msgs" in err
    assert "configure the uros_app firmware" not in err


@_RUNS
@pytest.mark.skipif(not FREERTOS, reason="set UROS_FREERTOS to a FreeRTOS-Kernel checkout (V11.x)")
def test_seed_001_on_freertos_with_the_kernel_heap(humble_out: Path, tmp_path: Path) -> None:
    """The same app on FreeRTOS (--freertos): appMain in the probe's task, micro-ROS's allocator and
    the app's microros_allocate & co on the kernel's heap (pvPortMalloc, heap_4), the clock the
    kernel's tick; --duration ends the run from the kernel's tick as on bare metal."""
    assert FREERTOS
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(SEED_001), "--freertos", FREERTOS)
    assert data is not None, err
    assert code == 0 and data["status"] == 0 and data["rtos"] == "freertos", err + _console(data)
    console = _console(data)
    assert "uros-probe: FreeRTOS V11" in console and "app: PASS 10 CmdVel back" in console
    assert "on FreeRTOS: exit(0)" in err
    code, err, data = _run_app(
        humble_out, tmp_path, "--app", str(SEED_000), "-D", "HSB_STATE_PERIOD_MS=200", "--duration", "2",
        "--freertos", FREERTOS,
    )  # fmt: skip
    assert code == 0 and data is not None and data["status"] == 83, err


# -- issue 43: what an app cannot forge, and -D and names as typed (UROS_AGENT, UROS_HUMBLE_WS) ------

_PRINTS = (
    "#include <stdio.h>\n#include <stdlib.h>\n"
    "#define STR2(x) #x\n#define STR(x) STR2(x)\n"
    "void appMain(void *arg) {\n  (void)arg;\n"
    '  printf("V=[%s] A=[%s] B=[%s] C=[%s] D=[%s]\\n", STR(V), A, B, C, D);\n'
    "  exit(EXIT_CODE);\n}\n"
)


@_RUNS
@pytest.mark.parametrize("status", [256, 512, -256, 326, 337])
def test_an_exit_status_is_read_whole(humble_out: Path, tmp_path: Path, status: int) -> None:
    """exit(256) was QEMU's 0 (a pass), exit(326) its 70 (a "hard fault"), exit(337) its 81 ("no
    agent"): the runner's end line has the whole int, and QEMU's status is the runner's choice (64)."""
    app = _app(
        tmp_path / "app", "#include <stdlib.h>\nvoid appMain(void *arg) { (void)arg; exit(EXIT_CODE); }\n"
    )
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app), "-D", f"EXIT_CODE={status}")
    assert code == 5, err
    assert data is not None and data["passed"] is False and data["exit_status"] == status
    assert data["status"] == 64 and data["ended_by"] == "exit"
    assert f"on cortex-m7 in QEMU mps2-an500: the app exited with {status} (" in err


@_RUNS
def test_exit_83_is_not_the_whole_duration(humble_out: Path, tmp_path: Path) -> None:
    """exit(83) after a second passed as "ran for the whole --duration (20 s)"."""
    app = _app(tmp_path / "app", "#include <stdlib.h>\nvoid appMain(void *arg) { (void)arg; exit(83); }\n")
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app), "--duration", "20")
    assert code == 5, err
    assert data is not None and data["passed"] is False and data["exit_status"] == 83
    assert "the app exited with 83" in err and "whole --duration" not in err


@_RUNS
def test_printed_lines_forge_no_figures_and_no_end(humble_out: Path, tmp_path: Path) -> None:
    """The board's figure line printed by the app set the reported heap and stack; a made-up end line
    (another nonce) counts for nothing; an exit through semihosting of the app's own, around the
    board's exit path, was QEMU's 0 and a pass."""
    forged = _app(
        tmp_path / "forged",
        "#include <stdio.h>\n#include <stdlib.h>\nvoid appMain(void *arg) {\n  (void)arg;\n"
        '  printf("\\nuros-probe: heap 1 B, stack 1 B\\n");\n'
        '  printf("uros-probe-0123456789abcdef0123456789abcdef: end exit 0 heap 1 B stack 1 B\\n");\n'
        "  exit(0);\n}\n",
    )
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(forged))
    assert code == 0 and data is not None and data["passed"] is True, err
    assert int(str(data["heap_bytes"])) > 1 and int(str(data["stack_bytes"])) > 1
    around = _app(
        tmp_path / "around",
        "#include <stdint.h>\nvoid appMain(void *arg) {\n  (void)arg;\n  uint32_t block[2] = {0x20026u, 0u};\n"
        '  register uint32_t r0 __asm("r0") = 0x20u;\n  register const void *r1 __asm("r1") = block;\n'
        '  __asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");\n}\n',
    )
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(around))
    assert code == 5, err
    assert data is not None and data["status"] == 0 and data["passed"] is False
    assert "without the runner's end line" in err


@_RUNS
@pytest.mark.parametrize(
    ("files", "said"),
    [
        (
            {
                "app.c": "#include <stddef.h>\n#include <stdlib.h>\nsize_t probe_heap_used(void) { return 1; }\n"
                "void appMain(void *arg) { (void)arg; exit(0); }\n"
            },
            "app.c defines probe_heap_used, which the probe's board defines",
        ),
        (
            {
                "app.c": "#include <stddef.h>\n#include <stdlib.h>\nsize_t probe_stack_used(void) { return 1; }\n"
                "void appMain(void *arg) { (void)arg; exit(0); }\n"
            },
            "app.c defines probe_stack_used, which the probe's board defines",
        ),
        (
            {"app.c": "int main(void) { return 0; }\nvoid appMain(void *arg) { (void)arg; }\n"},
            "app.c defines main, which the probe's board defines (its runner is main",
        ),
        (
            {"app.c": "void _exit(int s) { (void)s; for (;;) {} }\nvoid appMain(void *arg) { (void)arg; }\n"},
            "app.c defines _exit, which the probe's board defines",
        ),
        (
            {
                "a.c": "void appMain(void *arg) { (void)arg; }\n",
                "b.c": "void appMain(void *arg) { (void)arg; }\n",
            },
            "appMain is defined in both a.c and b.c",
        ),
        (
            {"app.c": "/*\nvoid appMain(void *arg) {\n}\n*/\nvoid other(void) {}\n"},
            "no C file defines void appMain(void *arg) once compiled (app.c: only in a comment",
        ),
    ],
)
def test_what_the_apps_objects_define_is_checked_before_qemu(
    humble_out: Path, tmp_path: Path, files: dict[str, str], said: str
) -> None:
    """A weak board function the app defines was taken silently (forged figures); main, _exit and a
    second appMain were collect2's "ld returned 1 exit status"; an appMain only in a comment passed the
    scan and failed in the linker."""
    app = tmp_path / "app"
    app.mkdir()
    for name, text in files.items():
        (app / name).write_text(text)
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app))
    assert code == 2 and data is None, err
    assert said in _one_error(subprocess.CompletedProcess([], code, "", err))
    assert "QEMU" not in err.split("error:", 1)[1]


@_RUNS
def test_defines_and_names_reach_the_compiler_as_typed(humble_out: Path, tmp_path: Path) -> None:
    """`-D 'MSG="a#b"'` was dropped, `V=0;V=3` two defines, `$(id)` expanded by make, `$<1:gen>` by
    CMake, `"a;b"` split; a folder named with a line break, ':' or `$<` failed in make or CMake; the
    app's own time.h broke the board's compile."""
    app = _app(tmp_path / "we\nird:$<1:x>#;$(id) folder", _PRINTS)
    (app / "time.h").write_text('#error "the app\'s time.h shadowed the system one"\n')
    code, err, data = _run_app(
        humble_out, tmp_path, "--app", str(app),
        "-D", "V=0;V=3", "-D", 'A="a#b"', "-D", 'B="$(id)"', "-D", 'C="$<1:gen>"', "-D", 'D="a;b \\" \'c\'"',
        "-D", "EXIT_CODE=0",
    )  # fmt: skip
    assert data is not None, err
    assert code == 0 and data["passed"] is True, err + _console(data)
    assert "V=[0;V=3] A=[a#b] B=[$(id)] C=[$<1:gen>] D=[a;b \" 'c']" in _console(data)
    assert "we\\nird" in err  # the folder shown on one line


@_RUNS
@pytest.mark.skipif(not FREERTOS, reason="set UROS_FREERTOS to a FreeRTOS-Kernel checkout (V11.x)")
def test_on_freertos_the_kernels_assertion_is_the_boards_and_exit_73_the_apps(
    humble_out: Path, tmp_path: Path
) -> None:
    """The kernel's assertion ends the run with interrupts masked: the board's (73); the app's own
    exit(73) is the app's, whole."""
    assert FREERTOS
    app = _app(
        tmp_path / "assert",
        '#include "FreeRTOS.h"\n#include "queue.h"\nvoid appMain(void *arg) {\n  (void)arg;\n  int x = 0;\n'
        "  (void)xQueueGenericSend(NULL, &x, 0, queueSEND_TO_BACK);\n}\n",
    )
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app), "--freertos", FREERTOS)
    assert code == 5 and data is not None and data["ended_by"] == "board" and data["status"] == 73, err
    assert "a FreeRTOS assertion failed (see the console)" in err
    app = _app(tmp_path / "exit73", "#include <stdlib.h>\nvoid appMain(void *arg) { (void)arg; exit(73); }\n")
    code, err, data = _run_app(humble_out, tmp_path, "--app", str(app), "--freertos", FREERTOS)
    assert code == 5 and data is not None and data["ended_by"] == "exit" and data["exit_status"] == 73, err
    assert "the app exited with 73" in err and data["status"] == 64
