"""Issue 33, item 6: the CI example (examples/ci/github-actions.yml) runs uros commands that uros's
own command line accepts, for every target of its matrix: each `uros ...` line of its steps, with
the job's and the step's variables put in for each matrix entry, is parsed by the real click
commands (unknown options, missing values and bad choices fail here as they would on the runner),
and every target is one uros ships. tests/integration/test_ci_example.py validates the file with
check-jsonschema against schemastore's github-workflow schema."""

from __future__ import annotations

import re
import shlex
from pathlib import Path
from typing import Any

import click
import pytest
import yaml

from uros_build import cli
from uros_build.target.profiles import shipped_profiles

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ci" / "github-actions.yml"
EXPRESSION = re.compile(r"\$\{\{\s*([^}]*?)\s*\}\}")
VARIABLE = re.compile(r"\$(?:\{(\w+)\}|(\w+))")
# what the repository's settings give the job (vars., secrets.) and the runner's own variables
OUTSIDE = {
    "vars.UROS_CACHE_URL": "https://cache.example.com/uros",
    "vars.UROS_PACKAGE": "uros-build",
    "secrets.CCACHE_REMOTE_STORAGE": "redis://:password@ccache.example.com:6379",
    "secrets.UROS_CACHE_TOKEN": "token",
    "runner.temp": "/home/runner/work/_temp",
}
RUNNER = {"RUNNER_TEMP": "/home/runner/work/_temp", "GITHUB_PATH": "/home/runner/work/_temp/path"}


def _expand(text: str, found: dict[str, str]) -> str:
    def one(match: re.Match[str]) -> str:
        assert match[1] in found, f"{EXAMPLE.name}: nothing gives ${{{{ {match[1]} }}}}"
        return found[match[1]]

    return EXPRESSION.sub(one, text)


def _words(line: str, env: dict[str, str]) -> list[str]:
    """A shell line's words, its variables put in (each must be set by the job, the step or the
    runner)."""

    def value(match: re.Match[str]) -> str:
        name = match[1] or match[2]
        assert name in env, f"{EXAMPLE.name}: ${name} is set nowhere ({line.strip()})"
        return env[name]

    return shlex.split(VARIABLE.sub(value, line))


def _uros_commands(workflow: dict[str, Any]) -> list[tuple[str, list[str]]]:
    """(matrix target, argv after `uros`) of every uros line of every job, for each matrix entry."""
    commands = []
    for job in workflow["jobs"].values():
        for target in job["strategy"]["matrix"]["target"]:
            given = {**OUTSIDE, "matrix.target": target}
            job_env = {k: _expand(str(v), given) for k, v in job.get("env", {}).items()}
            for step in job["steps"]:
                step_env = {k: _expand(str(v), given) for k, v in step.get("env", {}).items()}
                env = {**RUNNER, **job_env, **step_env}
                script = _expand(step.get("run", ""), given).replace("\\\n", " ")
                for line in script.splitlines():
                    words = line.split()
                    if not words or words[0] != "uros":
                        continue
                    commands.append((target, _words(line, env)[1:]))
    return commands


def _parse(argv: list[str]) -> click.Context:
    """``argv`` parsed by uros's real commands, down to the leaf command (nothing is run; the
    example gives no group options of its own)."""
    group: click.Group = cli.cli
    parent = click.Context(group, info_name="uros")
    name, *rest = argv
    while True:
        command = group.get_command(parent, name)
        assert command is not None, f"uros has no command {name!r}: {argv}"
        if not isinstance(command, click.Group):
            return command.make_context(name, rest, parent=parent)
        group, parent = command, click.Context(command, info_name=name, parent=parent)
        name, *rest = rest


def test_the_ci_example_runs_uros_commands_uros_accepts_for_every_target() -> None:
    workflow = yaml.safe_load(EXAMPLE.read_text())
    commands = _uros_commands(workflow)
    targets = {target for target, _ in commands}
    assert targets and targets <= set(shipped_profiles()), targets - set(shipped_profiles())
    builds = [(t, _parse(argv)) for t, argv in commands if argv[0] == "build"]
    assert len(builds) == len(targets)  # one build per target: a job each
    for target, ctx in builds:
        assert ctx.params["toolchains"] == (target,), ctx.params
        assert ctx.params["cache"] == OUTSIDE["vars.UROS_CACHE_URL"] and ctx.params["cache_upload"]
        assert ctx.params["ccache"] is True
    for _, argv in commands:
        _parse(argv)  # every other uros line parses too (create-firmware, info, check)


def test_a_wrong_uros_line_fails_the_check() -> None:
    """The check is no rubber stamp: an option uros does not have fails it."""
    with pytest.raises(click.UsageError, match="--cache-uplaod"):
        _parse(["build", "--toolchain", "cortex-m7", "--cache-uplaod"])
