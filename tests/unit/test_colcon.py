from __future__ import annotations

from pathlib import Path

from golden import check_golden

from uros_build.colcon.command import (
    UNUSED_EXTENSIONS,
    ColconPlan,
    build_env,
    ccache_counts,
    ccache_env,
    ccache_settings,
    ccache_trouble,
    colcon_argv,
    colcon_path,
    kept_by_ignores,
)


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
    argv = colcon_argv(
        _plan(toolchain_file=None, firmware=False, ignore_regex=None, packages_up_to=("ament_cmake",))
    )
    assert not any(
        a.startswith(("-DCMAKE_TOOLCHAIN_FILE", "-DTHIRDPARTY", "-DBUILD_SHARED_LIBS")) for a in argv
    )
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


def test_env_leaves_out_shells_nobody_sources_and_keeps_the_users_blocklist() -> None:
    env, _ = build_env({}, python_bin_dir="/b")
    blocked = env["COLCON_EXTENSION_BLOCKLIST"].split(":")
    assert blocked[:3] == ["colcon_core.shell.bash", "colcon_core.shell.zsh", "colcon_core.shell.powershell"]
    assert blocked == list(UNUSED_EXTENSIONS)  # and the rest no colcon build of uros uses
    # sh gives colcon its command environment on POSIX, bat on Windows; dsv is read by setup scripts
    assert not {"colcon_core.shell.sh", "colcon_core.shell.dsv", "colcon_core.shell.bat"} & set(blocked)
    mine = {
        "COLCON_EXTENSION_BLOCKLIST": "colcon_core.event_handler.desktop_notification:colcon_core.shell.zsh"
    }
    env, _ = build_env(mine, python_bin_dir="/b")
    assert env["COLCON_EXTENSION_BLOCKLIST"].split(":") == [
        "colcon_core.event_handler.desktop_notification",
        "colcon_core.shell.zsh",
        "colcon_core.shell.bash",
        "colcon_core.shell.powershell",
        *UNUSED_EXTENSIONS[3:],
    ]


def test_env_git_insteadof() -> None:
    env, _ = build_env({}, python_bin_dir="/b", git_config={"url./m/x.insteadOf": "https://github.com/x"})
    assert env["GIT_CONFIG_COUNT"] == "1"
    assert env["GIT_CONFIG_KEY_0"] == "url./m/x.insteadOf"
    assert env["GIT_CONFIG_VALUE_0"] == "https://github.com/x"
    assert "CMAKE_POLICY_VERSION_MINIMUM" not in env


def test_first_error_prefers_compiler_and_rosidl_messages() -> None:
    from uros_build.tooltext import first_error

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
    from uros_build.sources import packages

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


# --- colcon's job events -------------------------------------------------------------------------


def test_parse_event_reads_console_start_end_lines() -> None:
    from uros_build.colcon.command import JobEvent, parse_event

    assert parse_event("Starting >>> fx_core") == JobEvent("start", "fx_core")
    assert parse_event("Finished <<< fx_core [0.52s]") == JobEvent("finish", "fx_core", 0.52)
    assert parse_event("Finished <<< rcl [1min 3s]") == JobEvent("finish", "rcl", 63.0)
    assert parse_event("Failed   <<< fx_dup [0.05s, exited with code 1]") == JobEvent("fail", "fx_dup", 0.05)
    assert parse_event("Aborted  <<< rclc [2.1s]") == JobEvent("abort", "rclc", 2.1)
    # an output style's colours
    assert parse_event("\x1b[1mFinished\x1b[0m <<< \x1b[32mfx_util\x1b[0m [1.0s]") == JobEvent(
        "finish", "fx_util", 1.0
    )
    for line in ("Summary: 5 packages finished [3.1s]", "-- Starting >>> x", "", "Finished building"):
        assert parse_event(line) is None


def test_parse_duration() -> None:
    from uros_build.colcon.command import parse_duration

    assert parse_duration("0.05s") == 0.05
    assert parse_duration("2min 1s") == 121.0
    assert parse_duration("1h 0min 5s") == 3605.0
    assert parse_duration("soon") is None


def test_build_progress_tracks_running_finished_and_failed() -> None:
    from uros_build.colcon.command import BuildProgress

    p = BuildProgress(total=3, started_at=0.0)
    p.feed("Starting >>> a", 1.0)
    p.feed("Starting >>> b", 2.0)
    assert p.running == {"a": 1.0, "b": 2.0} and p.done == 0
    p.feed("Finished <<< a [4.0s]", 5.0)
    p.feed("some compiler output", 5.5)
    p.feed("Failed   <<< b [exited with code 2]", 6.0)  # no duration: measured from the lines
    assert p.finished == {"a": 4.0} and p.failed == ["b"] and p.running == {} and p.done == 2
    p.feed("Starting >>> c", 6.0)
    p.feed("Finished <<< c [9.0s]", 15.0)
    assert p.slowest(2) == [("c", 9.0), ("a", 4.0)]


def test_kept_by_ignores_matches_the_regex_as_a_prefix_as_colcon_does() -> None:
    plan = _plan(packages_ignore=("fx_host_py",))
    names = {
        "rcl",
        "rosidl_typesupport_cpp",
        "rosidl_typesupport_microxrcedds_cpp_tests",
        "fx_host_py",
        "my_cpp_x",
    }
    assert kept_by_ignores(plan, names) == {"rcl"}
    assert kept_by_ignores(_plan(ignore_regex=None), names) == names


def test_env_scrubs_what_gcc_reads_behind_the_command_line() -> None:
    base = {
        "PATH": "/usr/bin",
        "CPATH": "/evil",
        "C_INCLUDE_PATH": "/x",
        "LIBRARY_PATH": "/y",
        "GCC_EXEC_PREFIX": "/z",
    }
    env, scrubbed = build_env(base, python_bin_dir="/venv/bin")
    assert not {"CPATH", "C_INCLUDE_PATH", "LIBRARY_PATH", "GCC_EXEC_PREFIX"} & set(env)
    assert {"CPATH", "C_INCLUDE_PATH", "LIBRARY_PATH", "GCC_EXEC_PREFIX"} <= set(scrubbed)


def test_ccache_knows_the_compiler_by_its_content() -> None:
    """ccache's default check (size and mtime) gave a replaced compiler of the same size and mtime
    the old one's objects (issue 34, item 7)."""
    env = ccache_env(Path("/ws"), Path("/ws/.uros/stats.log"))
    assert env["CCACHE_COMPILERCHECK"] == "content" and env["CCACHE_INODECACHE"] == "true"


def test_no_launcher_is_said_as_an_empty_one() -> None:
    """A package's CMakeCache.txt keeps the last configure's launcher: a build without ccache
    must clear it, or ccache uninstalled fails every compile (issue 34, item 7)."""
    plan = ColconPlan(
        base_paths=(Path("/ws/src"),),
        build_base=Path("/b"),
        install_base=Path("/i"),
        log_base=Path("/l"),
        metas=(),
        toolchain_file=None,
        python="/py",
    )
    assert "-DCMAKE_C_COMPILER_LAUNCHER=" in colcon_argv(plan)
    assert "-DCMAKE_CXX_COMPILER_LAUNCHER=" in colcon_argv(plan)
    with_ccache = colcon_argv(ColconPlan(**{**plan.__dict__, "compiler_launcher": "/usr/bin/ccache"}))
    assert "-DCMAKE_C_COMPILER_LAUNCHER=/usr/bin/ccache" in with_ccache


def test_ccache_trouble_names_the_folder_it_cannot_use(tmp_path: Path) -> None:
    shown = ccache_settings(
        "(default) absolute_paths_in_stderr = false\n"
        f"(environment) cache_dir = {tmp_path}/cache\n"
        f"(default) temporary_dir = {tmp_path}/cache/tmp\n"
        "(default) read_only = false\n"
    )
    assert shown["cache_dir"] == f"{tmp_path}/cache"
    assert ccache_trouble(shown) is None  # not made yet: ccache makes it in tmp_path
    (tmp_path / "cache").write_text("a file\n")
    trouble = ccache_trouble(shown)
    assert trouble == f"its cache_dir {tmp_path}/cache: {tmp_path}/cache is not a folder"
    (tmp_path / "cache").unlink()
    (tmp_path / "cache").mkdir()
    assert ccache_trouble(shown) is None
    # read_only: ccache writes no cache, only its temporary folder
    assert ccache_trouble({"cache_dir": f"{tmp_path}/cache/x/y", "read_only": "true"}) is None
    (tmp_path / "f").write_text("")
    assert (
        ccache_trouble({"temporary_dir": f"{tmp_path}/f/t"})
        == f"its temporary_dir {tmp_path}/f/t: {tmp_path}/f is not a folder"
    )


def test_a_star_in_a_path_is_escaped_for_colcon_discovery() -> None:
    """colcon globs a --base-paths entry holding `*` (issue 34, item 7); without `*` it does not,
    so only such a path is escaped."""
    assert colcon_path(Path("/home/me/fw*/mcu_ws/src")) == "/home/me/fw[*]/mcu_ws/src"
    assert colcon_path(Path("/home/me/fw*[1]?/src")) == "/home/me/fw[*][[]1][?]/src"
    assert colcon_path(Path("/home/me/fw[1]?/src")) == "/home/me/fw[1]?/src"


def test_ccache_counts_say_what_its_remote_storage_served() -> None:
    """Issue 33, item 6: a compile taken from ccache's remote storage (a team's Redis) is a hit
    that the build names as remote; ccache logs one remote_storage_hit per compile and a
    remote_storage_read_hit per file read (ccache 4.7's stats_log, as test_ccache_remote.py's
    build wrote it)."""
    remote = "# a.c\ndirect_cache_hit\nlocal_storage_miss\nremote_storage_hit\nremote_storage_read_hit\nremote_storage_read_hit\n"
    local = "# b.c\ndirect_cache_hit\nlocal_storage_hit\n# c.c\ncache_miss\ndirect_cache_miss\nremote_storage_read_miss\n"
    assert ccache_counts(remote + local) == {"hits": 2, "misses": 1, "remote_hits": 1}
    assert ccache_counts(local) == {"hits": 1, "misses": 1}  # no remote storage: as before
