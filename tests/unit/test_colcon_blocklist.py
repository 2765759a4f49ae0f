"""The colcon extensions uros blocks: every run's unused ones, and a target's Python package extensions
only when nothing its colcon would find needs them (colcon/command.py, sources/packages.py,
steps/colcon_setup.py)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from fake_runner import FakeRunner

from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildargs import BuildArgs
from uros_build.config.plan import plan_build
from uros_build.sources import packages
from uros_build.sources.packages import PackageInfo
from uros_build.steps import colcon_setup, target_kind
from uros_build.steps.context import Context


def _info(name: str, build_type: str, path: Path) -> PackageInfo:
    return PackageInfo(name, build_type, frozenset(), path)


def test_with_blocked_keeps_the_users_entries_first_and_names_none_twice() -> None:
    env = colcon.with_blocked(
        {"PATH": "/b", "COLCON_EXTENSION_BLOCKLIST": "mine.a:colcon.x"}, ["colcon.x", "y", "y"]
    )
    assert env == {"PATH": "/b", "COLCON_EXTENSION_BLOCKLIST": "mine.a:colcon.x:y"}
    assert colcon.with_blocked({}, ["a", "b"]) == {"COLCON_EXTENSION_BLOCKLIST": "a:b"}


def test_every_colcon_run_blocks_what_no_build_uses_but_never_build_or_the_python_extensions() -> None:
    env, _ = colcon.build_env({}, python_bin_dir="/b")
    blocked = env["COLCON_EXTENSION_BLOCKLIST"].split(":")
    assert blocked == list(colcon.UNUSED_EXTENSIONS)
    assert "colcon_core.verb.build" not in blocked
    # dev_ws and the host stage build Python packages: only a target's colcon may go without them
    assert not set(colcon.PYTHON_EXTENSIONS) & set(blocked)
    # colcon's build task of a Python package stays everywhere: without it a Python package colcon
    # finds would be skipped with a warning, not built
    assert not [b for b in [*blocked, *colcon.PYTHON_EXTENSIONS] if b.startswith("colcon_core.task.")]


def test_builds_python_names_the_built_packages_of_another_build_type_than_cmakes(tmp_path: Path) -> None:
    found = [
        _info("a", "ament_cmake", tmp_path / "a"),
        _info("c", "cmake", tmp_path / "c"),
        _info("py", "ament_python", tmp_path / "py"),
        _info("odd", "catkin", tmp_path / "odd"),  # a build type uros does not know counts too
    ]
    assert packages.builds_python(found, {"a", "c", "plain_cmake_without_xml"}) == []
    assert packages.builds_python(found, {"a", "py", "odd"}) == ["odd", "py"]


def test_python_outside_packages_finds_setup_files_outside_every_package_xml_folder(tmp_path: Path) -> None:
    src = tmp_path / "src"
    found = [_info("py", "ament_python", src / "repo" / "py"), _info("a", "ament_cmake", src / "a")]
    inside = ["repo/py/setup.py", "repo/py/setup.cfg", "a/setup.cfg", "a/CMakeLists.txt", "repo/notes.py"]
    assert packages.python_outside_packages(found, src, inside) == []
    loose = ["loose/setup.py", "a/tools/setup.cfg", "setup.py"]  # nested in a package's folder counts
    assert packages.python_outside_packages(found, src, [*inside, *loose]) == sorted(loose)
    # a package in the source folder itself
    assert packages.python_outside_packages([_info("r", "ament_cmake", src)], src, ["setup.py"]) == []
    # a package outside the sources (an extra package elsewhere) holds none of them
    assert packages.python_outside_packages(
        [_info("x", "ament_cmake", tmp_path / "x")], src, ["x/setup.py"]
    ) == ["x/setup.py"]


def _package(src: Path, name: str, build_type: str, deps: Sequence[str] = ()) -> None:
    folder = src / name
    folder.mkdir(parents=True)
    depends = "".join(f"<depend>{d}</depend>" for d in deps)
    (folder / "package.xml").write_text(
        f'<package format="3"><name>{name}</name><version>0.0.0</version>{depends}'
        f"<export><build_type>{build_type}</build_type></export></package>",
        encoding="utf-8",
    )
    if build_type == "ament_python":
        (folder / "setup.py").write_text("from setuptools import setup\nsetup()\n", encoding="utf-8")


def _setup(ws: Path, **args: object) -> tuple[Context, colcon_setup.ColconSetup]:
    plan = dataclasses.replace(
        plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", **args)), ccache=False
    )  # type: ignore[arg-type]
    plan.target_dir.mkdir(parents=True, exist_ok=True)
    facts = HostFacts(cmake="cmake", cmake_version="3.25.1", colcon="colcon")
    runner = FakeRunner(ws / "run.log")  # answers nothing: colcon's setup starts no process
    ctx = Context(plan, runner, facts, target_kind.kind_of(plan, facts))  # type: ignore[arg-type]
    records = fp.scan_tree(plan.workspace.source_dir, {})
    env = colcon_setup.environment(ctx)
    return ctx, colcon_setup.colcon_setup(ctx, env, plan.target_dir / "toolchain.cmake", records)


def test_a_target_blocks_the_python_extensions_only_while_it_builds_no_python_package(tmp_path: Path) -> None:
    """As in micro-ROS: rosidl_cli (ament_python) is needed by a compiled package, and the host
    stage builds it, so the target's colcon skips it; when the stage shares nothing after all, the
    target builds it and needs its Python extensions again."""
    ws = tmp_path / "ws"
    _package(ws, "rosidl_cli", "ament_python")
    _package(ws, "app", "ament_cmake", ["rosidl_cli"])
    _package(ws, "tool_py", "ament_python")  # nothing compiled needs it: left out (packages_ignore)
    ctx, setup = _setup(ws)
    assert setup.skipped == ("tool_py",) and setup.shared == ("rosidl_cli",) and not setup.loose_python
    assert setup.blocked == colcon.PYTHON_EXTENSIONS
    blocked = setup.colcon_env["COLCON_EXTENSION_BLOCKLIST"].split(":")
    assert blocked == [*colcon.UNUSED_EXTENSIONS, *colcon.PYTHON_EXTENSIONS]
    assert "COLCON_EXTENSION_BLOCKLIST" in setup.env and setup.env != setup.colcon_env  # the host stage's
    alone = colcon_setup.sharing(ctx, setup, ())  # the stage shares nothing: the target builds rosidl_cli
    assert alone.blocked == () and alone.colcon_env == dict(alone.env)
    assert colcon_setup.sharing(ctx, alone, ("rosidl_cli",)).blocked == colcon.PYTHON_EXTENSIONS


def test_a_target_keeps_the_python_extensions_for_a_setup_py_uros_does_not_list(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _package(ws, "app", "ament_cmake")
    (ws / "loose").mkdir()
    (ws / "loose" / "setup.py").write_text("from setuptools import setup\nsetup()\n", encoding="utf-8")
    _, setup = _setup(ws)
    assert setup.loose_python and setup.blocked == ()


def test_a_selection_that_leaves_the_python_package_out_blocks_them(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _package(ws, "app", "ament_cmake")
    _package(ws, "other", "ament_cmake", ["py_needed"])
    _package(ws, "py_needed", "ament_python")
    _, setup = _setup(ws)
    assert setup.blocked == ()  # other needs py_needed: colcon builds it
    _, setup = _setup(ws, packages=("app",))  # app's closure: other and py_needed ignored
    assert setup.blocked == colcon.PYTHON_EXTENSIONS
