"""uros doctor's checks: pure functions of what the probes found."""

from __future__ import annotations

from pathlib import Path

from uros_build.colcon.fingerprint import FileRecord
from uros_build.commands import doctor as d
from uros_build.sources.wsfiles import Lock, LockedRepo
from uros_build.steps import inputs
from uros_build.target.profiles import find_profile


def test_versions_and_tools() -> None:
    assert d.version_tuple("2.39.5") == (2, 39, 5) and d.version_tuple("3.3.4rc1") == (3, 3)
    assert d.eval_cmake(None).status == d.FAIL and "apt-get install cmake" in d.eval_cmake(None).fix
    assert d.eval_cmake("3.25.1").status == d.OK and "POLICY" not in d.eval_cmake("3.25.1").detail
    assert "CMAKE_POLICY_VERSION_MINIMUM=3.5" in d.eval_cmake("4.0.2").detail
    assert d.eval_git("2.30.1", mirrors=True).status == d.FAIL
    assert d.eval_git("2.30.1", mirrors=False).status == d.WARN
    assert d.eval_git("2.31.0", mirrors=True).status == d.OK
    assert d.eval_git(None, mirrors=False).status == d.FAIL
    assert d.eval_empy("4.1", "py").status == d.FAIL and "'empy>=3.3.4,<4'" in d.eval_empy("4.1", "py").fix
    assert d.eval_empy(None, "py").status == d.FAIL and d.eval_empy("3.3.4", "py").status == d.OK
    assert d.eval_ninja(None).status == d.WARN and d.eval_colcon(None).status == d.FAIL


def test_ros_environment_and_disk() -> None:
    assert d.eval_ros_env({"HOME": "/root"}).status == d.OK
    sourced = d.eval_ros_env({"ROS_DISTRO": "humble", "AMENT_PREFIX_PATH": "/opt/ros/humble"})
    assert (
        sourced.status == d.WARN and "ROS_DISTRO" in sourced.detail and "AMENT_PREFIX_PATH" in sourced.detail
    )
    assert d.eval_disk(100 << 20, Path("/w")).status == d.FAIL
    assert d.eval_disk(2 << 30, Path("/w")).status == d.WARN
    assert d.eval_disk(50 << 30, Path("/w")).status == d.OK


def test_target_checks_name_what_is_missing() -> None:
    m7 = find_profile("cortex-m7")
    missing = d.eval_target(m7, None, "'arm-none-eabi-gcc' was not found on PATH")
    assert [c.status for c in missing] == [d.FAIL] and "gcc-arm-none-eabi" in missing[0].fix
    no_libc = d.eval_target(m7, "/usr/bin/arm-none-eabi-gcc", "arm-none-eabi-gcc has no C library (libc.a)")
    assert [c.status for c in no_libc] == [d.OK, d.FAIL, d.SKIP]
    no_cxx = d.eval_target(m7, "/usr/bin/arm-none-eabi-gcc", "arm-none-eabi-g++ has no C++ standard headers")
    assert [c.status for c in no_cxx] == [d.OK, d.OK, d.FAIL]
    assert [c.status for c in d.eval_target(m7, "/usr/bin/arm-none-eabi-gcc", None)] == [d.OK] * 3
    # rv32imc's compiler has no C++ headers: the build hands micro-ROS uros's wrappers (issue 32)
    rv = d.eval_target(find_profile("rv32imc"), "/usr/bin/riscv64-unknown-elf-gcc", None)
    assert [c.status for c in rv] == [d.OK] * 3 and "uros hands micro-ROS its wrappers" in rv[2].detail
    # an ESP32's compiler: doctor names what it makes for the core (issue 42)
    s3 = d.eval_target(
        find_profile("esp32s3"), "/x/xtensa-esp32s3-elf-gcc", None, "makes Espressif-core code"
    )
    assert s3[0].detail == "/x/xtensa-esp32s3-elf-gcc: makes Espressif-core code"


def test_workspace_state() -> None:
    lock = Lock("humble", {f"mcu_ws/r{i}": LockedRepo("u", "v", "s", f"c{i}") for i in range(5)})
    assert d.eval_lock(lock, {f"mcu_ws/r{i}": f"c{i}" for i in range(5)}).status == d.OK
    moved = d.eval_lock(lock, {**{f"mcu_ws/r{i}": f"c{i}" for i in range(5)}, "mcu_ws/r2": "other"})
    # create-firmware --force refuses a clone off its locked commit: the hint never names it there
    # (round 3, issue 34, 7: it named a fix that could not work)
    assert moved.status == d.WARN and "mcu_ws/r2" in moved.detail and "--force" not in moved.fix
    assert moved.fix.startswith("in the workspace, git -C mcu_ws/r2 checkout c2 puts it back")
    gone = d.eval_lock(lock, {"mcu_ws/r0": "c0"})
    assert gone.status == d.FAIL and "(and 1 more)" in gone.detail
    assert (
        gone.fix
        == "uros create-firmware --distro humble --locked --force clones the missing ones (in the workspace)"
    )
    both = d.eval_lock(lock, {"mcu_ws/r0": "x", "mcu_ws/r1": "y"})
    assert both.status == d.FAIL and both.fix.startswith(
        "git -C mcu_ws/r0 checkout c0 (and the same in the other 1) first, then uros create-firmware"
    )
    assert d.eval_dev_ws(False, False, True).status == d.WARN
    assert d.eval_dev_ws(True, False, True).detail == "built from another uros.lock"
    assert (
        d.eval_dev_ws(True, True, True).status == d.OK and d.eval_dev_ws(False, False, False).status == d.SKIP
    )
    assert d.eval_output("cortex-m7", True, []).detail == "built and up to date"
    stale = d.eval_output("cortex-m7", True, ["sources", "workspace settings"])
    assert (
        stale.status == d.WARN
        and stale.detail == "stale: inputs changed since the last build: sources, workspace settings"
    )
    assert d.eval_output("cortex-m7", False, None).status == d.WARN
    assert d.eval_output("cortex-m7", True, None).detail == "built (no record to compare)"


def test_render_one_line_per_check_with_the_fix() -> None:
    text = d.render(
        [d.Check("cmake", d.OK, "3.25.1"), d.Check("colcon", d.FAIL, "not found", "pip install colcon")]
    )
    assert text.splitlines() == ["ok    cmake   3.25.1", "FAIL  colcon  not found  -> pip install colcon"]
    assert d.failed([d.Check("a", d.WARN, "")]) == []


def test_doctor_sees_extra_packages_as_the_next_build_copies_them() -> None:
    """Issue 34, item 7: the copy in mcu_ws/extra_packages is replaced by the package's own
    folder, as workspace.sync_tree copies it (no .git names; files gone there go here too)."""

    def rec(sha: str) -> FileRecord:
        return FileRecord(1, 1, 1, sha)

    sources = {
        "src/fx_core/core.c": rec("a"),
        "extra_packages/fx_extra/extra.c": rec("old"),
        "extra_packages/fx_extra/gone.c": rec("g"),
        "extra_packages/fx_extra_two/x.c": rec("x"),
    }
    own = {"extra.c": rec("new"), ".git/HEAD": rec("h"), "sub/.gitignore": rec("i"), "package.xml": rec("p")}
    assert inputs.as_synced(sources, {"extra_packages/fx_extra": own}) == {
        "src/fx_core/core.c": rec("a"),
        "extra_packages/fx_extra/extra.c": rec("new"),
        "extra_packages/fx_extra/package.xml": rec("p"),
        "extra_packages/fx_extra_two/x.c": rec("x"),
    }
    assert inputs.as_synced(sources, {}) == sources


def test_a_ccache_that_cannot_be_used_is_a_warning() -> None:
    """The build compiles without it then (issue 34, item 7): doctor says so, and why."""
    check = d.eval_ccache("/usr/bin/ccache", "4.7.5", "its cache_dir /c: /c is not a folder")
    assert check.status == d.WARN and "cannot be used (its cache_dir /c: /c is not a folder)" in check.detail
    assert d.eval_ccache("/usr/bin/ccache", "4.7.5").status == d.OK
