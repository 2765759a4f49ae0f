"""meta/options.yaml's defaults agree with upstream's CMake files (read from a local mirror of the
upstream repositories, UROS_MIRROR; skipped without it)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

from uros_build.sources import options

pytestmark = [pytest.mark.integration, pytest.mark.realsources]

SOURCES = {  # package -> (mirror folder, branch, file)
    "rmw_microxrcedds": ("micro-ROS+rmw_microxrcedds", "humble", "rmw_microxrcedds_c/CMakeLists.txt"),
    "microxrcedds_client": ("eProsima+Micro-XRCE-DDS-Client", "ros2", "CMakeLists.txt"),
}


def _upstream_defaults(text: str) -> dict[str, str]:
    found = {}
    for name, value in re.findall(r'set\((\w+)\s+"?([^"\s]*)"?\s+CACHE', text):
        found[name] = value
    for name, value in re.findall(r'option\((\w+)\s+"[^"]*"\s+(ON|OFF)\)', text):
        found[name] = value
    return found


@pytest.mark.parametrize("package", sorted(SOURCES))
def test_defaults_match_upstream(package: str) -> None:
    mirror = os.environ.get("UROS_MIRROR")
    folder, branch, path = SOURCES[package]
    repo = Path(mirror or "/nonexistent") / folder / "repo"
    if not repo.is_dir():
        pytest.skip("UROS_MIRROR is not set or lacks " + folder)
    text = subprocess.run(
        ["git", "--git-dir", str(repo), "show", f"{branch}:{path}"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    upstream = _upstream_defaults(text)
    for option in options.by_package(options.known_options())[package].values():
        assert option.name in upstream, f"{option.name} is not an option of {folder}@{branch}"
        assert upstream[option.name] == option.default, option.name
