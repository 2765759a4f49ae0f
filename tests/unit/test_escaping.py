"""Every value uros renders into a CMake file stays one value (issue 8, items 7 and 9): hostile
names, paths and flags neither add a command, nor expand as a variable, nor lose a '$' on the
way through ninja or make to the compiler. Pure: rendered text read back by tests/unit/cmake_text."""

from __future__ import annotations

import os
import re
from dataclasses import replace
from pathlib import Path

import pytest
from cmake_text import flags_as_compiled, parse, set_values

from uros_build.colcon import command as colcon
from uros_build.errors import ConfigError
from uros_build.output.exports.cmake import cmake_package_files
from uros_build.output.exports.espidf import esp_idf_component_files
from uros_build.sources.workspace import check_build_folder
from uros_build.target.profiles import find_profile, parse_profile
from uros_build.target.toolchain import ToolchainRequest, link_unsafe_flags, render_toolchain
from uros_build.templating import cmake_comment, cmake_flags, cmake_link_flags, cmake_quote

HOSTILE = [
    'x") execute_process(COMMAND touch /tmp/uros-pwned) set(Y "',
    "a\nexecute_process(COMMAND touch /tmp/uros-pwned)\n#",
    "${HOME}",
    "$ENV{HOME}",
    'back\\slash "quote" \\" ;semi; #hash (paren) `tick` \'single\'',
    "tab\there\rcr",
]
FLAGS = [
    '-DBOARD_NAME="cost $5 $x"',
    "-DP=${HOME}",
    "-DQ=$ENV{PATH}",
    '-DA="x;y"',
    "-DB='it'\"'\"'s'",
    "-DC=a\\b",
    "-DD=#hash",
    "-DE=(paren) `tick` $(touch /tmp/uros-pwned)",
    "-DF=50%",
]


def _commands(text: str) -> list[str]:
    return [c.name for c in parse(text)]


def _render(**changes: object) -> str:
    base = find_profile("cortex-m7")
    micro_ros = bool(changes.pop("micro_ros", True))
    tool_dir = changes.pop("tool_dir", None)
    prefix_map = changes.pop("prefix_map", None)
    req = ToolchainRequest(
        replace(base, **changes),  # type: ignore[arg-type]
        micro_ros=micro_ros,
        gcc_major=12,
        clock_header="/ws/h.h",
        tool_dir=tool_dir,  # type: ignore[arg-type]
        prefix_map=prefix_map,  # type: ignore[arg-type]
    )
    return render_toolchain(req)


@pytest.mark.parametrize("value", HOSTILE)
def test_cmake_quote_round_trips_and_never_expands(value: str) -> None:
    (cmd,) = parse(f'set(X "{cmake_quote(value)}")\n')
    assert cmd.args == ["X", value] and cmd.expands == [False, False]


@pytest.mark.parametrize("value", HOSTILE)
def test_hostile_profile_values_stay_values_in_the_toolchain_file(value: str) -> None:
    benign = _render()
    for micro_ros in (True, False):
        text = _render(
            name=value,
            system_processor=value,
            source=f"/tmp/{value}.yaml",
            micro_ros=micro_ros,
        )
        assert _commands(text) == _commands(_render(micro_ros=micro_ros))
        values = set_values(text)
        assert values["UROS_TARGET"] == value and values["CMAKE_SYSTEM_PROCESSOR"] == value
        assert not any(c.expands[1] for c in parse(text) if c.name == "set" and c.args[0].startswith("UROS_"))
    assert "execute_process" not in "".join(_commands(benign))


def test_hostile_optimisation_stays_one_flag() -> None:
    text = _render(optimization='-O2") execute_process(COMMAND touch /tmp/uros-pwned) #')
    assert "execute_process" not in _commands(text)


@pytest.mark.parametrize("micro_ros", [True, False])
def test_flags_reach_the_compiler_exactly_through_ninja_and_make(micro_ros: bool) -> None:
    text = _render(c_flags=tuple(FLAGS), micro_ros=micro_ros)
    # one guard: a generator other than Ninja or Makefiles is refused; -D flags are safe to link
    assert _commands(text).count("message") == 1
    compiled = flags_as_compiled(set_values(text)["CMAKE_C_FLAGS_INIT"])
    end = len(compiled) - (3 if micro_ros else 0)  # then -DCLOCK_MONOTONIC=0 -include /ws/h.h
    assert compiled[end - len(FLAGS) : end] == FLAGS


def test_a_workspace_path_with_dollar_reaches_the_include_flag() -> None:
    ws = "/home/me/fw $x ${HOME} (1)"
    text = _render(prefix_map=ws)
    compiled = flags_as_compiled(set_values(text)["CMAKE_C_FLAGS_INIT"])
    assert compiled[-4:] == [
        "-include",
        "/ws/h.h",
        f"-ffile-prefix-map={ws}=.",
        "-ffile-prefix-map=../../../../../=./",
    ]
    req = ToolchainRequest(find_profile("cortex-m7"), True, gcc_major=12, clock_header=f"{ws}/h.h")
    compiled = flags_as_compiled(set_values(render_toolchain(req))["CMAKE_C_FLAGS_INIT"])
    assert compiled[-2:] == ["-include", f"{ws}/h.h"]


def test_plain_flags_need_no_generator_guard() -> None:
    text = _render()
    assert "CMAKE_GENERATOR" not in text and "$$" not in text


def test_linker_flags_keep_a_single_dollar() -> None:
    # CMake escapes LINK_FLAGS for ninja itself; Makefile generators run link.txt without make
    assert cmake_link_flags(["--specs=/opt/a$b/x.specs"]) == "'--specs=/opt/a\\$b/x.specs'"
    assert cmake_flags(["--specs=/opt/a$b/x.specs"]) == "'--specs=/opt/a\\$\\$b/x.specs'"


def test_link_unsafe_flags_are_those_a_linker_reads() -> None:
    flags = [
        "-DX=$a",
        "-include",
        "/p$/h.h",
        "-I/i$",
        "-ffile-prefix-map=/w$=.",
        "--specs=/s$/x.specs",
        "-L/l$",
    ]
    assert link_unsafe_flags(flags) == ["--specs=/s$/x.specs", "-L/l$"]
    text = _render(c_flags=("--specs=/opt/a$b/x.specs",), micro_ros=False)
    guard = next(c for c in parse(text) if c.name == "if" and "Makefiles" in c.args)
    assert guard.args == ["CMAKE_GENERATOR", "MATCHES", "Makefiles"]


@pytest.mark.parametrize("bad", ['/opt/a"b', "/opt/a;b", "/opt/a\\b", "/opt/${HOME}", "/opt/$(id)"])
def test_tool_paths_cmake_cannot_use_are_refused(bad: str) -> None:
    with pytest.raises(ConfigError, match="CMake cannot use a tool path"):
        _render(tool_dir=f"{bad}/bin")


def test_tool_paths_with_dollar_space_and_parens_stay_values() -> None:
    tool_dir = "/opt/my $x $5 (tools) #h/bin"
    values = set_values(_render(tool_dir=tool_dir))
    assert values["CMAKE_C_COMPILER"] == f"{tool_dir}/arm-none-eabi-gcc"


@pytest.mark.parametrize("flag", ["-DA=1\n-DB=2", "-DA=\x1b[1m"])
def test_flags_with_control_characters_are_refused(flag: str) -> None:
    with pytest.raises(ConfigError, match="control character"):
        cmake_flags([flag])


def test_comments_cannot_be_ended() -> None:
    assert cmake_comment("a\nb\x00c") == "a\\nb\\x00c"


@pytest.mark.parametrize("value", HOSTILE)
def test_hostile_values_in_the_cmake_package_and_esp_idf_component(value: str) -> None:
    for name, text in cmake_package_files(value, tuple(FLAGS)).items():
        benign = cmake_package_files("cortex-m7", ("-mthumb",))[name]
        assert _commands(text) == _commands(benign), name
    values = set_values(cmake_package_files(value, tuple(FLAGS))["microros.cmake"])
    assert values["MICROROS_TARGET"] == value
    assert flags_as_compiled(values["MICROROS_CPU_FLAGS"]) == FLAGS
    text = esp_idf_component_files(value, value, value)["CMakeLists.txt"]
    assert _commands(text) == _commands(
        esp_idf_component_files("esp32s3", "esp32s3", "udp")["CMakeLists.txt"]
    )
    guard = next(c for c in parse(text) if c.name == "if" and "STREQUAL" in c.args)
    assert guard.args[-1] == value and not guard.expands[-1]


def test_every_template_value_goes_through_an_escape() -> None:
    """A new {{ value }} in a template must pick an escape (or be one of uros's own constants)."""
    own = {"version", "purpose", "package_version", "profile.c_standard", "profile.cxx_standard", "opt"}
    own.add("c_standard")  # a whole number uros computes
    own.add('requires | join(" ")')  # a fixed list: lwip or nothing
    escapes = ("cmake_quote", "cmake_comment", "cmake_path", "cmake_flags", "cmake_link_flags")
    escapes += (
        "make_flags",
        "pc_flags",
        "meson_string",
        "meson_list",
        "python_literal",
        "sh_quote",
        "sh_join",
    )
    templates = Path(__file__).resolve().parents[2] / "templates"
    for path in sorted(templates.glob("*.j2")):
        for expr in re.findall(r"\{\{\s*(.*?)\s*\}\}", path.read_text()):
            assert expr in own or expr.endswith(escapes), f"{path.name}: {{{{ {expr} }}}} is not escaped"


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"system_processor": 'arm") execute_process(COMMAND id'}, "is not a word like 'arm'"),
        ({"compiler_prefix": '/opt/a"b/arm-none-eabi-'}, "which CMake cannot use in a tool path"),
        ({"compiler_prefix": "/opt/${HOME}/arm-none-eabi-"}, "which CMake cannot use in a tool path"),
        ({"c_flags": ["-DA=1\t-DB=2"]}, "is not a single compiler flag"),
    ],
)
def test_profile_values_cmake_would_run_are_refused_on_load(
    changes: dict[str, object], expected: str
) -> None:
    data = {
        "name": "board",
        "description": 'x") execute_process(COMMAND id) #',  # never rendered into CMake
        "compiler_prefix": "/opt/tools $x (1)/bin/arm-none-eabi-",
        "system_processor": "arm",
        "cpu_flags": ["-mthumb"],
        "elf": {"machine": "ARM"},
    }
    assert parse_profile(data, "board.yaml").compiler_prefix == "/opt/tools $x (1)/bin/arm-none-eabi-"
    with pytest.raises(ConfigError, match=re.escape(expected)):
        parse_profile({**data, **changes}, "board.yaml")


@pytest.mark.parametrize("name", ["fw$x", "fw`id`", 'fw"q', "fw\\b", "fw;2", "fw\nx"])
def test_workspace_folders_colcon_or_cmake_cannot_use_are_refused(tmp_path: Path, name: str) -> None:
    with pytest.raises(ConfigError, match="colcon and CMake cannot build in a folder"):
        check_build_folder(tmp_path / name, "--workspace")
    check_build_folder(tmp_path / "fw 'q' #h (1) =+@", "--workspace")


def test_cmake_generator_of_the_user_wins_over_ninja() -> None:
    assert colcon.generator({"PATH": "/nonexistent"}) is None
    assert colcon.generator({"CMAKE_GENERATOR": "Unix Makefiles", "PATH": os.environ["PATH"]}) is None
