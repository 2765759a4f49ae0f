"""`uros probe --app`'s pure pieces (run/app.py, run/appverdict.py): the app folder scanned for
appMain and for the interface packages its #includes name, the one-line message for packages the library lacks, the
defines and --duration checked, the firmware's CMakeLists escaped, the verdicts, the size line."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from uros_build.errors import ConfigError, StepFailed
from uros_build.output.symbols import NmSymbol
from uros_build.probesteps import plan as probe_plan
from uros_build.run import app, appverdict
from uros_build.run.stages import ConsoleLine
from uros_build.target.toolsearch import bintools_beside

REPO = Path(__file__).resolve().parents[2]
APP_MAIN = "void appMain(void *arg)\n{\n  (void)arg;\n}\n"


def _app(tmp_path: Path, text: str, name: str = "app.c") -> Path:
    folder = tmp_path / "my app"
    folder.mkdir(exist_ok=True)
    (folder / name).write_text(text)
    return folder


def test_includes_name_the_interface_packages_with_their_line() -> None:
    text = (
        "#include <rcl/rcl.h>\n"
        "#include <eic_demo_interface/msg/cmd_vel.h>\n"
        '  #  include "eic_demo_interface/srv/get_time.h"\n'
        "#include <std_msgs/msg/detail/int32__struct.h>\n"
        "#include <example_interfaces/action/fibonacci.h>\n"
        "// #include <not_code/msg/x.h> is a comment, but a line starting with # is what counts\n"
        "#include <rosidl_runtime_c/message_type_support_struct.h>\n"
        "#include <uxr/client/transport.h>\n"
    )
    assert app.interface_includes(text) == [
        ("eic_demo_interface", 2),
        ("eic_demo_interface", 3),
        ("std_msgs", 4),
        ("example_interfaces", 5),
    ]


def test_the_seed_apps_name_their_packages() -> None:
    seed001 = app.scan_app(REPO / "examples" / "stm32h7-custom")
    assert list(seed001.packages) == ["eic_demo_interface"]
    assert [p.name for p in seed001.sources] == ["app.c"]
    seed000 = app.scan_app(REPO / "examples" / "esp32s3-idf" / "app")
    assert list(seed000.packages) == ["demo_interfaces"]


def test_headers_beside_the_app_count(tmp_path: Path) -> None:
    folder = _app(tmp_path, '#include "app.h"\n' + APP_MAIN)
    (folder / "app.h").write_text("#include <demo_interfaces/msg/hsb.h>\n")
    scanned = app.scan_app(folder)
    assert scanned.packages == {"demo_interfaces": "app.h:1"}


def test_missing_packages_are_said_in_one_line_with_the_fix(tmp_path: Path) -> None:
    folder = _app(
        tmp_path, "#include <std_msgs/msg/int32.h>\n#include <eic_demo_interface/msg/cmd_vel.h>\n" + APP_MAIN
    )
    scanned = app.scan_app(folder)
    missing = app.missing_packages(scanned, ["std_msgs", "rcl"])
    assert missing == ["eic_demo_interface"]
    error = app.missing_packages_error(scanned, missing, Path("/ws/build/cortex-m7"), Path("/ws"))
    assert "\n" not in error.message and "\n" not in (error.hint or "")
    assert error.message == (
        f"--app {folder}: the library /ws/build/cortex-m7 lacks eic_demo_interface (app.c:2)"
    )
    assert "uros add-package -w /ws" in (error.hint or "")
    assert "uros build -w /ws --packages eic_demo_interface std_msgs" in (error.hint or "")
    assert app.missing_packages(scanned, ["std_msgs", "eic_demo_interface"]) == []


@pytest.mark.parametrize(
    ("files", "message"),
    [
        (None, "no such folder"),
        ({"README.md": "hi"}, "holds no .c file"),
        ({"app.c": "int main(void) { return 0; }\n"}, "no C file defines void appMain"),
        ({"app.c": "void appMain(void *arg);\n"}, "no C file defines void appMain"),  # declared only
    ],
)
def test_a_folder_that_is_no_app_is_refused(
    tmp_path: Path, files: dict[str, str] | None, message: str
) -> None:
    folder = tmp_path / "app"
    if files is not None:
        folder.mkdir()
        for name, text in files.items():
            (folder / name).write_text(text)
    with pytest.raises(ConfigError, match=message) as raised:
        app.scan_app(folder)
    assert raised.value.message.startswith(f"--app {folder}")


def test_defines_are_c_macro_names() -> None:
    assert app.parse_defines(["HSB_LOOPBACK", "HSB_EXIT_AFTER=3", 'TOPIC="a b"']) == (
        "HSB_LOOPBACK",
        "HSB_EXIT_AFTER=3",
        'TOPIC="a b"',
    )
    for bad in ("1X", "A-B=1", "", "X Y"):
        with pytest.raises(ConfigError, match="is not a C macro name"):
            app.parse_defines([bad])
    for bad in ("X=\x01", 'MSG="a\nb"', "X=a\rb"):
        with pytest.raises(ConfigError, match="control character") as raised:
            app.parse_defines([bad])
        assert "\n" not in raised.value.message


@pytest.mark.parametrize("name", ["UROS_APP_DURATION_MS=1", "UROS_APP_NONCE", "PROBE_CLOCK_HZ=1", "UROS_X"])
def test_the_runners_macro_names_are_refused(name: str) -> None:
    with pytest.raises(ConfigError, match="is the probe board's own") as raised:
        app.parse_defines([name])
    assert "--duration" in (raised.value.hint or "")


def test_the_response_file_gives_the_compiler_each_define_as_typed() -> None:
    """GCC reads @file as libiberty's buildargv does: a backslash takes the next character as it is
    (POSIX shlex splits the same way for text without control characters)."""
    defines = [
        'MSG="a#b"',
        "EXIT_CODE=0;EXIT_CODE=3",
        "X=$(id)",
        "Y=$<1:gen>",
        'Z="a;b"',
        "Q='\\ `x` ${Y}'",
        "E=",
    ]
    text = app.response_file(defines)
    assert shlex.split(text) == [f"-D{d}" for d in defines]
    assert app.response_file([]) == ""


@pytest.mark.parametrize("duration", [0.0, -1.0, float("nan"), float("inf"), 90000.0])
def test_a_duration_that_is_no_time_is_refused(duration: float) -> None:
    with pytest.raises(ConfigError, match="--duration"):
        app.check_duration(duration)


def test_durations_and_timeouts() -> None:
    assert app.check_duration(None) == 0
    assert app.check_duration(2.5) == 2500
    assert app.session_timeout(60.0, 0) == 60.0
    assert app.session_timeout(60.0, 5000) == 5 * app.DURATION_SLOWDOWN + app.DURATION_GRACE


def test_define_or_duration_without_app_is_refused() -> None:
    assert probe_plan.app_request(None, (), None) is None
    with pytest.raises(ConfigError, match="--duration: only with --app"):
        probe_plan.app_request(None, (), 3.0)
    with pytest.raises(ConfigError, match="--define: only with --app"):
        probe_plan.app_request(None, ("X",), None)


NONCE = "0123456789abcdef0123456789abcdef"


def test_the_cmakelists_names_no_path_of_the_users(tmp_path: Path) -> None:
    folder = tmp_path / "we\nird:$<1:x>;#${y}$(id)"
    folder.mkdir()
    (folder / "app.c").write_text(APP_MAIN)
    (folder / "b-2.c").write_text("int b;\n")
    scanned = app.scan_app(folder)
    text = app.app_cmake(scanned, ['TOPIC="x${y}"', "N=1"], 3000, NONCE)
    body = [line for line in text.splitlines() if not line.startswith("#")]
    assert not any("ird" in line for line in body), "the folder is reached through app/"
    assert '"app/app.c"' in text and '"app/b-2.c"' in text
    assert "TOPIC" not in text, "the app's -D are in the response file, not in a build file"
    assert '"@${CMAKE_CURRENT_SOURCE_DIR}/app-defines.rsp"' in text
    assert "app-defines.rsp" not in app.app_cmake(scanned, [], 3000, NONCE)
    # the runner's duration and nonce reach app_main.c alone, never the app's objects
    assert (
        'set_property(SOURCE app_main.c APPEND PROPERTY COMPILE_DEFINITIONS "UROS_APP_DURATION_MS=3000"'
        in text
    )
    assert f'"UROS_APP_NONCE=\\"{NONCE}\\""' in text and text.count(NONCE) == 1
    # the board's include path has no folder of the app's, the app's none of the board's
    board = "target_include_directories(uros_probe PRIVATE ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/board)"
    assert board in text and "target_include_directories(uros_app_code" not in text
    assert "target_sources(uros_probe PRIVATE allocators.c)" in text  # bare metal; FreeRTOS: the kernel heap
    assert app.app_cmake(scanned, ['TOPIC="x${y}"', "N=1"], 3000, NONCE) == text  # deterministic


@pytest.mark.parametrize("name", ["a:b.c", "a b.c", "a$<1:x>.c", "a\nb.c", "-x.c", "a#.h", "é.c"])
def test_a_file_name_the_build_files_cannot_carry_is_refused(tmp_path: Path, name: str) -> None:
    folder = _app(tmp_path, APP_MAIN)
    (folder / name).write_text("int x;\n")
    with pytest.raises(ConfigError, match="cannot be written into the build files") as raised:
        app.scan_app(folder)
    assert "\n" not in raised.value.message


def test_a_symlink_loop_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    with pytest.raises(ConfigError, match="cannot be followed"):
        app.scan_app(tmp_path / "a")


def _end(kind: str, status: int, seen: float = 10.0) -> appverdict.RunEnd:
    return appverdict.RunEnd(kind, status, 100, 200, seen)


def test_the_end_line_is_the_runners_with_this_runs_nonce() -> None:
    lines = [
        ConsoleLine(1.0, f"uros-probe-{NONCE}: start"),
        ConsoleLine(2.0, "uros-probe: heap 1 B, stack 1 B"),
        ConsoleLine(2.1, "uros-probe-ffffffffffffffffffffffffffffffff: end exit 0 heap 1 B stack 1 B"),
        ConsoleLine(3.0, f"uros-probe-{NONCE}: end exit 256 heap 1932 B stack 1872 B"),
    ]
    assert appverdict.run_end(lines, NONCE) == appverdict.RunEnd("exit", 256, 1932, 1872, 3.0)
    assert appverdict.app_started(lines, NONCE) == 1.0
    assert appverdict.run_end(lines[:3], NONCE) is None
    twice = [*lines, ConsoleLine(4.0, f"uros-probe-{NONCE}: end exit 0 heap 1 B stack 1 B")]
    assert appverdict.run_end(twice, NONCE) is None


@pytest.mark.parametrize(
    ("end", "code"),
    [
        (_end("exit", 0), 0),
        (_end("exit", 63), 63),
        (_end("exit", 64), appverdict.OUT_OF_RANGE),
        (_end("exit", 256), appverdict.OUT_OF_RANGE),
        (_end("exit", -256), appverdict.OUT_OF_RANGE),
        (_end("exit", 83), appverdict.OUT_OF_RANGE),
        (_end("fault", 70), appverdict.CRASHED),
        (_end("board", 71), 71),
        (_end("board", 84), appverdict.NO_HEAP),
        (_end("board", 3), 127),
        (_end("no-agent", 81), appverdict.NO_AGENT),
        (_end("returned", 82), appverdict.RETURNED),
        (_end("duration", 83), appverdict.DURATION_OVER),
    ],
)
def test_the_status_qemu_must_give_for_each_end(end: appverdict.RunEnd, code: int) -> None:
    assert appverdict.expected_code(end) == code


def test_verdicts() -> None:
    assert appverdict.verdict(0, _end("exit", 0), 0) == (True, "exit(0)")
    assert appverdict.verdict(3, _end("exit", 3), 0) == (False, "the app exited with 3")
    for status in (256, 512, -256, 326, 337, 83):
        assert appverdict.verdict(appverdict.OUT_OF_RANGE, _end("exit", status), 0) == (
            False,
            f"the app exited with {status}",
        )
        assert (
            appverdict.verdict(status % 256, _end("exit", status), 0)[0] is False
        )  # QEMU's mod 256 disagrees
    # QEMU's status alone passes nothing: no end line, or one that does not match it
    assert "without the runner's end line" in appverdict.verdict(0, None, 0)[1]
    assert appverdict.verdict(0, None, 0)[0] is False
    assert appverdict.verdict(0, _end("exit", 3), 0)[0] is False
    assert appverdict.verdict(appverdict.DURATION_OVER, _end("exit", 0), 5000)[0] is False
    passed, said = appverdict.verdict(
        appverdict.DURATION_OVER, _end("duration", 83, seen=16.0), 5000, started=10.0
    )
    assert passed and "ran for the whole --duration (5 s)" in said and "not that it did its job" in said
    # the board's clock said 5 s, uros's saw 1 s: not a pass
    passed, said = appverdict.verdict(
        appverdict.DURATION_OVER, _end("duration", 83, seen=11.0), 5000, started=10.0
    )
    assert not passed and "uros's clock saw 1.0 s" in said
    assert appverdict.verdict(appverdict.DURATION_OVER, _end("duration", 83), 5000, started=None)[0] is False
    assert (
        appverdict.verdict(appverdict.DURATION_OVER, _end("duration", 83, seen=99.0), 0, started=1.0)[0]
        is False
    )
    assert (
        "appMain returned without exit(status)"
        in appverdict.verdict(appverdict.RETURNED, _end("returned", 82), 0)[1]
    )
    assert "crashed" in appverdict.verdict(appverdict.CRASHED, _end("fault", 70), 0)[1]
    assert "no agent answered" in appverdict.verdict(appverdict.NO_AGENT, _end("no-agent", 81), 0)[1]
    assert "unaligned" in appverdict.verdict(71, _end("board", 71), 0)[1]
    assert appverdict.verdict(None, None, 0) == (
        False,
        "timeout: the app neither exited nor crashed within --timeout",
    )
    assert appverdict.verdict(None, _end("exit", 0), 5000)[0] is False


def _nm(*symbols: str) -> tuple[NmSymbol, ...]:
    return tuple(NmSymbol("x.o", name, kind) for name, kind in (s.split() for s in symbols))


BOARD = _nm("main T", "_exit T", "probe_heap_used W", "probe_millis W", "usleep W", "sleep W", "appMain U")


def test_the_app_may_not_define_what_the_board_does() -> None:
    ok = {"app.c": _nm("appMain T", "usleep T", "helper T", "rcl_init U")}
    assert app.symbol_conflicts(Path("/a"), ok, BOARD) is None
    for name, kind in (("probe_heap_used", "T"), ("main", "T"), ("_exit", "T"), ("probe_millis", "W")):
        found = app.symbol_conflicts(Path("/a"), {"app.c": _nm("appMain T", f"{name} {kind}")}, BOARD)
        assert found is not None and f"app.c defines {name}, which the probe's board defines" in found.message
    two = app.symbol_conflicts(Path("/a"), {"a.c": _nm("appMain T"), "b.c": _nm("appMain T")}, BOARD)
    assert two is not None and two.message == "--app /a: appMain is defined in both a.c and b.c"
    none = app.symbol_conflicts(Path("/a"), {"app.c": _nm("other T")}, BOARD)
    assert none is not None and "no C file defines void appMain(void *arg) once compiled" in none.message


def test_the_linkers_own_reason() -> None:
    output = (
        "/usr/lib/gcc/arm-none-eabi/12.2.1/../bin/ld: CMakeFiles/uros_probe.dir/app/b.c.obj: in function `f':",
        "/x/ld: b.c:(.text.f+0x4): undefined reference to `nowhere'",
        "collect2: error: ld returned 1 exit status",
    )
    assert app.link_error(output) == "undefined reference to 'nowhere' (b.c:(.text.f+0x4))"
    assert app.link_error(("collect2: error: ld returned 1 exit status",)) is None


def test_the_runner_statuses_match_the_firmware() -> None:
    text = (REPO / "templates" / "probe" / "app_main.c").read_text()
    for name, status in (
        ("OUT_OF_RANGE", appverdict.OUT_OF_RANGE),
        ("CRASHED", appverdict.CRASHED),
        ("NO_AGENT", appverdict.NO_AGENT),
        ("RETURNED", appverdict.RETURNED),
        ("DURATION_OVER", appverdict.DURATION_OVER),
        ("NO_HEAP", appverdict.NO_HEAP),
        ("ENDED_TWICE", appverdict.ENDED_TWICE),
    ):
        assert f"#define PROBE_APP_{name} {status}" in text
    assert "code = status >= 0 && status <= 63 ? status : PROBE_APP_OUT_OF_RANGE;" in text
    assert "code = status > 64 && status < 128 ? status : 127;" in text
    # the board's own ends: before appMain, in an exception, or with interrupts masked (FreeRTOS's assertion)
    assert "!app_started || exception != 0u || (status > 70 && status < 80 && interrupts_masked())" in text
    for kind in ("no-agent", "returned", "duration", "board", "fault", "exit"):
        assert f'"{kind}"' in text
    for board in ("arm", "riscv", "xtensa"):
        source = (REPO / "templates" / "probe" / board / "board.c").read_text()
        assert "void _exit(int status) {\n  status = probe_exit_status(status);" in source
    arm = (REPO / "templates" / "probe" / "arm" / "board.c").read_text()
    assert f"_exit({appverdict.CRASHED})" in arm and "probe_tick_hook();" in arm
    assert 71 in appverdict.RUNNER_STATUSES and "unaligned" in appverdict.RUNNER_STATUSES[71]


def test_the_size_line_and_the_size_tool() -> None:
    out = "   text\t   data\t    bss\t    dec\t    hex\tfilename\n  69824\t    688\t  17256\t  87768\t  156d8\turos_app.elf\n"
    sizes = app.elf_sizes(out)
    assert (sizes.text, sizes.data, sizes.bss) == (69824, 688, 17256)
    with pytest.raises(StepFailed):
        app.elf_sizes("nothing\n")
    assert bintools_beside("/usr/bin/arm-none-eabi-gcc").size == "/usr/bin/arm-none-eabi-size"
    assert bintools_beside(None).size == "size"
