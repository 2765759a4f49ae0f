"""Closures over package.xml dependencies (pure): the packages a selection builds, and the host
tools (dev_ws) an MCU build needs, on package.xml sets shaped like micro-ROS's."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.sources import packages
from uros_build.sources.packages import PackageInfo

TAGS = ("depend", "build_depend", "buildtool_depend", "exec_depend", "test_depend", "build_export_depend",
        "buildtool_export_depend", "group_depend", "member_of_group")  # fmt: skip


def _xml(root: Path, name: str, build_type: str = "ament_cmake", **deps: tuple[str, ...]) -> None:
    folder = root / name
    folder.mkdir(parents=True)
    lines = "".join(f"<{tag}>{d}</{tag}>" for tag in TAGS for d in deps.get(tag, ()))
    folder.joinpath("package.xml").write_text(
        f'<package format="3"><name>{name}</name>{lines}'
        f"<export><build_type>{build_type}</build_type></export></package>"
    )


def _dev_ws(root: Path) -> list[PackageInfo]:
    """A humble-shaped dev_ws: ament_cmake's family, ament_lint's linters, uncrustify, gtest."""
    _xml(root, "ament_package", "ament_python")
    _xml(root, "ament_cmake_core", buildtool_depend=("ament_package",))
    _xml(root, "ament_cmake_export_libraries", buildtool_depend=("ament_cmake_core",))
    _xml(root, "ament_cmake_test", buildtool_depend=("ament_cmake_core",))
    _xml(root, "ament_cmake", buildtool_export_depend=("ament_cmake_core", "ament_cmake_export_libraries",
                                                       "ament_cmake_test"))  # fmt: skip
    _xml(root, "ament_cmake_python", buildtool_depend=("ament_cmake_core",))
    _xml(root, "ament_index_python", "ament_python")
    _xml(root, "ament_cmake_ros", buildtool_depend=("ament_cmake",), exec_depend=("domain_coordinator",))
    _xml(root, "domain_coordinator", "ament_python")
    _xml(root, "uncrustify_vendor", buildtool_depend=("ament_cmake",))
    _xml(root, "ament_uncrustify", "ament_python", exec_depend=("uncrustify_vendor",))
    _xml(root, "ament_cmake_uncrustify", buildtool_depend=("ament_cmake",), exec_depend=("ament_uncrustify",))
    _xml(root, "ament_lint_auto", buildtool_depend=("ament_cmake_test",))
    _xml(root, "ament_lint_common", exec_depend=("ament_cmake_uncrustify", "ament_lint_auto"))
    _xml(root, "gtest_vendor", "cmake")
    _xml(root, "ament_cmake_gtest", buildtool_depend=("ament_cmake_test",), exec_depend=("gtest_vendor",))
    return packages.discover(root)


def _mcu_ws(root: Path) -> list[PackageInfo]:
    _xml(root, "rcutils", buildtool_depend=("ament_cmake_ros", "ament_cmake_python"),
         test_depend=("ament_lint_auto", "ament_lint_common", "ament_cmake_gtest"))  # fmt: skip
    _xml(root, "rosidl_adapter", "ament_python", exec_depend=("ament_index_python",),
         test_depend=("ament_lint_common",))  # fmt: skip
    _xml(root, "std_msgs", buildtool_depend=("ament_cmake", "rosidl_default_generators"),
         test_depend=("ament_lint_common",))  # fmt: skip
    _xml(root, "rosidl_default_generators", buildtool_export_depend=("ament_cmake_core",))
    return packages.discover(root)


def test_the_mcu_build_needs_ament_cmake_not_linters_or_uncrustify(tmp_path: Path) -> None:
    needed = packages.tool_closure(_mcu_ws(tmp_path / "mcu"), _dev_ws(tmp_path / "dev"))
    assert needed == {
        "ament_package", "ament_cmake_core", "ament_cmake_export_libraries", "ament_cmake_test",
        "ament_cmake", "ament_cmake_python", "ament_index_python", "ament_cmake_ros", "domain_coordinator",
    }  # fmt: skip


def test_a_package_that_uses_a_test_tool_outside_tests_gets_it(tmp_path: Path) -> None:
    mcu = tmp_path / "mcu"
    _xml(mcu, "my_lib", buildtool_depend=("ament_cmake",), build_depend=("ament_cmake_gtest",))
    needed = packages.tool_closure(packages.discover(mcu), _dev_ws(tmp_path / "dev"))
    assert {"ament_cmake_gtest", "gtest_vendor", "ament_cmake_test"} <= needed
    assert "uncrustify_vendor" not in needed


def test_group_dependencies_reach_every_member(tmp_path: Path) -> None:
    dev = tmp_path / "dev"
    _xml(dev, "gen_a", member_of_group=("rosidl_generator_packages",), depend=("helper",))
    _xml(dev, "gen_b", member_of_group=("rosidl_generator_packages",))
    _xml(dev, "helper", "ament_python")
    _xml(dev, "unrelated")
    _xml(dev, "defaults", group_depend=("rosidl_generator_packages",))
    mcu = tmp_path / "mcu"
    _xml(mcu, "msgs_a", buildtool_depend=("defaults",))
    _xml(mcu, "msgs_b", group_depend=("rosidl_generator_packages",))
    assert packages.tool_closure(packages.discover(mcu / "msgs_a"), packages.discover(dev)) == {
        "defaults", "gen_a", "gen_b", "helper",
    }  # fmt: skip
    assert packages.tool_closure(packages.discover(mcu / "msgs_b"), packages.discover(dev)) == {
        "gen_a", "gen_b", "helper",
    }  # fmt: skip


def test_nothing_needed_builds_nothing(tmp_path: Path) -> None:
    _xml(tmp_path / "mcu", "plain", "cmake")
    assert packages.tool_closure(packages.discover(tmp_path / "mcu"), _dev_ws(tmp_path / "dev")) == set()


@pytest.mark.parametrize(
    ("roots", "expected"),
    [(("std_msgs",), {"std_msgs", "rosidl_default_generators"}), (("nothing",), set())],
)
def test_closure_within_a_workspace(tmp_path: Path, roots: tuple[str, ...], expected: set[str]) -> None:
    assert packages.closure(_mcu_ws(tmp_path), roots) == expected


def test_left_out_is_everything_but_the_closure_and_none_for_unknown_roots(tmp_path: Path) -> None:
    mcu = _mcu_ws(tmp_path)
    names = {p.name for p in mcu}
    out = packages.left_out(mcu, ["std_msgs"])
    assert out == names - {"std_msgs", "rosidl_default_generators"} == {"rcutils", "rosidl_adapter"}
    # a root without a package.xml (a plain CMake package): colcon's --packages-up-to chooses
    assert packages.left_out(mcu, ["std_msgs", "plain_cmake_lib"]) is None
