from __future__ import annotations

from pathlib import Path

from golden import check_golden

from uros_build.colcon import ColconPlan, build_env, colcon_argv


def _plan(**kw: object) -> ColconPlan:
    base = dict(
        base_paths=(Path("/ws/mcu_ws"),),
        build_base=Path("/ws/.uros/targets/cortex-m7/build"),
        install_base=Path("/ws/.uros/targets/cortex-m7/install"),
        log_base=Path("/ws/.uros/targets/cortex-m7/log"),
        metas=(Path("/ws/.uros/targets/cortex-m7/colcon.meta"),),
        toolchain_file=Path("/ws/.uros/targets/cortex-m7/toolchain.cmake"),
        python="/venv/bin/python3",
    )
    base.update(kw)
    return ColconPlan(**base)  # type: ignore[arg-type]


def test_colcon_argv_golden() -> None:
    argv = colcon_argv(_plan())
    check_golden("colcon-argv.txt", "\n".join(argv) + "\n")
    # generate_lib's essentials
    assert "--merge-install" in argv and "--packages-ignore-regex=.*_cpp" in argv
    assert "--ignore-user-meta" in argv
    cmake_args = argv[argv.index("--cmake-args") + 1 :]
    for arg in (
        "-DBUILD_SHARED_LIBS=OFF",
        "-DBUILD_TESTING=OFF",
        "-DCMAKE_POSITION_INDEPENDENT_CODE:BOOL=OFF",
        "-DCMAKE_TOOLCHAIN_FILE=/ws/.uros/targets/cortex-m7/toolchain.cmake",
        "-DPython3_EXECUTABLE=/venv/bin/python3",
    ):
        assert arg in cmake_args


def test_host_build_has_no_toolchain() -> None:
    argv = colcon_argv(_plan(toolchain_file=None, ignore_regex=None, packages_up_to=("ament_cmake",)))
    assert not any(a.startswith("-DCMAKE_TOOLCHAIN_FILE") for a in argv)
    assert argv[argv.index("--packages-up-to") + 1] == "ament_cmake"


def test_env_scrubs_sourced_ros() -> None:
    base = {
        "PATH": "/opt/ros/humble/bin:/usr/bin:/home/u/ws/install/bin",
        "PYTHONPATH": "/opt/ros/humble/lib/python3.10/site-packages:/home/u/lib",
        "AMENT_PREFIX_PATH": "/opt/ros/humble:/home/u/ws/install",
        "CMAKE_PREFIX_PATH": "/opt/ros/humble",
        "ROS_DISTRO": "humble",
        "CFLAGS": "-march=native",
        "HOME": "/home/u",
    }
    env, scrubbed = build_env(base, python_bin_dir="/venv/bin", cmake_major=4)
    assert env["PATH"] == "/venv/bin:/usr/bin"
    assert env["PYTHONPATH"] == "/home/u/lib"
    for name in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "ROS_DISTRO", "CFLAGS"):
        assert name not in env
    assert env["HOME"] == "/home/u"
    assert env["CMAKE_POLICY_VERSION_MINIMUM"] == "3.5"
    assert "AMENT_PREFIX_PATH" in scrubbed and "PATH (ROS entries)" in scrubbed


def test_env_git_insteadof() -> None:
    env, _ = build_env({}, python_bin_dir="/b", git_config={"url./m/x.insteadOf": "https://github.com/x"})
    assert env["GIT_CONFIG_COUNT"] == "1"
    assert env["GIT_CONFIG_KEY_0"] == "url./m/x.insteadOf"
    assert env["GIT_CONFIG_VALUE_0"] == "https://github.com/x"
    assert "CMAKE_POLICY_VERSION_MINIMUM" not in env


def test_first_error_prefers_compiler_and_rosidl_messages() -> None:
    from uros_build.proc import first_error

    assert first_error(
        ["-- Up-to-date: /x/test_failed/lib.a", "/w/a.c:3:9: error: expected ';'", "FAILED: x"]
    ) == ("/w/a.c:3:9: error: expected ';'")
    rosidl = [
        "CMake Error at /i/share/rosidl_adapter/cmake/rosidl_adapt_interfaces.cmake:59 (message):",
        "Traceback (most recent call last):",
        "rosidl_adapter.parser.InvalidFieldDefinition: 'int32 a 3.5'",
    ]
    assert first_error(rosidl) == "rosidl_adapter.parser.InvalidFieldDefinition: 'int32 a 3.5'"
    assert first_error(["just output"]) == "just output"
    # iron: a generator's missing Python module, under ninja's very long FAILED line
    iron = [
        "FAILED: [code=1] " + "rosidl_generator_c/x.h " * 40,
        "Traceback (most recent call last):",
        "ModuleNotFoundError: No module named 'rosidl_pycommon'",
        "ninja: build stopped: subcommand failed.",
    ]
    assert first_error(iron) == "ModuleNotFoundError: No module named 'rosidl_pycommon'"
    assert len(first_error(["FAILED: " + "x" * 1000]) or "") == 300


def test_pure_python_packages_nothing_compiled_needs_are_skipped(tmp_path: Path) -> None:
    from uros_build import packages

    def pkg(name: str, build_type: str, deps: list[str] = [], ignored: bool = False) -> None:  # noqa: B006
        d = tmp_path / name
        d.mkdir()
        dep_xml = "".join(f"<build_depend>{x}</build_depend>" for x in deps)
        (d / "package.xml").write_text(
            f"<package format='3'><name>{name}</name>{dep_xml}<export><build_type>{build_type}</build_type></export></package>"
        )
        if ignored:
            (d / "COLCON_IGNORE").write_text("")

    pkg("ros2trace", "ament_python")
    pkg("rosidl_cli", "ament_python")
    pkg("needed_py", "ament_python", ["needed_too_py"])
    pkg("needed_too_py", "ament_python")
    pkg("rcl", "ament_cmake", ["needed_py"])
    pkg("ignored_py", "ament_python", ignored=True)
    found = packages.discover(tmp_path)
    assert [p.name for p in found] == ["needed_py", "needed_too_py", "rcl", "ros2trace", "rosidl_cli"]
    assert packages.host_only(found) == ["ros2trace", "rosidl_cli"]
    argv = colcon_argv(_plan(packages_ignore=("ros2trace", "rosidl_cli")))
    assert argv[argv.index("--packages-ignore") + 1 : argv.index("--packages-ignore") + 3] == [
        "ros2trace",
        "rosidl_cli",
    ]
