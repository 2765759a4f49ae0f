"""micro-ROS Jazzy from a mirror that lacks some of its jazzy branches (issue 33 item 5).

The first test runs everywhere (CI): a fake mirror shaped like the local one, every repository a
real git repository with the refs the local mirror has. The others build the real sources. The jazzy manifest names the real jazzy branches; the distro declares stand-ins for the ones such a
mirror lacks (meta/distros/jazzy/distro.yaml stand_ins:), used only on request (`create-firmware
--stand-ins`), each printed with its reason and recorded in uros.yaml and uros.lock. Runs when
UROS_MIRROR names a folder of clones laid out as <owner>+<repo>/repo; skipped otherwise (CI has no
mirror). The probe in QEMU runs when UROS_AGENT names a MicroXRCEAgent too. About 10 minutes on 2
cores (docs/jazzy.md).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from uros_helpers import REPO, build_firmware_project, git_commit, git_out, run_uros

from uros_build.sources import distros

pytestmark = [pytest.mark.integration, pytest.mark.realsources]

MIRROR = os.environ.get("UROS_MIRROR")
AGENT = os.environ.get("UROS_AGENT")
_NEEDS_MIRROR = pytest.mark.skipif(
    not MIRROR, reason="set UROS_MIRROR to a folder of upstream clones (<owner>+<repo>/repo)"
)
EXAMPLE = REPO / "examples" / "cmake-firmware"
STAND_INS = {
    "dev_ws/ament/googletest": "ros2",
    "mcu_ws/ros2/rcl": "9.2.0",
    "mcu_ws/ros2/rosidl_core": "0.2.0",
    "mcu_ws/ros2/rosidl_dynamic_typesupport": "0.1.2",
    "mcu_ws/uros/rclc": "6.1.0",
    "mcu_ws/uros/rosidl_typesupport": "fictionlab/rosidl_typesupport@jazzy",
    "mcu_ws/uros/micro_ros_msgs": "rolling",
    "mcu_ws/uros/micro_ros_utilities": "rolling",
    "mcu_ws/uros/rmw_microxrcedds": "rolling",
    "mcu_ws/uros/rosidl_typesupport_microxrcedds": "rolling",
}


def _fake_mirror(root: Path) -> dict[str, str]:
    """<root>/<owner>+<repo>: the jazzy repositories as the local mirror holds them: a jazzy branch,
    except for the ten that lack one, which hold only what stands in (a tag, rolling, ros2, and the
    fictionlab fork's jazzy). Returns workspace path -> the commit its stand-in names."""
    jazzy = distros.load_distro("jazzy")
    declared = {o.key: o for o in jazzy.stand_ins}
    wanted = {}
    for ws, repos in (("dev_ws", jazzy.dev), ("mcu_ws", jazzy.mcu)):
        for repo in repos:
            key = distros.owner_repo(repo.url)
            assert key
            stand_in = declared.get(repo.path) or declared.get(key)
            path = root / key.replace("/", "+")
            if stand_in is not None and stand_in.url:  # a fork stands in: the upstream holds only foxy
                path.mkdir(parents=True)
                git_out("init", "-q", "-b", "foxy", cwd=path)
                git_commit(path, "foxy")
                path = root / (distros.owner_repo(stand_in.url) or "").replace("/", "+")
            path.mkdir(parents=True)
            ref = stand_in.version if stand_in and stand_in.version else repo.version
            is_tag = ref[0].isdigit()
            git_out("init", "-q", "-b", "main" if is_tag else ref, cwd=path)
            (path / "README").write_text(f"fake {key}\n")
            head = git_commit(path, "initial")
            if is_tag:
                git_out("tag", ref, cwd=path)
            if stand_in is not None:
                wanted[f"{ws}/{repo.path}"] = head
    return wanted


def test_stand_ins_are_declared_printed_and_recorded(tmp_path: Path) -> None:
    """Without --stand-ins the clone of a missing branch fails and names the flag; with it, every
    declared stand-in is cloned, printed with its reason and recorded (uros.lock, uros.yaml)."""
    mirror = tmp_path / "mirror"
    wanted = _fake_mirror(mirror)
    assert len(wanted) == len(STAND_INS)
    fw = tmp_path / "fw"
    base = ["create-firmware", "--distro", "jazzy", "-w", str(fw), "--no-dev-build",
            "--mirror", f"https://github.com/{{owner}}/{{repo}}={mirror}/{{owner}}+{{repo}}"]  # fmt: skip
    failed = run_uros(*base, check=False)
    said = " ".join(failed.stderr.split())
    assert failed.returncode == 4 and "at 'jazzy' failed" in said
    assert "pass --stand-ins: the jazzy manifest declares" in said and not fw.exists()
    assert "jazzy was built here with 10 stand-ins for branches the mirror lacked" in said

    done = run_uros(*base, "--stand-ins")
    said = " ".join(done.stderr.split())
    assert "10 of 34 repositories from stand-ins (not the manifest's):" in said
    for path, version in STAND_INS.items():
        assert f"stand-in {path}: {version.split('@')[-1]} from " in said, path
    assert "instead of jazzy (no jazzy branch in the mirror; tag 9.2.0 (c19dab5, 2024-03-28)" in said
    lock = json.loads((fw / "uros.lock").read_text())["repositories"]
    assert {p: r["commit"] for p, r in lock.items() if "stand_in" in r} == wanted
    assert {p: r["stand_in"]["use"] for p, r in lock.items() if "stand_in" in r} == STAND_INS
    assert lock["mcu_ws/uros/rosidl_typesupport"]["source"] == f"{mirror}/fictionlab+rosidl_typesupport"
    assert lock["mcu_ws/ros2/rmw"]["version"] == "jazzy" and "stand_in" not in lock["mcu_ws/ros2/rmw"]
    assert git_out("rev-parse", "HEAD", cwd=fw / "mcu_ws/uros/rclc") == wanted["mcu_ws/uros/rclc"]
    assert "why: no jazzy branch in the mirror; tag 9.2.0" in " ".join((fw / "uros.yaml").read_text().split())

    # `uros update` keeps them (uros.yaml), and says so again
    moved = run_uros("update", "-w", str(fw), "--dry-run")
    assert "10 of 34 repositories from stand-ins" in " ".join(moved.stderr.split())


def _nm_defined(path: Path) -> set[str]:
    out = subprocess.run(
        ["arm-none-eabi-nm", "-g", "--defined-only", str(path)],
        check=True, capture_output=True, text=True, env={**os.environ, "LC_ALL": "C"},
    ).stdout  # fmt: skip
    return {line.split()[-1] for line in out.splitlines() if len(line.split()) == 3}


@pytest.fixture(scope="module")
def jazzy(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A jazzy workspace made with the declared stand-ins, built for cortex-m7 (std_msgs and the
    core: what examples/cmake-firmware and the probe firmware use); (workspace, create's stderr)."""
    assert MIRROR
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("arm-none-eabi-gcc is not installed")
    fw = tmp_path_factory.mktemp("jazzy") / "fw"
    created = run_uros(
        "create-firmware", "generate_lib", "--distro", "jazzy", "--workspace", str(fw), "--stand-ins",
        "--mirror", f"https://github.com/{{owner}}/{{repo}}={MIRROR}/{{owner}}+{{repo}}/repo",
    )  # fmt: skip
    run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw), "--packages", "std_msgs", "-j", "2")
    return fw, created.stderr


@_NEEDS_MIRROR
def test_every_stand_in_is_printed_and_recorded(jazzy: tuple[Path, str]) -> None:
    fw, said = jazzy
    said = " ".join(said.split())  # the console wraps long lines
    assert f"{len(STAND_INS)} of 34 repositories from stand-ins" in said
    for path, version in STAND_INS.items():
        assert f"stand-in {path}: {version.split('@')[-1]} from " in said, path
    assert "instead of jazzy (no jazzy branch in the mirror" in said
    lock = json.loads((fw / "uros.lock").read_text())["repositories"]
    assert {p: r["stand_in"]["use"] for p, r in lock.items() if "stand_in" in r} == STAND_INS
    assert all(r["version"] == "jazzy" for p, r in lock.items() if p in STAND_INS and "googletest" not in p)
    assert lock["mcu_ws/ros2/rmw"]["version"] == "jazzy" and "stand_in" not in lock["mcu_ws/ros2/rmw"]
    assert "fictionlab+rosidl_typesupport" in lock["mcu_ws/uros/rosidl_typesupport"]["source"]
    cfg = (fw / "uros.yaml").read_text()
    assert "why: no jazzy branch in the mirror; tag 9.2.0" in " ".join(cfg.split())


@_NEEDS_MIRROR
def test_the_library_by_its_bytes_and_the_example_links(jazzy: tuple[Path, str], tmp_path: Path) -> None:
    fw, _ = jazzy
    out = fw / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text())
    assert {"rcl", "rclc", "rmw_microxrcedds", "microxrcedds_client", "microcdr", "std_msgs"} <= set(
        info["packages"]
    )
    # the library says which of its packages came from a stand-in (build-info.json, uros info)
    assert info["sources"]["rclc"]["stand_in"] == "6.1.0"
    assert info["sources"]["rmw_microxrcedds"]["stand_in"] == "rolling"
    assert info["sources"]["rosidl_typesupport_c"]["stand_in"] == "fictionlab/rosidl_typesupport@jazzy"
    assert "stand_in" not in info["sources"]["rmw"]
    shown = run_uros("info", str(out)).stdout
    assert "(stand-in: 6.1.0, not the manifest's branch)" in shown
    symbols = _nm_defined(out / "libmicroros.a")
    for name in (
        "rcl_init",
        "rcl_publish",
        "rclc_support_init",
        "rclc_executor_spin_some",
        "rmw_create_publisher",
        "rmw_uros_set_custom_transport",
        "uxr_create_session",
        "ucdr_serialize_int32_t",
        "rosidl_typesupport_c__get_message_type_support_handle__std_msgs__msg__Int32",
    ):
        assert name in symbols, name
    # jazzy's rcl (micro-ROS/rcl jazzy): type descriptions came with iron, dynamic type support with jazzy
    assert "rcl_node_type_description_service_init" in symbols
    for header in ("rcl/rcl.h", "rclc/rclc.h", "rmw_microros/rmw_microros.h", "std_msgs/msg/int32.h"):
        assert (out / "include" / header).is_file(), header
    elf = build_firmware_project(EXAMPLE, out, tmp_path / "fw-build")
    attrs = subprocess.run(["readelf", "-A", str(elf)], check=True, capture_output=True, text=True).stdout
    assert "Tag_ABI_VFP_args: VFP registers" in attrs
    linked = _nm_defined(elf)
    assert "rclc_publisher_init_default" in linked and "uxr_create_session" in linked


@_NEEDS_MIRROR
@pytest.mark.skipif(
    not (AGENT and shutil.which("qemu-system-arm")),
    reason="set UROS_AGENT (a MicroXRCEAgent) and install qemu-system-arm",
)
def test_the_library_runs_against_the_agent(jazzy: tuple[Path, str]) -> None:
    fw, _ = jazzy
    assert AGENT
    proc = run_uros(
        "probe", "--json", "--toolchain", "cortex-m7", "-w", str(fw), "--agent", AGENT, check=False
    )
    data = json.loads(proc.stdout) if proc.stdout.strip() else None
    assert proc.returncode == 0, proc.stderr
    assert data is not None and data["status"] == 0
    assert "uros-probe: PASS" in Path(str(data["console_log"])).read_text()
