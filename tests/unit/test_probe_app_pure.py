"""`uros probe --app`'s pure pieces (run/app.py): the app folder scanned for appMain and for the
interface packages its #includes name, the one-line message for packages the library lacks, the
defines and --duration checked, the firmware's CMakeLists escaped, the verdicts, the size line."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.commands import probe as probe_cmd
from uros_build.errors import ConfigError, StepFailed
from uros_build.run import app
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
    with pytest.raises(ConfigError, match="control character"):
        app.parse_defines(["X=\x01"])


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
    assert probe_cmd.app_request(None, (), None) is None
    with pytest.raises(ConfigError, match="--duration: only with --app"):
        probe_cmd.app_request(None, (), 3.0)
    with pytest.raises(ConfigError, match="--define: only with --app"):
        probe_cmd.app_request(None, ("X",), None)


def test_the_cmakelists_escapes_paths_and_defines(tmp_path: Path) -> None:
    folder = _app(tmp_path, APP_MAIN, name="a$b.c")
    scanned = app.scan_app(folder)
    text = app.app_cmake(scanned, ['TOPIC="x${y}"', "N=1"], 3000)
    assert f'"{folder}/a\\$b.c"' in text
    assert '"TOPIC=\\"x\\${y}\\""' in text
    assert '"UROS_APP_DURATION_MS=3000"' in text
    assert "add_executable(uros_probe app_main.c transport.c ${probe_board}" in text
    assert "target_sources(uros_probe PRIVATE allocators.c)" in text  # bare metal; FreeRTOS: the kernel heap
    assert app.app_cmake(scanned, ['TOPIC="x${y}"', "N=1"], 3000) == text  # deterministic


def test_a_path_cmake_cannot_use_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "a;b"
    folder.mkdir()
    (folder / "app.c").write_text(APP_MAIN)
    with pytest.raises(ConfigError, match="CMake cannot use a path containing ';'"):
        app.app_cmake(app.scan_app(folder), [], 0)


def test_verdicts() -> None:
    assert app.verdict(0, 0) == (True, "exit(0)")
    assert app.verdict(3, 0) == (False, "the app exited with 3")
    passed, said = app.verdict(app.DURATION_OVER, 5000)
    assert passed and "ran for the whole --duration (5 s)" in said and "not that it did its job" in said
    assert app.verdict(app.RETURNED, 0)[0] is False
    assert "appMain returned without exit(status)" in app.verdict(app.RETURNED, 0)[1]
    assert "crashed" in app.verdict(app.CRASHED, 0)[1]
    assert "no agent answered" in app.verdict(app.NO_AGENT, 0)[1]
    assert app.verdict(None, 0) == (False, "timeout: the app neither exited nor crashed within --timeout")
    assert app.verdict(None, 5000)[0] is False


def test_the_runner_statuses_match_the_firmware() -> None:
    text = (REPO / "templates" / "probe" / "app_main.c").read_text()
    assert f"#define APP_NO_AGENT {app.NO_AGENT}" in text
    assert f"#define APP_RETURNED {app.RETURNED}" in text
    assert f"#define APP_DURATION_OVER {app.DURATION_OVER}" in text
    board = (REPO / "templates" / "probe" / "arm" / "board.c").read_text()
    assert f"_exit({app.CRASHED})" in board and "probe_tick_hook();" in board
    assert 71 in app.RUNNER_STATUSES and "unaligned" in app.RUNNER_STATUSES[71]


def test_the_size_line_and_the_size_tool() -> None:
    out = "   text\t   data\t    bss\t    dec\t    hex\tfilename\n  69824\t    688\t  17256\t  87768\t  156d8\turos_app.elf\n"
    sizes = app.elf_sizes(out)
    assert (sizes.text, sizes.data, sizes.bss) == (69824, 688, 17256)
    with pytest.raises(StepFailed):
        app.elf_sizes("nothing\n")
    assert bintools_beside("/usr/bin/arm-none-eabi-gcc").size == "/usr/bin/arm-none-eabi-size"
    assert bintools_beside(None).size == "size"
