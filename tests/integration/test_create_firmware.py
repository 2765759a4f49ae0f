"""`uros create-firmware` on real git repositories served from file paths (as west's tests do):
a fake upstream for every repository of the humble manifest, reached through --mirror."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml
from uros_helpers import git_commit, git_out, need, run_uros, run_uros_here, upstream_mirror

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def _interface_made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The interface package `uros interface new` makes, once for this module."""
    folder = tmp_path_factory.mktemp("interface")
    msg = folder / "CmdVel.msg"
    msg.write_text("int32 left_rpm\nint32 right_rpm\n")
    srv = folder / "GetTime.srv"
    srv.write_text("int64 time_ms_req\n---\nint64 time_ms_res\n")
    out = folder / "eic_demo_interface"
    run_uros(
        "interface", "new", "eic_demo_interface", "--msg", str(msg), "--srv", str(srv), "--output", str(out)
    )
    return out


@pytest.fixture
def interface_pkg(_interface_made: Path, tmp_path: Path) -> Path:
    """A copy of that package of this test's own (tests edit it): tmp_path/eic_demo_interface."""
    return Path(shutil.copytree(_interface_made, tmp_path / "eic_demo_interface"))


def test_create_lock_force_and_locked(upstream: Path, tmp_path: Path, interface_pkg: Path) -> None:
    pkg = interface_pkg
    fw = tmp_path / "firmware"
    base = [
        "create-firmware",
        "generate_lib",
        "--distro",
        "humble",
        "--workspace",
        str(fw),
        "--no-dev-build",
        *upstream_mirror(upstream),
    ]
    run_uros(*base, "--extra-package", str(pkg))

    lock = json.loads((fw / "uros.lock").read_text())
    assert lock["distro"] == "humble" and len(lock["repositories"]) == 32
    rcl = lock["repositories"]["mcu_ws/uros/rcl"]
    assert rcl["url"] == "https://github.com/micro-ROS/rcl" and len(rcl["commit"]) == 40
    assert (fw / "mcu_ws/uros/rclc/README").is_file() and (fw / "dev_ws/ament/ament_cmake/README").is_file()
    assert (fw / "mcu_ws/extra_packages/eic_demo_interface/msg/CmdVel.msg").is_file()
    cfg = yaml.safe_load((fw / "uros.yaml").read_text())
    assert cfg["distro"] == "humble" and cfg["extra_packages"] == [str(pkg)]
    meta = json.loads((fw / "colcon.meta").read_text())
    assert "-DRCL_LOGGING_ENABLED=OFF" in meta["names"]["rcl"]["cmake-args"]

    # an existing workspace is an error naming --force; nothing changes
    (fw / "colcon.meta").write_text('{"names": {"rcl": {"cmake-args": ["-DMINE=1"]}}}\n')
    proc = run_uros_here(*base, check=False)  # refused before any process starts
    assert proc.returncode == 2 and "--force" in proc.stderr

    # upstream moves on; --force re-creates at the new commit and keeps the user's meta and extras
    new_head = git_commit(upstream / "micro-ROS+rcl", "moved on")
    run_uros(*base, "--force")
    assert json.loads((fw / "uros.lock").read_text())["repositories"]["mcu_ws/uros/rcl"]["commit"] == new_head
    assert "-DMINE=1" in (fw / "colcon.meta").read_text()
    assert (fw / "mcu_ws/extra_packages/eic_demo_interface/package.xml").is_file()

    # --lock-file re-creates exactly the commits of the first lock
    old_lock = tmp_path / "old.lock"
    old_lock.write_text(json.dumps(lock))
    run_uros(*base, "--force", "--lock-file", str(old_lock))
    head = git_out("rev-parse", "HEAD", cwd=fw / "mcu_ws/uros/rcl")
    assert head == rcl["commit"] != new_head


def test_missing_branch_names_repo_and_cleans_up(upstream_to_read: Path, tmp_path: Path) -> None:
    fw = tmp_path / "fw"
    args = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream_to_read)]
    args += ["--mirror-override", "uros/rclc=@no-such-branch"]
    proc = run_uros(*args, check=False)
    assert proc.returncode == 4, proc.stderr
    line = next(x for x in proc.stderr.splitlines() if x.startswith("error:"))
    assert "mcu_ws/uros/rclc" in line and "no-such-branch" in line
    assert "--mirror-override uros/rclc=" in proc.stderr
    assert not fw.exists()  # no half-created workspace
    proc = run_uros(*args, "--keep-partial", check=False)
    assert proc.returncode == 4 and fw.is_dir()


def test_a_source_git_cannot_read_says_so_not_a_missing_branch(
    upstream_to_read: Path, tmp_path: Path
) -> None:
    """git's failure is classified once (sources/clones.py): a folder that is no repository is a
    source that cannot be reached, so the hint does not send the user looking for a branch."""
    empty = tmp_path / "not-a-repo"
    empty.mkdir()
    fw = tmp_path / "fw"
    args = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream_to_read)]
    proc = run_uros(*args, "--mirror-override", f"uros/rclc={empty}@humble", check=False)
    assert proc.returncode == 4, proc.stderr
    line = next(x for x in proc.stderr.splitlines() if x.startswith("error:"))
    assert f"cloning mcu_ws/uros/rclc from {empty} at 'humble' failed: " in line, line
    assert f"fatal: repository '{empty}' does not exist" in line, line
    assert (
        f"hint: check that {empty} can be reached, or override it: --mirror-override uros/rclc="
        in proc.stderr
    )
    assert "check that the source has" not in proc.stderr and not fw.exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--distro", "ardent"], "unknown distro 'ardent'"),
        (["--mirror", "https://github.com/{owner}/{repo}=/nonexistent/{owner}+{repo}"], "/nonexistent/"),
        (["--extra-package", "/"], "no package.xml"),
        (["--mirror", "nonsense"], "expected UPSTREAM=LOCAL"),
    ],
)
def test_bad_input(tmp_path: Path, args: list[str], expected: str) -> None:
    fw = tmp_path / "fw"
    proc = run_uros_here("create-firmware", "--workspace", str(fw), "--no-dev-build", *args, check=False)
    assert proc.returncode == 2, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and expected in errors[0]
    assert not fw.exists()


def test_add_package_keeps_in_sync(created: Path, tmp_path: Path, interface_pkg: Path) -> None:
    fw = created  # create-firmware's workspace, made once per worker (conftest): a copy
    pkg = interface_pkg
    run_uros("add-package", str(pkg), "--workspace", str(fw))
    copy = fw / "mcu_ws/extra_packages/eic_demo_interface"
    assert (copy / "srv/GetTime.srv").is_file()
    (pkg / "msg/CmdVel.msg").write_text("int32 left_rpm\nint32 right_rpm\nint32 lift\n")
    from uros_build.sources.workspace import Workspace

    ws, cfg = Workspace.open_firmware(fw)
    ws.sync_extra_packages(cfg)  # what `uros build` does first
    assert "lift" in (copy / "msg/CmdVel.msg").read_text()
    proc = run_uros_here("add-package", str(tmp_path), "--workspace", str(fw), check=False)  # refused
    assert proc.returncode == 2 and "no package.xml" in proc.stderr


def test_add_package_keeps_comments_and_refuses_duplicates(
    created: Path, tmp_path: Path, interface_pkg: Path
) -> None:
    """Issue 16, item 8: add-package rewrote uros.yaml (the user's comments gone) and took a second
    folder with a package name the workspace already had (colcon: duplicate package names)."""
    fw = created  # create-firmware's workspace, made once per worker (conftest): a copy
    config = fw / "uros.yaml"
    config.write_text("# our board: keep this note\n" + config.read_text() + "target: cortex-m7  # the H7\n")
    pkg = interface_pkg
    run_uros("add-package", str(pkg), "--workspace", str(fw))
    text = config.read_text()
    assert text.startswith("# our board: keep this note\n") and "target: cortex-m7  # the H7" in text
    assert yaml.safe_load(text)["extra_packages"] == [str(pkg)]
    again = run_uros("add-package", str(pkg), "--workspace", str(fw))  # the same folder: a sync
    assert "already in uros.yaml" in again.stderr and config.read_text() == text
    twin = tmp_path / "elsewhere" / "eic_demo_interface"
    shutil.copytree(pkg, twin)
    proc = run_uros_here("add-package", str(twin), "--workspace", str(fw), check=False)  # refused
    assert proc.returncode == 2, proc.stderr
    assert "the workspace already has a package named eic_demo_interface" in proc.stderr
    assert config.read_text() == text
    # a package the distro's clones already hold
    rclc = tmp_path / "my_rclc"
    rclc.mkdir()
    (rclc / "package.xml").write_text(_pkg_xml("rclc"))
    (fw / "mcu_ws/uros/rclc/package.xml").write_text(_pkg_xml("rclc"))
    proc = run_uros_here("add-package", str(rclc), "--workspace", str(fw), check=False)  # refused
    assert proc.returncode == 2 and "already has a package named rclc (" in proc.stderr
    assert config.read_text() == text and not (fw / "mcu_ws/extra_packages/rclc").exists()


def _pkg_xml(name: str) -> str:
    return (
        f'<?xml version="1.0"?>\n<package format="3"><name>{name}</name><version>0.0.0</version>'
        "<description>d</description><maintainer email='a@b.c'>a</maintainer><license>MIT</license>"
        "<buildtool_depend>ament_cmake</buildtool_depend><export><build_type>ament_cmake</build_type></export>"
        "</package>\n"
    )


def test_target_prerequisites_are_checked_before_cloning(upstream_to_read: Path, tmp_path: Path) -> None:
    fw = tmp_path / "fw"
    # esp32s3's compiler is not packaged: exit 3 with the install hint, nothing cloned or left behind
    # (refused before any process starts: in process)
    env: dict[str, str | None] = {"IDF_PATH": None, "IDF_TOOLS_PATH": str(tmp_path / "no-idf")}
    proc = run_uros_here(
        "create-firmware",
        "--workspace",
        str(fw),
        "--no-dev-build",
        "--toolchain",
        "esp32s3",
        *upstream_mirror(upstream_to_read),
        check=False,
        env=env,
    )
    assert proc.returncode == 3, proc.stderr
    assert "xtensa-esp32s3-elf-gcc" in proc.stderr and "cloning" not in proc.stderr
    assert not fw.exists()
    # cortex-m7's compiler, newlib and C++ headers are installed here (.ci/run installs them)
    run_uros(
        "create-firmware",
        "--workspace",
        str(fw),
        "--no-dev-build",
        "--toolchain",
        "cortex-m7",
        *upstream_mirror(upstream_to_read),
    )
    assert (fw / "uros.lock").is_file()


@pytest.mark.colcon
def test_firmware_workspace_builds_end_to_end(upstream_to_read: Path, tmp_path: Path) -> None:
    """create-firmware + uros build through the firmware-workspace path (dev_ws, workspace meta,
    extra packages) with the real colcon and arm-none-eabi-gcc; the upstreams hold fixture packages."""
    from fixture_ws import make_fixture_workspace

    need("arm-none-eabi-gcc")
    # A host tool in the dev workspace: an MCU package finds it through dev_ws/install.
    host = tmp_path / "up" / "ament+ament_cmake"
    shutil.copytree(upstream_to_read / "ament+ament_cmake", host)
    (host / "host_tool").mkdir()
    (host / "host_tool/package.xml").write_text(
        "<package format='3'><name>host_tool</name><version>0.1.0</version><description>d</description>"
        "<maintainer email='m@example.com'>m</maintainer><license>MIT</license>"
        "<export><build_type>cmake</build_type></export></package>\n"
    )
    (host / "host_tool/CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(host_tool NONE)\n"
        'file(WRITE ${CMAKE_BINARY_DIR}/host_toolConfig.cmake "set(HOST_TOOL_FOUND TRUE)\\n")\n'
        "install(FILES ${CMAKE_BINARY_DIR}/host_toolConfig.cmake DESTINATION share/host_tool/cmake)\n"
    )
    # A host tool nothing in mcu_ws depends on (as uncrustify and the linters): never built.
    (host / "linter_tool").mkdir()
    (host / "linter_tool/package.xml").write_text(
        (host / "host_tool/package.xml").read_text().replace("host_tool", "linter_tool")
    )
    (host / "linter_tool/CMakeLists.txt").write_text(
        'cmake_minimum_required(VERSION 3.16)\nproject(linter_tool NONE)\nmessage(FATAL_ERROR "not needed")\n'
    )
    # ... even when a needed host tool names it as a test dependency (colcon's --packages-up-to
    # would build it: it takes test dependencies too)
    xml = host / "host_tool/package.xml"
    xml.write_text(xml.read_text().replace("<export>", "<test_depend>linter_tool</test_depend><export>"))
    git_commit(host, "host tool")
    # The MCU sources: the fixture packages inside the micro-ROS rclc repository.
    mcu = tmp_path / "up" / "ros2+rclc"
    shutil.copytree(upstream_to_read / "ros2+rclc", mcu)
    fixture = make_fixture_workspace(tmp_path / "fixture")
    for pkg in (fixture / "mcu_ws" / "src").iterdir():
        if pkg.name != "fx_skip_cpp":
            shutil.copytree(pkg, mcu / pkg.name)
    git_commit(mcu, "fixture packages")
    # An extra package that needs the host tool at configure time.
    extra = tmp_path / "fx_extra"
    (extra / "src").mkdir(parents=True)
    (extra / "package.xml").write_text(
        "<package format='3'><name>fx_extra</name><version>0.1.0</version><description>d</description>"
        "<maintainer email='m@example.com'>m</maintainer><license>MIT</license>"
        "<buildtool_depend>host_tool</buildtool_depend>"
        "<export><build_type>cmake</build_type></export></package>\n"
    )
    (extra / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(fx_extra C)\nfind_package(host_tool REQUIRED)\n"
        "add_library(fx_extra STATIC src/extra.c)\ninstall(TARGETS fx_extra ARCHIVE DESTINATION lib)\n"
    )
    (extra / "src/extra.c").write_text("int fx_extra_v1(void) { return 1; }\n")

    fw = tmp_path / "firmware"
    run_uros(
        "create-firmware",
        "--workspace",
        str(fw),
        "--toolchain",
        "cortex-m7",
        "--extra-package",
        str(extra),
        *upstream_mirror(upstream_to_read),
        "--mirror-override",
        f"ament/ament_cmake={host}",
        "--mirror-override",
        f"uros/rclc={mcu}",
    )
    assert (fw / "dev_ws/install/share/host_tool/cmake/host_toolConfig.cmake").is_file()  # dev_ws built once
    # only what the MCU packages need (fx_extra's buildtool_depend): not linter_tool
    dev_built = json.loads((fw / "dev_ws/install/.uros-dev-packages.json").read_text())
    assert dev_built["built"] == ["host_tool"] and "linter_tool" in dev_built["available"]
    # the workspace's colcon.meta is layered into every build: fx_time needs this option
    meta = json.loads((fw / "colcon.meta").read_text())
    meta["names"]["fx_time"] = {"cmake-args": ["-DFX_TIME_ENABLE=ON"]}
    (fw / "colcon.meta").write_text(json.dumps(meta))

    run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(fw))
    out = fw / "build" / "cortex-m7"
    info = json.loads((out / "build-info.json").read_text())
    assert "fx_extra" in info["packages"] and "fx_time" in info["packages"]
    assert info["transport"] == "custom"

    def symbols() -> str:
        return subprocess.run(
            ["arm-none-eabi-nm", str(out / "libmicroros.a")], capture_output=True, text=True, check=True
        ).stdout

    assert " T fx_extra_v1" in symbols()
    # editing the extra package's source folder reaches the next build; run from inside the
    # workspace with no options: the workspace is the nearest uros.yaml upward, the target the one
    # create-firmware --toolchain wrote there, and its transport and set apply
    (extra / "src/extra.c").write_text("int fx_extra_v2(void) { return 2; }\n")
    cfg = yaml.safe_load((fw / "uros.yaml").read_text())
    assert cfg["target"] == "cortex-m7"
    cfg.update({"transport": "udp", "set": ["fx_core.FX_CORE_LEVEL=3"]})
    (fw / "uros.yaml").write_text(yaml.safe_dump(cfg))
    run_uros("build", cwd=fw / "mcu_ws")
    assert " T fx_extra_v2" in symbols() and "fx_extra_v1" not in symbols()
    assert json.loads((out / "build-info.json").read_text())["transport"] == "udp"
    cache = fw / ".uros/targets/cortex-m7/build/fx_core/CMakeCache.txt"
    assert "FX_CORE_LEVEL:UNINITIALIZED=3" in cache.read_text()
    # uros info: the packages with the commits of the repositories they came from
    info = json.loads(run_uros("info", "--json", cwd=fw).stdout)
    lock = json.loads((fw / "uros.lock").read_text())["repositories"]
    rows = {p["name"]: p for p in info["packages"]}
    assert rows["fx_core"]["repository"] == "mcu_ws/uros/rclc"
    assert rows["fx_core"]["commit"] == lock["mcu_ws/uros/rclc"]["commit"]
    assert rows["fx_extra"]["commit"] is None  # an extra package: no lock entry
    # a key uros does not know is an error naming file and line, before anything runs
    (fw / "uros.yaml").write_text(yaml.safe_dump(cfg) + "tragets: [rp2040]\n")
    proc = run_uros_here("build", cwd=fw, check=False)  # refused before any process starts
    lines = len(yaml.safe_dump(cfg).splitlines())
    assert proc.returncode == 2 and f"uros.yaml:{lines + 1}: tragets: unknown key" in proc.stderr, proc.stderr


def test_add_package_from_a_git_url(created: Path, tmp_path: Path, interface_pkg: Path) -> None:
    fw = created  # create-firmware's workspace, made once per worker (conftest): a copy
    repo = tmp_path / "my_msgs_repo"
    shutil.copytree(interface_pkg, repo / "eic_demo_interface")
    git_out("init", "-q", "-b", "main", cwd=repo)
    git_commit(repo, "interfaces")
    run_uros("add-package", f"file://{repo}", "--version", "main", "--workspace", str(fw))
    assert (fw / "mcu_ws/extra_packages/my_msgs_repo/eic_demo_interface/package.xml").is_file()
    # a repository without any package.xml is refused and not left behind
    empty = tmp_path / "empty_repo"
    empty.mkdir()
    git_out("init", "-q", "-b", "main", cwd=empty)
    git_commit(empty, "nothing")
    proc = run_uros("add-package", f"file://{empty}", "--workspace", str(fw), check=False)
    assert proc.returncode == 2 and "holds no package.xml" in proc.stderr
    assert not (fw / "mcu_ws/extra_packages/empty_repo").exists()


def test_distros_and_interface_checks_through_the_cli(tmp_path: Path) -> None:
    rows = json.loads(run_uros("distros", "--json").stdout)
    assert {r["name"]: r["status"] for r in rows}["humble"] == "built-here"
    bad = tmp_path / "Wheel.msg"
    bad.write_text("int32 rpm 3.5\n")
    proc = run_uros_here(  # refused before any process starts: in process
        "interface", "new", "my_msgs", "--msg", str(bad), "--output", str(tmp_path / "my_msgs"), check=False
    )
    assert proc.returncode == 2
    assert f"error: {bad}:1: default value '3.5' is not an integer for type int32" in proc.stderr
    assert not (tmp_path / "my_msgs").exists()


@pytest.mark.colcon
def test_clone_error_is_in_english_in_a_spanish_locale(
    upstream_to_read: Path, tmp_path: Path, spanish_env: dict[str, str]
) -> None:
    """git speaks Spanish there ("Rama remota ... no encontrada"); uros's error line quotes git, so
    the tools it runs print their messages in English (LC_MESSAGES=C)."""
    fw = tmp_path / "fw"
    args = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream_to_read)]
    proc = run_uros(*args, "--mirror-override", "uros/rclc=@no-such-branch", check=False, env=spanish_env)
    assert proc.returncode == 4, proc.stderr
    line = next(x for x in proc.stderr.splitlines() if x.startswith("error:"))
    assert "Remote branch no-such-branch not found" in line, line


def _pkg(folder: Path, name: str) -> None:
    folder.mkdir(parents=True)
    (folder / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>\n")


def _tree(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` but uros's run logs."""
    files = (p for p in sorted(root.rglob("*")) if p.is_file() and ".uros" not in p.parts)
    return {str(p.relative_to(root)): p.read_bytes() for p in files}


def test_force_replaces_only_what_uros_cloned(upstream: Path, tmp_path: Path) -> None:
    """Issue 8 item 3: --force deleted the user's own mcu_ws packages. Only the repositories
    uros.lock lists are re-cloned; the user's packages, next to them or inside their folders, stay."""
    fw = tmp_path / "firmware"
    base = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream)]
    run_uros(*base)
    mine = {
        "mcu_ws/my_board": "my_board",  # beside the clones
        "mcu_ws/uros/my_driver": "my_driver",  # inside a folder that holds clones
        "dev_ws/my_tool": "my_tool",
    }
    for rel, name in mine.items():
        _pkg(fw / rel, name)
    (fw / "mcu_ws/notes.txt").write_text("keep me\n")
    (fw / "mcu_ws/uros/rclc/HISTORY").unlink()  # a clone with a deleted file: the user's edit
    proc = run_uros(*base, "--force", check=False)
    assert proc.returncode == 2 and "mcu_ws/uros/rclc has 1 changed file(s)" in proc.stderr
    assert (fw / "mcu_ws/uros/rcl/README").is_file()  # refused before anything was removed
    git_out("checkout", "--", "HISTORY", cwd=fw / "mcu_ws/uros/rclc")
    new_head = git_commit(upstream / "micro-ROS+rcl", "moved on again")
    run_uros(*base, "--force")
    for rel, name in mine.items():
        assert name in (fw / rel / "package.xml").read_text(), rel
    assert (fw / "mcu_ws/notes.txt").read_text() == "keep me\n"
    assert git_out("rev-parse", "HEAD", cwd=fw / "mcu_ws/uros/rcl") == new_head
    assert json.loads((fw / "uros.lock").read_text())["repositories"]["mcu_ws/uros/rcl"]["commit"] == new_head
    # a --force that fails half-way removes what it cloned, and only that
    proc = run_uros(*base, "--force", "--mirror-override", "uros/rclc=@no-such-branch", check=False)
    assert proc.returncode == 4, proc.stderr
    for rel, name in mine.items():
        assert name in (fw / rel / "package.xml").read_text(), rel
    assert (fw / "mcu_ws/notes.txt").is_file() and not (fw / "mcu_ws/uros/rcl").exists()


def test_force_keeps_a_clone_with_local_commits(upstream_to_read: Path, created: Path) -> None:
    fw = created  # the workspace `base` creates, made once per worker (conftest): a copy
    base = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream_to_read)]
    mine = git_commit(fw / "mcu_ws/uros/rclc", "my fix")
    before = _tree(fw)
    proc = run_uros(*base, "--force", check=False)
    assert proc.returncode == 2, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and f"mcu_ws/uros/rclc is at {mine[:12]}, not at its locked commit" in errors[0]
    assert _tree(fw) == before


@pytest.mark.parametrize(
    ("setup", "expected"),
    [
        # a folder uros did not make: refused even with --force (issue 8 item 3)
        ("no-uros-files", "not a workspace made by uros create-firmware (no uros.yaml, no uros.lock)"),
        # uros.yaml but no lock: a folder uros is about to clone into holds the user's files
        ("no-lock", "mcu_ws/uros/rclc exists and is not in uros.lock, so uros did not clone it"),
        # a lock naming a folder outside the clones
        ("crafted-lock", "'../mine' is not a repository folder inside dev_ws/ or mcu_ws/"),
    ],
)
def test_force_refuses_folders_uros_did_not_make(
    upstream_to_read: Path, tmp_path: Path, setup: str, expected: str
) -> None:
    fw = tmp_path / "firmware"
    _pkg(fw / "mcu_ws/uros/rclc", "my_rclc")
    _pkg(tmp_path / "mine", "mine")
    if setup == "no-lock":
        (fw / "uros.yaml").write_text("distro: humble\n")
    if setup == "crafted-lock":
        (fw / "uros.lock").write_text(json.dumps({"repositories": {"../mine": {"commit": "c" * 40}}}))
    before = _tree(tmp_path)
    proc = run_uros_here(  # refused before any process starts
        "create-firmware",
        "--workspace",
        str(fw),
        "--no-dev-build",
        "--force",
        *upstream_mirror(upstream_to_read),
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and expected in errors[0], proc.stderr
    assert _tree(tmp_path) == before
