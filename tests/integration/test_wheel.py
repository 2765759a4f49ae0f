"""The built wheel carries toolchains/, meta/ and templates/ and works from any directory."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest
from uros_helpers import REPO

pytestmark = pytest.mark.integration


def test_wheel_installs_and_runs_elsewhere(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(dist), str(REPO)],
        check=True,
        capture_output=True,
        text=True,
    )
    wheel = next(dist.glob("uros_build-*.whl"))
    # The dependencies (colcon, jinja2, ...) come from this interpreter's site-packages; the
    # package itself only from the wheel.
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True, system_site_packages=True)
    py = env_dir / "bin" / "python"
    subprocess.run(
        [str(py), "-m", "pip", "install", "--no-deps", "--no-index", "--force-reinstall", str(wheel)],
        check=True,
        capture_output=True,
        text=True,
    )
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    # A PYTHONPATH pointing at a checkout (as when testing a worktree) would shadow the wheel.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = subprocess.run(
        [str(py), "-c", "import uros_build.resources as r; print(r.toolchains_dir())"],
        env=env,
        cwd=elsewhere,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    assert where.startswith(str(env_dir)) and where.endswith("uros_build/_data/toolchains")

    uros = env_dir / "bin" / "uros"
    targets = json.loads(
        subprocess.run(
            [str(uros), "targets", "--json"],
            cwd=elsewhere,
            env=env,
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    )
    assert "cortex-m7" in [t["name"] for t in targets]
    tc = subprocess.run(
        [str(uros), "toolchain", "render", "cortex-m7"],
        cwd=elsewhere,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    assert "set(CMAKE_SYSTEM_NAME Generic)" in tc
    meta = subprocess.run(
        [str(uros), "meta", "write", "--target", "cortex-m7"],
        cwd=elsewhere,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    assert "-DRMW_UXRCE_TRANSPORT=custom" in meta
    for name in ("microrosConfig.cmake.j2", "toolchain.cmake.j2", "esp-idf-component.cmake.j2"):
        assert (Path(where).parent / "templates" / name).is_file()
