from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from uros_build.cli import cli
from uros_build.commands.check import CheckRequest
from uros_build.commands.size import SizeRequest
from uros_build.probesteps.context import ProbeRequest


def _commands(group: click.Group, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out = [prefix]
    for name, command in group.commands.items():
        if isinstance(command, click.Group):
            out += _commands(command, (*prefix, name))
        else:
            out.append((*prefix, name))
    return out


def test_every_command_has_help() -> None:
    runner = CliRunner()
    commands = _commands(cli)
    assert (
        ("create-firmware",) in commands
        and ("export", "esp-idf") in commands
        and ("interface", "new") in commands
    )
    for path in commands:
        result = runner.invoke(cli, [*path, "--help"])
        assert result.exit_code == 0, (path, result.output)
        assert "Usage: " in result.output


def test_old_spellings_work_but_stay_out_of_help() -> None:
    runner = CliRunner()
    for path, old, new in (
        (("create-firmware",), "--dir", "--workspace"),
        (("check",), "--target", "--toolchain"),
        (("meta", "write"), "--target", "--toolchain"),
        (("build",), "--dir", "--workspace"),
    ):
        text = runner.invoke(cli, [*path, "--help"]).output
        assert new in text and old not in text, (path, text)
    result = runner.invoke(cli, ["meta", "write", "--target", "cortex-m7"])
    assert result.exit_code == 0 and "rcutils" in result.output


def test_one_vocabulary_for_outputs() -> None:
    runner = CliRunner()
    for path in (
        ("toolchain", "render"),
        ("meta", "write"),
        ("export", "cmake"),
        ("interface", "new"),
        ("build",),
    ):
        assert "-o, --output" in runner.invoke(cli, [*path, "--help"]).output, path


def test_an_unexpected_error_is_one_line_and_the_traceback_goes_to_a_log(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from uros_build import cli as cli_mod
    from uros_build import proc
    from uros_build.commands import listings

    def broken() -> list[dict[str, object]]:
        raise RuntimeError("boom")

    monkeypatch.setattr(listings, "targets_table", broken)
    monkeypatch.setattr(proc, "user_log_dir", lambda: tmp_path)
    monkeypatch.setattr(proc, "_current_log", None)
    with pytest.raises(SystemExit) as exit_info:
        cli_mod.main(["targets"])
    assert exit_info.value.code == 1
    err = capsys.readouterr().err
    assert "internal error: RuntimeError: boom" in err and "Traceback" not in err
    logs = list(tmp_path.glob("*-error-*.log"))
    assert len(logs) == 1 and "Traceback" in logs[0].read_text() and str(logs[0]) in err.replace("\n", "")


def test_listings_have_headers() -> None:
    runner = CliRunner()
    lines = runner.invoke(cli, ["targets"]).output.splitlines()
    assert lines[0].split() == ["TARGET", "COMPILER", "TRANSPORT", "DESCRIPTION"]
    assert lines[1].startswith("cortex-m0plus ")
    lines = runner.invoke(cli, ["distros"]).output.splitlines()
    assert lines[0].split() == ["DISTRO", "STATUS", "DEV", "REPOS", "MCU", "REPOS", "STAND-INS"]
    assert any(line.split()[0] == "humble" for line in lines[1:])


def test_targets_show_prints_a_profile_to_copy(tmp_path: Path) -> None:
    import yaml

    from uros_build.target.profiles import find_profile, parse_profile

    runner = CliRunner()
    result = runner.invoke(cli, ["targets", "show", "cortex-m7"])
    assert result.exit_code == 0
    copy = tmp_path / "my-board.yaml"
    copy.write_text(result.output)
    assert (
        parse_profile(yaml.safe_load(copy.read_text()), copy).cpu_flags == find_profile("cortex-m7").cpu_flags
    )
    assert result.output.startswith("#")  # the file as shipped, comments and all
    typo = runner.invoke(cli, ["targets", "show", "cortex-m77"])
    assert "did you mean cortex-m7" in str(typo.exception)


def test_every_probe_option_is_a_field_of_the_probe_request() -> None:
    """cli/data.py:probe hands its options to ProbeRequest by name: --app, -D and --duration become
    its one ``app`` field, every other option the field of its own name."""
    probe = cli.commands["probe"]
    options = {p.name for p in probe.params}
    assert options - {"app", "defines", "duration"} == {f.name for f in fields(ProbeRequest)} - {"app"}


@pytest.mark.parametrize("name", ["check", "size"])
def test_every_check_and_size_option_is_a_field_of_its_request(name: str) -> None:
    """cli/build.py hands check's and size's options to their records by name."""
    record = {"check": CheckRequest, "size": SizeRequest}[name]
    assert {p.name for p in cli.commands[name].params} == {f.name for f in fields(record)}
