"""Each step of `uros build` over one frozen context and the fake runner (tests/unit/fake_runner.py):
a real plan of a small plain workspace, no process started. The build as a whole is tested through
the real CLI in tests/integration."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest
from fake_idf import make_idf_build
from fake_runner import FakeRunner

from uros_build.colcon import command as colcon
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import hoststage, installtree
from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildargs import BuildArgs
from uros_build.config.buildplan import BuildPlan
from uros_build.config.plan import plan_build
from uros_build.errors import StepFailed
from uros_build.output import folders as outputs
from uros_build.output.archive import MergeReport
from uros_build.steps import (
    colcon_run,
    colcon_setup,
    deliver,
    host_stage,
    inputs,
    prepare,
    start,
    target_kind,
    team_cache,
    toolchain_file,
)
from uros_build.steps.context import Context

FACTS = HostFacts(cmake="cmake", cmake_version="3.25.1", colcon="colcon")
C_FACTS = 'set(CMAKE_{lang}_COMPILER "/usr/bin/arm-none-eabi-gcc")\nset(CMAKE_{lang}_COMPILER_ID "GNU")\n'


def _package(src: Path, name: str, deps: Sequence[str] = ()) -> None:
    folder = src / name
    folder.mkdir(parents=True)
    depends = "".join(f"<depend>{d}</depend>" for d in deps)
    (folder / "package.xml").write_text(
        f'<package format="3"><name>{name}</name><version>0.0.0</version>{depends}'
        "<export><build_type>ament_cmake</build_type></export></package>",
        encoding="utf-8",
    )


def _cmake(argv: Sequence[str]) -> str:
    """cmake configuring the compiler-facts project: it leaves CMake<LANG>Compiler.cmake."""
    build = Path(argv[argv.index("-B") + 1])
    platform = build / "CMakeFiles" / "3.25.1"
    platform.mkdir(parents=True)
    for lang in ("C", "CXX"):
        (platform / f"CMake{lang}Compiler.cmake").write_text(C_FACTS.format(lang=lang))
    (build / "CMakeCache.txt").write_text("CMAKE_EXECUTABLE_FORMAT:INTERNAL=ELF\n")
    return ""


def _plan(tmp_path: Path, *names: str, toolchain: str = "cortex-m7", **args: Any) -> BuildPlan:
    ws = tmp_path / "ws"
    for name in names or ("app",):
        _package(ws, name)
    plan = plan_build(BuildArgs(workspace=ws, toolchain=toolchain, **args))
    plan.target_dir.mkdir(parents=True, exist_ok=True)
    return dataclasses.replace(plan, ccache=False)


def _ctx(plan: BuildPlan, **answers: Any) -> Context:
    # python: asked what CMake will ask it, it answers nothing (every question goes to it then)
    python = {Path(colcon.host_python()).name: lambda argv: ""}
    runner = FakeRunner(plan.workspace.root / "run.log", {"cmake": _cmake, **python, **answers})
    return Context(plan, runner, FACTS, target_kind.kind_of(plan, FACTS))  # type: ignore[arg-type]


def _setup(ctx: Context) -> tuple[Path, colcon_setup.ColconSetup, dict[str, fp.FileRecord]]:
    toolchain = toolchain_file.write_toolchain(ctx)
    sources = inputs.scan(ctx)
    env = colcon_setup.environment(ctx)
    seeded = toolchain_file.seeded_toolchain(ctx, toolchain, env.env)
    return toolchain, colcon_setup.colcon_setup(ctx, env, seeded, sources), sources


# -- start ---------------------------------------------------------------------------------------


def test_start_opens_the_runs_log_and_builds_no_dev_ws_for_a_plain_workspace(tmp_path: Path) -> None:
    plan = _plan(tmp_path)
    runner = start.open_run(plan)
    assert runner.log_path.is_file() and runner.log_path.is_relative_to(plan.workspace.root)
    ctx = _ctx(plan)
    start.sync_extra_packages(ctx)  # no uros.yaml: no extra packages, no dev_ws
    start.build_dev_workspace(ctx)
    assert ctx.runner.calls == []  # type: ignore[attr-defined]


# -- prepare -------------------------------------------------------------------------------------


def test_prepare_reconfigures_after_a_full_disk_and_drops_packages_the_workspace_lost(tmp_path: Path) -> None:
    plan = _plan(tmp_path)
    build = plan.target_dir / "build"
    for name in ("app", "gone"):
        (build / name).mkdir(parents=True)
        (build / name / "CMakeCache.txt").write_text("CMAKE_HOME_DIRECTORY:INTERNAL=x\n")
    (plan.target_dir / prepare.DISK_FULL_MARK).write_text("")
    ctx = _ctx(plan)
    assert prepare.prepare_trees(ctx) is False  # nothing a killed build left
    assert not (build / "app" / "CMakeCache.txt").exists()  # the full disk: every package configures
    assert not (plan.target_dir / prepare.DISK_FULL_MARK).exists()
    assert (plan.target_dir / "compiler.sha256").is_file()  # the compiler's identity, for the next build
    prepare.drop_removed_packages(ctx)
    assert (build / "app").is_dir() and not (build / "gone").exists()
    assert prepare.drop_readers_of_changed_headers(ctx)  # no record yet: the digest of none
    assert ctx.runner.calls == []  # type: ignore[attr-defined]


# -- toolchain_file ------------------------------------------------------------------------------


def test_the_toolchain_file_is_written_when_it_changes_and_seeded_once(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path))
    cache = ctx.plan.target_dir / "build" / "app" / "CMakeCache.txt"
    cache.parent.mkdir(parents=True)
    path = toolchain_file.write_toolchain(ctx)
    assert path == ctx.plan.target_dir / "toolchain.cmake" and "cortex-m7" in path.read_text()
    assert not cache.exists()  # a new toolchain file: its flags reach the compiles by a fresh configure
    cache.write_text("")
    assert toolchain_file.write_toolchain(ctx) == path and cache.exists()  # unchanged: configures kept
    seeded = toolchain_file.seeded_toolchain(ctx, path, {})
    assert seeded != path and str(path) in seeded.read_text()
    assert toolchain_file.seeded_toolchain(ctx, path, {}) == seeded
    assert [c[0] for c in ctx.runner.calls] == ["cmake"]  # type: ignore[attr-defined]  # found once


# -- colcon_setup --------------------------------------------------------------------------------


def test_colcons_command_and_the_host_stages_packages_skipped(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path, "app", "rosidl_typesupport_interface"))
    _, setup, _ = _setup(ctx)
    assert (ctx.plan.target_dir / "colcon.meta").is_file()
    shim = ctx.plan.target_dir / "uros-python"  # the generation cache's shim: colcon's Python
    assert f"-DPython3_EXECUTABLE={shim}" in setup.argv and not shim.exists()  # named, not written yet
    assert colcon_setup.python_shim(ctx.plan, ctx.runner, ctx.plan.target_dir) == shim and shim.is_file()
    assert setup.building == {"app", "rosidl_typesupport_interface"}
    assert setup.stage is not None and setup.stage.packages == ("rosidl_typesupport_interface",)
    # never built: every package the stage will build is skipped by the target's colcon
    assert setup.shared == ("rosidl_typesupport_interface",) and "--packages-skip" in setup.argv
    fewer = colcon_setup.sharing(ctx, setup, ())  # the stage shares nothing after all
    assert "--packages-skip" not in fewer.argv and fewer.shared == ()
    assert setup.shared == ("rosidl_typesupport_interface",)  # a new record: the old one unchanged
    assert colcon_setup.sharing(ctx, setup, setup.shared) is setup


# -- inputs --------------------------------------------------------------------------------------


def test_inputs_are_a_frozen_record_and_later_facts_make_new_ones(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path))
    toolchain, setup, sources = _setup(ctx)
    found = inputs.resolve(ctx, toolchain, setup, sources, "outside")
    assert found.previous is None and len(found.key) == 64
    assert inputs.resolve(ctx, toolchain, setup, sources, "outside").key == found.key  # by content
    with pytest.raises(dataclasses.FrozenInstanceError):
        found.key = ""  # type: ignore[misc]
    after = inputs.with_outside_headers(found, "read by colcon")
    assert after.parts["headers outside the workspace"] == "read by colcon"
    assert found.parts["headers outside the workspace"] == "outside" and after.key == found.key
    assert inputs.with_colcon(ctx, found, setup).parts == found.parts  # the same command: the same parts
    assert not inputs.up_to_date(ctx, found, repaired=False)  # never built


# -- host_stage ----------------------------------------------------------------------------------


def test_a_host_stage_whose_colcon_fails_shares_nothing(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path, "app", "rosidl_typesupport_interface"))  # colcon has no answer: fails
    _, setup, _ = _setup(ctx)
    assert setup.stage is not None
    assert host_stage.ready(ctx, setup) == ()  # each target builds the package itself
    marker = hoststage.read_marker(setup.stage)
    assert marker is not None and marker.failed
    assert host_stage.ready(ctx, setup) == ()  # remembered for the stage's key: not tried again
    colcons = [c for c in ctx.runner.calls if c[0] == "colcon"]  # type: ignore[attr-defined]
    assert len(colcons) == 1
    assert host_stage.ready(ctx, colcon_setup.sharing(ctx, setup, ())) == ()


def test_no_host_stage_readies_nothing(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path))
    _, setup, _ = _setup(ctx)
    calls = len(ctx.runner.calls)  # type: ignore[attr-defined]
    assert setup.stage is None and host_stage.ready(ctx, setup) == ()
    assert len(ctx.runner.calls) == calls  # type: ignore[attr-defined]


# -- colcon_run ----------------------------------------------------------------------------------


def _colcon_builds(build_base: Path, install_base: Path) -> Any:
    """colcon building app: its archive and header installed, its manifest written."""

    def answer(argv: Sequence[str]) -> str:
        (install_base / "lib").mkdir(parents=True, exist_ok=True)
        (install_base / "include" / "app").mkdir(parents=True, exist_ok=True)
        (install_base / "lib" / "libapp.a").write_bytes(b"!<arch>\n")
        (install_base / "include" / "app" / "app.h").write_text("/* app */\n")
        (build_base / "app").mkdir(parents=True, exist_ok=True)
        manifest = f"{install_base / 'lib' / 'libapp.a'}\n{install_base / 'include' / 'app' / 'app.h'}\n"
        (build_base / "app" / "install_manifest.txt").write_text(manifest)
        return "Starting >>> app\nFinished <<< app [0.52s]\n"

    return answer


def test_colcon_runs_and_says_what_it_built(tmp_path: Path) -> None:
    plan = _plan(tmp_path)
    build_base, install_base = plan.target_dir / "build", plan.target_dir / "install"
    ctx = _ctx(plan, colcon=_colcon_builds(build_base, install_base))
    toolchain, setup, sources = _setup(ctx)
    found = inputs.resolve(ctx, toolchain, setup, sources, "outside")
    compiled = colcon_run.compile_packages(ctx, setup, found)
    assert compiled.packages == ("app",) and compiled.shared == () and compiled.ccache == {}
    assert compiled.progress.finished == {"app": pytest.approx(0.52)}
    assert installtree.stale(build_base, {"app": "another flags stamp"}) == ["app"]  # stamped
    assert compiled.outside_headers and found.parts["headers outside the workspace"] == "outside"


def test_a_failed_colcon_is_a_failed_step(tmp_path: Path) -> None:
    ctx = _ctx(_plan(tmp_path))  # no answer for colcon: it fails
    toolchain, setup, sources = _setup(ctx)
    found = inputs.resolve(ctx, toolchain, setup, sources, "outside")
    with pytest.raises(StepFailed, match="colcon build"):
        colcon_run.compile_packages(ctx, setup, found)
    assert not (ctx.plan.target_dir / prepare.DISK_FULL_MARK).exists()  # not a full disk


# -- deliver and team_cache ------------------------------------------------------------------------


def _fake_merge(runner: Any, tools: Any, libs: Sequence[Path], library: Path, scratch: Path) -> MergeReport:
    """The merge itself is tested in test_archive.py: here the library is the one input."""
    library.write_bytes(libs[0].read_bytes())
    return MergeReport(inputs=tuple(lib.name for lib in libs), members=1, symbols=1, renamed_duplicates=0)


def test_deliver_assembles_swaps_in_and_records_the_state(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(deliver, "merge_archives", _fake_merge)
    (tmp_path / "board.cmake").write_text("set(CMAKE_SYSTEM_NAME Generic)\n")
    plan = _plan(tmp_path, toolchain=str(tmp_path / "board.cmake"))  # the user's own: no ABI check
    build_base, install_base = plan.target_dir / "build", plan.target_dir / "install"
    ctx = _ctx(plan, colcon=_colcon_builds(build_base, install_base))
    toolchain, setup, sources = _setup(ctx)
    found = inputs.resolve(ctx, toolchain, setup, sources, "outside")
    compiled = colcon_run.compile_packages(ctx, setup, found)
    assembled = deliver.assemble(ctx, found, setup, compiled)
    info = assembled.info
    assert info.build_key == found.key and info.packages == ("app",) and info.toolchain_file
    assert info.abi_check["checked"] is False and assembled.merge_key
    assert (assembled.folder / "include" / "app" / "app.h").is_file()
    assert outputs.entries_of(assembled.folder) == sorted(
        {p.name for p in assembled.folder.iterdir()} | {"build-info.json"}
    )
    assert deliver.swap_in(ctx, found, assembled) == []
    assert json.loads((plan.output / "build-info.json").read_text())["build_key"] == found.key
    assert not assembled.folder.exists()
    assert inputs.up_to_date(ctx, inputs.resolve(ctx, toolchain, setup, sources, "outside"), False)
    deliver.say_done(ctx, assembled, [], 0.0, "")
    team_cache.upload_if_asked(ctx, found.key, outputs.entries_of(plan.output))  # no cache: nothing
    assert team_cache.take(ctx, found.key, {}) is None


# -- target_kind ---------------------------------------------------------------------------------


def test_the_target_kind_is_chosen_once_and_answers_for_the_target(tmp_path: Path) -> None:
    """A profile's target, the user's own toolchain file, an ESP-IDF project: the steps ask the
    kind, never which kind it is."""
    (tmp_path / "board.cmake").write_text("set(CMAKE_SYSTEM_NAME Generic)\n")
    own = target_kind.kind_of(_plan(tmp_path / "own", toolchain=str(tmp_path / "board.cmake")), FACTS)
    profile = target_kind.kind_of(_plan(tmp_path / "m7"), FACTS)
    idf_plan = _plan(tmp_path / "idf", toolchain="esp32s3", idf_build=make_idf_build(tmp_path / "idf-build"))
    idf = target_kind.kind_of(idf_plan, FACTS)
    assert isinstance(own, target_kind.OwnToolchainFile) and isinstance(idf, target_kind.IdfProfile)
    assert isinstance(profile, target_kind.Profile) and not isinstance(profile, target_kind.IdfProfile)
    assert (own.uses_ccache, profile.uses_ccache) == (False, True)
    assert own.firmware_toolchain() is None and "cortex-m7" in (profile.firmware_toolchain() or "")
    assert own.check_library(FakeRunner(tmp_path / "log"), tmp_path / "lib.a")["checked"] is False  # type: ignore[arg-type]
    assert own.described().toolchain_file == str(tmp_path / "board.cmake")
    described = profile.described()
    assert (
        described.profile == "cortex-m7.yaml" and described.idf is None and described.toolchain_file is None
    )
    assert idf.described().idf is not None and idf.described().idf_target == "esp32s3"
    # the portable key's toolchain text: no workspace folder in it, the user's file as it is
    m7_plan = _plan(tmp_path / "m7b")
    m7 = target_kind.kind_of(m7_plan, FACTS)
    assert str(m7_plan.workspace.root) not in m7.portable_toolchain(m7.write_toolchain())
    assert str(m7_plan.workspace.root) in m7.write_toolchain().read_text()
    assert own.portable_toolchain(tmp_path / "board.cmake") == (tmp_path / "board.cmake").read_text()
