"""Issue 33, item 6: the CI example (examples/ci/github-actions.yml) validated by real tools, not by
eye: check-jsonschema against schemastore's github-workflow schema (vendored in the package, so
offline), which also refuses a broken copy of it (so the check is no rubber stamp), and bash's own
parser over every step's script. Its uros lines are parsed by uros in tests/unit/test_ci_example.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from uros_helpers import REPO, need

pytestmark = pytest.mark.integration

EXAMPLE = REPO / "examples" / "ci" / "github-actions.yml"


def _check_jsonschema(workflow: Path) -> subprocess.CompletedProcess[str]:
    """check-jsonschema (a test requirement of '.[test]') with its vendored schemastore schema."""
    argv = [sys.executable, "-m", "check_jsonschema", "--builtin-schema", "vendor.github-workflows"]
    return subprocess.run([*argv, str(workflow)], capture_output=True, text=True)


def test_the_ci_example_is_a_valid_github_workflow(tmp_path: Path) -> None:
    done = _check_jsonschema(EXAMPLE)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "ok -- validation done" in done.stdout

    broken = tmp_path / "broken.yml"  # `runs-on` misspelled: a workflow GitHub would refuse
    broken.write_text(EXAMPLE.read_text().replace("runs-on:", "run-on:"))
    refused = _check_jsonschema(broken)
    assert refused.returncode == 1 and "run-on" in refused.stdout + refused.stderr, refused.stdout


def test_every_step_script_of_the_ci_example_is_valid_bash() -> None:
    need("bash")
    steps = [s for job in yaml.safe_load(EXAMPLE.read_text())["jobs"].values() for s in job["steps"]]
    scripts = [s["run"] for s in steps if "run" in s]
    assert len(scripts) >= 4
    for script in scripts:
        done = subprocess.run(
            ["bash", "-n", "-e", "-o", "pipefail"], input=script, capture_output=True, text=True
        )
        assert done.returncode == 0, f"{script}\n{done.stderr}"
