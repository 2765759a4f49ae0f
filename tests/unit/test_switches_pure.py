"""The steps read the environment's switches from the plan (config/settings.py resolves them once):
switched off, each step does without, and runs nothing (the fake runner would record it)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

from fake_runner import FakeRunner

from uros_build.colcon import command as colcon
from uros_build.steps import colcon_setup, toolchain_file


def _plan(tmp_path: Path, **switches: Any) -> Any:
    on = {"compiler_seed": True, "gen_cache": True, "host_stage": True}
    return SimpleNamespace(target_dir=tmp_path, **{**on, **switches})


def test_compiler_seed_off_gives_the_toolchain_file_itself(tmp_path: Path) -> None:
    runner = FakeRunner(tmp_path / "log")
    toolchain = tmp_path / "toolchain.cmake"
    toolchain.write_text("set(CMAKE_SYSTEM_NAME Generic)\n")
    facts: Any = SimpleNamespace(gcc="", cmake="cmake", cmake_version="3.25")
    off = _plan(tmp_path, compiler_seed=False)
    ctx: Any = SimpleNamespace(plan=off, facts=facts, runner=runner)
    assert toolchain_file.seeded_toolchain(ctx, toolchain, {}) == toolchain
    plain = toolchain_file.host_toolchain(off, tmp_path, facts, runner, {"PATH": ""})  # type: ignore[arg-type]
    assert plain == tmp_path / "host-toolchain.cmake" and plain.is_file()
    assert runner.calls == [] and not (tmp_path / "toolchain-seeded.cmake").exists()


def test_gen_cache_off_gives_the_real_python(tmp_path: Path) -> None:
    runner = FakeRunner(tmp_path / "log")
    python = colcon_setup.python_shim(_plan(tmp_path, gen_cache=False), runner, tmp_path)  # type: ignore[arg-type]
    assert python == Path(colcon.host_python()) and runner.calls == []
    assert not (tmp_path / "uros-python").exists()


def test_host_stage_off_gives_no_stage(tmp_path: Path) -> None:
    ctx: Any = SimpleNamespace(plan=_plan(tmp_path, host_stage=False), facts=None, runner=None)
    assert colcon_setup._stage_for(ctx, frozenset(), {}, {}) is None
