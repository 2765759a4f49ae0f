"""A target's colcon runs without its Python package extensions only when nothing it would find needs
them (colcon/command.py PYTHON_EXTENSIONS): a Python package is still found, built and refused as
before. Real uros CLI, real colcon, CMake and arm-none-eabi-gcc."""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import UP_TO_CORE
from uros_helpers import build_fixture

from uros_build.colcon.command import PYTHON_EXTENSIONS

pytestmark = [pytest.mark.integration, pytest.mark.colcon]


def _colcon_blocklist(ws: Path) -> list[str]:
    """The COLCON_EXTENSION_BLOCKLIST the target's colcon build ran with, from the build's run log
    (proc.py writes each command's environment difference under it)."""
    lines = (ws / ".uros" / "log" / "latest.log").read_text(encoding="utf-8").splitlines()
    start = next(
        i for i, line in enumerate(lines) if line.startswith("+ ") and " build --base-paths " in line
    )
    for line in lines[start + 1 :]:
        if not line.startswith("  export "):
            break
        name, _, value = line.removeprefix("  export ").partition("=")
        if name == "COLCON_EXTENSION_BLOCKLIST":
            return value.split(":")
    return []


def test_the_fixture_build_runs_colcon_without_its_python_extensions(m7_build: Path) -> None:
    """The fixture's one Python package (fx_host_py) is left out, every other is CMake: colcon runs
    without its Python package extensions (the CPU this saves every build is the point)."""
    assert set(PYTHON_EXTENSIONS) <= set(_colcon_blocklist(m7_build))


def test_a_setup_py_without_a_package_xml_is_still_a_package_colcon_builds(
    built: Callable[[str], Path],
) -> None:
    """A folder holding a setup.py and no package.xml is a Python package to colcon, which uros does
    not list: its colcon keeps its Python extensions and builds it (this one refuses, as a
    package that must not be built), where without them colcon would no longer see it and the
    build would pass without it. The built fixture (restored) with the folder added: the build
    after it must see it as well as a first build would."""
    ws = built("m7")
    loose = ws / "mcu_ws" / "src" / "fx_loose_py"
    loose.mkdir()
    (loose / "setup.py").write_text(
        textwrap.dedent(
            """
            import sys

            from setuptools import setup

            if {"egg_info", "build", "install", "develop"} & set(sys.argv[1:]):
                raise SystemExit("fx_loose_py must not be built")
            setup(name="fx_loose_py", version="0.1.0", packages=[])
            """
        ),
        encoding="utf-8",
    )
    proc = build_fixture(ws, check=False)
    assert proc.returncode == 4, proc.stderr
    assert "error: colcon build failed in package fx_loose_py: fx_loose_py must not be built" in proc.stderr
    assert not set(PYTHON_EXTENSIONS) & set(_colcon_blocklist(ws))


def test_a_python_package_a_compiled_one_needs_is_built_with_its_data_files(
    built: Callable[[str], Path],
) -> None:
    """An ament_python package a compiled package depends on is built by the target's colcon, with
    what its setup.py installs beside the code (data_files), and its colcon keeps the Python
    extensions: colcon-ros's augmentation of ament_python packages gives colcon's Python build task
    the setup() arguments it reads (data_files again on a rebuild: `install_data --force`;
    --symlink-install's links). The fx_core build restored (built("core")), then fx_core given the
    new dependency: the Python package's first build, and fx_core's again."""
    ws = built("core")
    src = ws / "mcu_ws" / "src"
    core_xml = src / "fx_core" / "package.xml"
    core_xml.write_text(
        core_xml.read_text(encoding="utf-8").replace("<export>", "<depend>fx_tool_py</depend>\n  <export>"),
        encoding="utf-8",
    )
    tool = src / "fx_tool_py"
    (tool / "resource").mkdir(parents=True)
    (tool / "resource" / "fx_tool_py").write_text("", encoding="utf-8")
    host_xml = (src / "fx_host_py" / "package.xml").read_text(encoding="utf-8")
    (tool / "package.xml").write_text(host_xml.replace("fx_host_py", "fx_tool_py"), encoding="utf-8")
    (tool / "setup.py").write_text(
        textwrap.dedent(
            """
            from setuptools import setup

            setup(
                name="fx_tool_py",
                version="0.1.0",
                packages=[],
                data_files=[
                    ("share/ament_index/resource_index/packages", ["resource/fx_tool_py"]),
                    ("share/fx_tool_py", ["package.xml"]),
                ],
            )
            """
        ),
        encoding="utf-8",
    )
    proc = build_fixture(ws, *UP_TO_CORE)
    assert "[2/2] built fx_core" in proc.stderr
    install = ws / ".uros" / "targets" / "cortex-m7" / "install"
    assert (install / "share" / "fx_tool_py" / "package.xml").is_file()
    assert (install / "share" / "ament_index" / "resource_index" / "packages" / "fx_tool_py").is_file()
    assert not set(PYTHON_EXTENSIONS) & set(_colcon_blocklist(ws))
