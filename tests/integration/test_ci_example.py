"""Issue 33, item 6: the CI example (examples/ci/github-actions.yml) validated by real tools, not by
eye: check-jsonschema against schemastore's github-workflow schema (vendored in the package, so
offline), which also refuses a broken copy of it (so the check is no rubber stamp), and bash's own
parser over every step's script; its Build and Check steps run by bash on the fixture, twice (a
second runner takes the output from the team cache). Its uros lines are parsed by uros in tests/unit/test_ci_example_pure.py."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from fixture_ws import make_fixture_workspace
from uros_helpers import REPO, need

pytestmark = pytest.mark.integration

EXAMPLE = REPO / "examples" / "ci" / "github-actions.yml"


def _check_jsonschema(workflow: Path) -> subprocess.CompletedProcess[str]:
    """check-jsonschema (a test requirement of '.[test]') with its vendored schemastore schema: its
    own click command, run in this process (click's CliRunner), its exit code and its output."""
    from check_jsonschema import main
    from click.testing import CliRunner

    args = ["--builtin-schema", "vendor.github-workflows", str(workflow)]
    done = CliRunner().invoke(main, args)
    if done.exception is not None and not isinstance(done.exception, SystemExit):
        raise done.exception
    return subprocess.CompletedProcess(["check-jsonschema", *args], done.exit_code, done.stdout, done.stderr)


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


def _step_script(name: str) -> str:
    (job,) = yaml.safe_load(EXAMPLE.read_text())["jobs"].values()
    (script,) = [s["run"] for s in job["steps"] if s.get("name", "").startswith(name)]
    assert "${{" not in script  # what GitHub would put in, this test cannot: the job's env: carries it
    return str(script)


@pytest.mark.colcon
def test_the_ci_example_builds_and_the_next_runner_takes_it_from_the_team_cache(tmp_path: Path) -> None:
    """The example's own Build and Check steps, run by bash as the runner would, on the fixture
    workspace in `firmware/` (a uros.yaml and a colcon.meta, as create-firmware leaves them): the
    first runner builds and uploads, a second runner (another folder, an empty ccache) takes the
    output from the team cache and checks the same library."""
    need("bash", "arm-none-eabi-gcc", "cmake", "ccache")
    store = tmp_path / "team cache"
    libraries = []
    for runner in ("runner one", "runner two"):
        ws = make_fixture_workspace(tmp_path / runner / "firmware")
        (ws / "uros.yaml").write_text("target: cortex-m7\n")
        shutil.copy(ws / "fixture.meta", ws / "colcon.meta")
        env = {
            **os.environ,
            "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",  # the venv's uros
            "TARGET": "cortex-m7",
            "UROS_CACHE_URL": store.as_uri(),
            "CCACHE_DIR": str(tmp_path / runner / "ccache"),
        }
        said = ""
        for step in ("Build", "Check the library"):
            done = subprocess.run(
                ["bash", "-e", "-o", "pipefail", "-c", _step_script(step)],
                cwd=tmp_path / runner, env=env, capture_output=True, text=True,
            )  # fmt: skip
            assert done.returncode == 0, f"{step}: {done.stdout}\n{done.stderr}"
            said += done.stdout + done.stderr
        assert "all 8 objects match cortex-m7" in said, said
        libraries.append((ws / "build" / "cortex-m7" / "libmicroros.a").read_bytes())
        if runner == "runner one":
            assert "cache: uploaded entry" in said, said
        else:
            assert f"from the cache {store.as_uri()}" in said, said
    assert libraries[0] == libraries[1]
