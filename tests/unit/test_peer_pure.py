"""`uros probe --peer`'s pure pieces: the wheels' CMake mend, the venv's cache key and spec, which
interface packages are built for the host and in what order, the namespace's command lines, the
peer's environment and the verdict of firmware and peer together (run/peerenv.py, run/netns.py,
run/peer.py)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import pytest

from tests.unit.fake_runner import FakeRunner
from uros_build.errors import ConfigError, StepFailed
from uros_build.probesteps.plan import check_peer
from uros_build.run import netns, peerenv
from uros_build.run.peer import peer_verdict
from uros_build.sources.packages import PackageInfo

# what the ros-* wheels' std_msgs__rosidl_generator_pyExport.cmake says (trimmed)
WHEEL_CMAKE = (
    "set_target_properties(std_msgs::std_msgs__rosidl_generator_py PROPERTIES\n"
    '  INTERFACE_INCLUDE_DIRECTORIES "/opt/python/cp311-cp311/include/python3.11;'
    '/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"\n'
    '  INTERFACE_LINK_LIBRARIES "std_msgs::std_msgs__rosidl_typesupport_c"\n)\n'
)


def test_the_wheels_cmake_gets_the_venv_s_include_folders() -> None:
    fixed = peerenv.fix_wheel_cmake(WHEEL_CMAKE, "/usr/include/python3.11", "/v/lib/numpy/_core/include")
    assert '"/usr/include/python3.11;/v/lib/numpy/_core/include"' in fixed
    assert "/opt/python" not in fixed
    assert "std_msgs::std_msgs__rosidl_typesupport_c" in fixed  # the rest untouched
    assert peerenv.fix_wheel_cmake(fixed, "/usr/include/python3.11", "/x") == fixed  # idempotent
    older = WHEEL_CMAKE.replace("cp311-cp311", "cp310-cp310").replace("python3.11", "python3.10")
    assert "/opt/python" not in peerenv.fix_wheel_cmake(older.replace("_core", "core"), "/p", "/n")


def test_the_shipped_spec_is_pinned_and_names_rclpy() -> None:
    spec = peerenv.load_spec()
    assert any(p.startswith("ros-rclpy==") for p in spec.packages)
    assert all("==" in p for p in spec.packages)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"distro": "kilted", "packages": ["ros-rclpy"]}, "is not pinned"),
        ({"distro": "kilted", "packages": ["ros-rclpy>=9"]}, "is not pinned"),
        ({"distro": "kilted", "packages": []}, "packages: empty"),
        ({"distro": "Kilted!", "packages": ["ros-rclpy==9.1.2"]}, "not a ROS 2 distro name"),
        ({"packages": ["ros-rclpy==9.1.2"]}, "distro"),
    ],
)
def test_a_bad_spec_is_one_line_naming_the_file(data: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as caught:
        peerenv.parse_spec(data, "ros2-peer.yaml")
    assert "ros2-peer.yaml" in str(caught.value)


def test_the_venv_key_follows_the_versions_and_the_python() -> None:
    spec = peerenv.PeerEnvSpec("kilted", ("ros-rclpy==9.1.2", "catkin_pkg==1.1.1"))
    same = peerenv.PeerEnvSpec("kilted", ("catkin_pkg==1.1.1", "ros-rclpy==9.1.2"))
    newer = peerenv.PeerEnvSpec("kilted", ("ros-rclpy==9.1.3", "catkin_pkg==1.1.1"))
    key = peerenv.venv_key(spec, "3.11")
    assert key == peerenv.venv_key(same, "3.11")
    assert key != peerenv.venv_key(newer, "3.11")
    assert key != peerenv.venv_key(spec, "3.12")
    assert peerenv.venv_path(Path("/c"), spec, "3.11") == Path(f"/c/kilted-py3.11-{key}")


def test_the_interfaces_key_follows_every_file_and_the_dependencies() -> None:
    files = {"msg/CmdVel.msg": b"int32 left_rpm\n", "package.xml": b"<package/>"}
    changed = {"msg/CmdVel.msg": b"int16 left_rpm\n", "package.xml": b"<package/>"}
    assert peerenv.interfaces_key("v1", files) != peerenv.interfaces_key("v1", changed)
    assert peerenv.interfaces_key("v1", files) != peerenv.interfaces_key("v2", files)
    assert peerenv.interfaces_key("v1", files) == peerenv.interfaces_key("v1", dict(files))
    assert peerenv.interfaces_key("v1", files, ["k1"]) != peerenv.interfaces_key("v1", files, ["k2"])


def _pkg(name: str, deps: Sequence[str] = (), interface: bool = True) -> PackageInfo:
    groups = frozenset({peerenv.INTERFACE_GROUP}) if interface else frozenset()
    return PackageInfo(name, "ament_cmake", frozenset(deps), Path(f"/ws/{name}"), groups=groups)


def test_the_library_s_interface_packages_the_venv_lacks_in_build_order() -> None:
    found = [
        _pkg("robot_msgs", ["std_msgs", "base_msgs"]),
        _pkg("base_msgs", ["builtin_interfaces"]),
        _pkg("std_msgs"),
        _pkg("rclc", interface=False),
        _pkg("not_in_library"),
        _pkg("example_interfaces"),
    ]
    library = ["robot_msgs", "base_msgs", "std_msgs", "rclc", "example_interfaces"]
    have = {"std_msgs", "builtin_interfaces"}
    names = [p.name for p in peerenv.interface_packages(found, library, have)]
    assert names == ["base_msgs", "example_interfaces", "robot_msgs"]
    # the workspace's own packages and what they need, not every upstream one the wheels lack
    own = [p.name for p in peerenv.interface_packages(found, library, have, own=["robot_msgs"])]
    assert own == ["base_msgs", "robot_msgs"]
    assert peerenv.interface_packages(found, library, have, own=[]) == []


def test_the_host_build_argv_and_environment() -> None:
    prefixes = peerenv.HostPrefixes(Path("/pre"), Path("/venv"), (Path("/dep"),))
    argv = peerenv.cmake_configure_argv("cmake", Path("/ws/eic"), Path("/b"), prefixes)
    assert "-DCMAKE_PREFIX_PATH=/dep;/venv" in argv
    assert "-DCMAKE_INSTALL_PREFIX=/pre" in argv
    assert "-DPython3_EXECUTABLE=/venv/bin/python3" in argv
    env = peerenv.build_env({"PATH": "/usr/bin", "PYTHONPATH": "/uros"}, Path("/venv"), [Path("/dep")])
    assert env["PATH"] == "/venv/bin:/usr/bin"
    assert env["AMENT_PREFIX_PATH"] == "/dep:/venv"
    assert "PYTHONPATH" not in env


def test_the_peer_s_environment() -> None:
    base = {"PATH": "/usr/bin", "PYTHONPATH": "/uros", "VIRTUAL_ENV": "/uros-venv", "LD_LIBRARY_PATH": "/l"}
    env = peerenv.peer_env(base, Path("/venv"), [Path("/a"), Path("/b")], "3.11")
    assert env["PYTHONPATH"] == "/a/lib/python3.11/site-packages:/b/lib/python3.11/site-packages"
    assert env["LD_LIBRARY_PATH"] == "/a/lib:/b/lib:/l"
    assert env["AMENT_PREFIX_PATH"] == "/a:/b:/venv"
    assert env["RMW_IMPLEMENTATION"] == "rmw_fastrtps_cpp"
    assert "VIRTUAL_ENV" not in env
    bare = peerenv.peer_env(base, Path("/venv"), [], "3.11")
    assert "PYTHONPATH" not in bare and bare["AMENT_PREFIX_PATH"] == "/venv"
    assert peerenv.peer_argv(Path("/venv"), Path("/p.py")) == ["/venv/bin/python3", "-u", "/p.py"]


def test_the_namespace_argv() -> None:
    assert netns.holder_argv()[:2] == ["unshare", "--net"]
    assert netns.enter_argv(42, ["agent", "-m", "dds"]) == [
        "nsenter",
        "--net=/proc/42/ns/net",
        "--",
        "agent",
        "-m",
        "dds",
    ]
    assert netns.loopback_argv() == ["ip", "link", "set", "lo", "up", "multicast", "on"]
    netns.check_root(0, "uros probe --peer p.py")
    with pytest.raises(ConfigError, match="needs root"):
        netns.check_root(1000, "uros probe --peer p.py")


def test_peer_is_checked_before_anything_runs(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"--peer .*missing\.py: no such file"):
        check_peer(tmp_path / "missing.py", 0)
    script = tmp_path / "peer.py"
    script.write_text("import rclpy\n", encoding="utf-8")
    check_peer(script, 0)
    with pytest.raises(ConfigError, match="needs root"):
        check_peer(script, 1000)


@pytest.mark.parametrize(
    ("firmware", "peer", "passed", "words"),
    [
        ("pass", 0, True, "both passed"),
        ("pass", 6, False, "the peer failed (exit 6), though the firmware passed its own checks"),
        ("pass", None, False, "the peer did not finish in time"),
        ("samples lost", 0, False, "samples lost; the peer passed"),
        ("timeout: the firmware did not finish", None, False, "did not finish; the peer did not finish"),
        # issue 43, item 1: the firmware exited 0, but a stage the host judges failed
        ("stage time failed: +2.001 s off", 0, False, "stage time failed: +2.001 s off; the peer passed"),
    ],
)
def test_the_verdict_needs_the_firmware_s_judged_verdict_and_the_peer(
    firmware: str, peer: int | None, passed: bool, words: str
) -> None:
    judged = peer_verdict(firmware == "pass", firmware, peer)
    assert judged.passed is passed
    assert words in judged.text


def _fake_pip(venv_root: Path, fail: bool = False) -> FakeRunner:
    def python(argv: Sequence[str]) -> str:
        if argv[1:3] == ["-m", "venv"]:
            Path(argv[3], "bin").mkdir(parents=True, exist_ok=True)
            return ""
        if "pip" in argv:
            if fail:
                raise StepFailed(
                    "pip failed", cause="ERROR: Could not find a version that satisfies ros-rclpy"
                )
            venv = Path(argv[0]).parents[1]
            (venv / "share" / "std_msgs" / "cmake").mkdir(parents=True)
            (venv / "share" / "std_msgs" / "cmake" / "gen_pyExport.cmake").write_text(
                WHEEL_CMAKE, encoding="utf-8"
            )
            return ""
        return "/usr/include/python3.11\n/venv/numpy/_core/include\n"

    return FakeRunner(venv_root / "log.txt", {Path(sys.executable).name: python, "python3": python})


def test_the_venv_is_made_once_and_its_cmake_mended(tmp_path: Path) -> None:
    spec = peerenv.PeerEnvSpec("kilted", ("ros-rclpy==9.1.2",))
    runner = _fake_pip(tmp_path)
    venv = peerenv.ensure_venv(runner, spec, tmp_path)  # type: ignore[arg-type]
    assert (venv / peerenv.READY).is_file() and not (venv / peerenv.PARTIAL).exists()
    text = (venv / "share/std_msgs/cmake/gen_pyExport.cmake").read_text(encoding="utf-8")
    assert "/opt/python" not in text and "/usr/include/python3.11" in text
    calls = len(runner.calls)
    assert peerenv.ensure_venv(runner, spec, tmp_path) == venv  # type: ignore[arg-type]
    assert len(runner.calls) == calls  # made before: nothing runs


def test_an_offline_pip_is_one_line_naming_what_to_do(tmp_path: Path) -> None:
    spec = peerenv.PeerEnvSpec("kilted", ("ros-rclpy==9.1.2",))
    with pytest.raises(StepFailed, match=r"pip could not install ros-rclpy==9\.1\.2") as caught:
        peerenv.ensure_venv(_fake_pip(tmp_path, fail=True), spec, tmp_path)  # type: ignore[arg-type]
    assert "UROS_ROS2_VENV" in str(caught.value.hint) and "PyPI" in str(caught.value.hint)
    # the unfinished folder is uros's: the next run clears it and starts again
    venv = peerenv.venv_path(tmp_path, spec, peerenv.python_version())
    assert (venv / peerenv.PARTIAL).is_file()
    assert peerenv.ensure_venv(_fake_pip(tmp_path), spec, tmp_path) == venv  # type: ignore[arg-type]


def test_a_folder_uros_did_not_make_is_left_alone(tmp_path: Path) -> None:
    spec = peerenv.PeerEnvSpec("kilted", ("ros-rclpy==9.1.2",))
    venv = peerenv.venv_path(tmp_path, spec, peerenv.python_version())
    venv.mkdir(parents=True)
    (venv / "mine.txt").write_text("keep\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="uros did not make it"):
        peerenv.ensure_venv(_fake_pip(tmp_path), spec, tmp_path)  # type: ignore[arg-type]
    assert (venv / "mine.txt").is_file()


def test_each_interface_package_is_built_once_and_again_only_when_it_or_a_dependency_changed(
    tmp_path: Path,
) -> None:
    def package(name: str, deps: Sequence[str], text: str) -> PackageInfo:
        folder = tmp_path / "src" / name
        (folder / "msg").mkdir(parents=True, exist_ok=True)
        (folder / "msg" / "M.msg").write_text(text, encoding="utf-8")
        return PackageInfo(name, "ament_cmake", frozenset(deps), folder)

    def cmake(argv: Sequence[str]) -> str:
        if "-B" in argv:
            Path(argv[argv.index("-B") + 1]).mkdir(parents=True)
        return ""

    runner = FakeRunner(tmp_path / "log.txt", {"cmake": cmake})
    root, venv = tmp_path / "cache", tmp_path / "venv"

    def built(*packages: PackageInfo) -> list[str]:
        before = len(runner.calls)
        peerenv.build_interfaces(runner, venv, list(packages), root)  # type: ignore[arg-type]
        return [Path(c[c.index("-S") + 1]).name for c in runner.calls[before:] if "-S" in c]

    base, robot = package("base_msgs", [], "int32 a\n"), package("robot_msgs", ["base_msgs"], "int32 b\n")
    assert built(base, robot) == ["base_msgs", "robot_msgs"]
    assert built(base, robot) == []  # both built before
    assert built(base, package("robot_msgs", ["base_msgs"], "int16 b\n")) == ["robot_msgs"]
    assert built(package("base_msgs", [], "int16 a\n"), robot) == ["base_msgs", "robot_msgs"]
    configure = next(c for c in runner.calls if "-S" in c and c[c.index("-S") + 1].endswith("robot_msgs"))
    assert any(a.startswith("-DCMAKE_PREFIX_PATH=") and "base_msgs-venv-" in a for a in configure)
