"""The mapping from raw arguments to plans, tested without running anything (cibuildwheel's
unit_test/main_tests idea): every input is validated before a process could start."""

from __future__ import annotations

from pathlib import Path

import pytest
from fake_idf import make_idf_build

from uros_build import defaults, resources
from uros_build.config.buildargs import BuildArgs
from uros_build.config.colconmeta import meta_option, meta_transport
from uros_build.config.plan import plan_build
from uros_build.config.sourceplan import CreateArgs, plan_create, plan_sources
from uros_build.config.targets import ProfileTarget, ToolchainFileTarget, resolve_target, target_profile
from uros_build.errors import ConfigError
from uros_build.sources.distros import Distro, Mirror, MirrorRule, Override, Repo
from uros_build.sources.meta import Meta


def _ws(tmp_path: Path) -> Path:
    pkg = tmp_path / "ws" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>pkg</name></package>", encoding="utf-8")
    return tmp_path / "ws"


# -- resolve_target ----------------------------------------------------------------------------


def test_a_shipped_target_by_name() -> None:
    target = resolve_target("cortex-m7", None)
    assert isinstance(target, ProfileTarget)
    assert target.key == "cortex-m7" and target.profile.name == "cortex-m7"


def test_a_toolchain_file_is_used_unchanged(tmp_path: Path) -> None:
    tc = tmp_path / "my board.cmake"
    tc.write_text("set(CMAKE_SYSTEM_NAME Generic)\n", encoding="utf-8")
    target = resolve_target(str(tc), None)
    assert isinstance(target, ToolchainFileTarget)
    assert target.key == "my_board" and target.toolchain_file == tc.resolve()


def test_a_yaml_target_is_a_profile_file(tmp_path: Path) -> None:
    """Issue 34, item 3: never handed to CMake as a toolchain file."""
    board = tmp_path / "my_board.yaml"
    board.write_text(
        (resources.toolchains_dir() / "cortex-m7.yaml")
        .read_text()
        .replace("name: cortex-m7", "name: my-board")
    )
    target = resolve_target(str(board), None, flag="uros.yaml: target")
    assert isinstance(target, ProfileTarget) and target.key == "my-board"
    with pytest.raises(ConfigError, match=r"uros\.yaml: target .*none\.yml: no such profile file"):
        resolve_target(str(tmp_path / "none.yml"), None, flag="uros.yaml: target")


def test_deriving_from_a_target_gets_its_own_key() -> None:
    target = resolve_target("cortex-m4f", None, cflags=("-DBOARD=2",))
    assert isinstance(target, ProfileTarget) and target.key == "cortex-m4f-custom"
    assert target.profile.c_flags[-1] == "-DBOARD=2"


def test_a_standalone_compiler_prefix() -> None:
    target = resolve_target(None, None, compiler_prefix="riscv64-unknown-elf-", cflags=("-march=rv32imac",))
    assert isinstance(target, ProfileTarget) and target.key == "custom-riscv64-unknown-elf"


@pytest.mark.parametrize(
    ("toolchain", "profile", "prefix", "cflags", "message"),
    [
        (None, None, None, (), "no target given"),
        ("cortex-m9", None, None, (), "unknown target 'cortex-m9'"),
        ("cortex-m7", Path("x.yaml"), None, (), "name a target twice"),
        ("/nope/tc.cmake", None, None, (), "no such file"),
        (None, None, None, ("-DX",), "--cflags without a target"),
    ],
)
def test_bad_targets(
    toolchain: str | None, profile: Path | None, prefix: str | None, cflags: tuple[str, ...], message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        resolve_target(toolchain, profile, prefix, cflags)


def test_a_toolchain_file_cannot_be_derived(tmp_path: Path) -> None:
    tc = tmp_path / "tc.cmake"
    tc.write_text("", encoding="utf-8")
    with pytest.raises(ConfigError, match="cannot change your own toolchain file"):
        resolve_target(str(tc), None, cflags=("-DX",))


# -- meta_transport ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (("-DRMW_UXRCE_TRANSPORT=udp", "-DX=1"), "udp"),
        (("-DX=1",), None),
        ("-DRMW_UXRCE_TRANSPORT=udp", None),  # a string, not a list: not a cmake-args list
    ],
)
def test_meta_transport(args: tuple[str, ...] | str, expected: str | None) -> None:
    assert meta_transport(Meta({"rmw_microxrcedds": {"cmake-args": args}})) == expected
    assert meta_transport(Meta({})) is None


# -- plan_build --------------------------------------------------------------------------------


def test_plan_build_defaults(tmp_path: Path) -> None:
    ws = _ws(tmp_path)
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7"))
    assert plan.output == ws.resolve() / "build" / "cortex-m7"
    assert plan.target_dir == ws.resolve() / ".uros" / "targets" / "cortex-m7"
    assert plan.config is None and plan.distro is None and target_profile(plan.target) is not None
    assert meta_transport(plan.meta) == "custom"  # the target's transport
    assert "rcutils" in plan.meta.names  # no native 64-bit atomics on cortex-m7


def test_plan_build_layers_sets_over_the_transport(tmp_path: Path) -> None:
    plan = plan_build(
        BuildArgs(workspace=_ws(tmp_path), toolchain="cortex-m7", transport="udp",
                  sets=("rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2",))
    )  # fmt: skip
    args = plan.meta.names["rmw_microxrcedds"]["cmake-args"]
    assert "-DRMW_UXRCE_TRANSPORT=udp" in args and "-DRMW_UXRCE_MAX_NODES=2" in args


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"jobs": 0}, "-j/--jobs 0: must be 1 or more"),
        ({"transport": "can"}, "unknown transport 'can'"),
        ({"preset": "ardent"}, "unknown preset 'ardent'"),
        ({"sets": ("nodot",)}, "expected PACKAGE.OPTION=VALUE"),
        ({"metas": (Path("/nope.meta"),)}, "no such file"),
    ],
)
def test_plan_build_refuses_bad_input(tmp_path: Path, change: dict[str, object], message: str) -> None:
    args = BuildArgs(workspace=_ws(tmp_path), toolchain="cortex-m7")
    with pytest.raises(ConfigError, match=message):
        plan_build(BuildArgs(**{**args.__dict__, **change}))  # type: ignore[arg-type]


def test_plan_build_needs_packages(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"not a uros workspace .* no package\.xml"):
        plan_build(BuildArgs(workspace=tmp_path, toolchain="cortex-m7"))


def test_plan_build_reads_the_workspace_config(tmp_path: Path) -> None:
    ws = _ws(tmp_path)
    (ws / "uros.yaml").write_text("distro: jazzy\n", encoding="utf-8")
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7"))
    assert plan.config is not None and plan.distro is not None and plan.distro.name == "jazzy"


def test_uros_yaml_names_the_targets_and_the_command_line_wins(tmp_path: Path) -> None:
    from uros_build.config.buildargs import expand_targets

    ws = _ws(tmp_path)
    (ws / "uros.yaml").write_text("distro: humble\ntargets: [cortex-m7, rp2040]\n", encoding="utf-8")
    expanded = expand_targets(BuildArgs(workspace=ws))
    assert [a.toolchain for a in expanded] == ["cortex-m7", "rp2040"]
    assert expand_targets(BuildArgs(workspace=ws, toolchain="cortex-m4")) == (
        BuildArgs(workspace=ws, toolchain="cortex-m4"),
    )
    with pytest.raises(ConfigError, match="--output with 2 targets"):
        expand_targets(BuildArgs(workspace=ws, output=tmp_path / "out"))
    (ws / "uros.yaml").write_text("distro: humble\ntarget: cortex-m9\n", encoding="utf-8")
    (request,) = expand_targets(BuildArgs(workspace=ws))
    with pytest.raises(ConfigError, match=r"uros.yaml: target: unknown target 'cortex-m9' \(did you mean"):
        plan_build(request)
    (ws / "uros.yaml").write_text("distro: humble\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="no target given") as info:
        plan_build(expand_targets(BuildArgs(workspace=ws))[0])
    assert "target: NAME" in str(info.value.hint)


def test_uros_yaml_transport_and_set_come_under_the_command_line(tmp_path: Path) -> None:
    ws = _ws(tmp_path)
    (ws / "uros.yaml").write_text(
        "distro: humble\ntransport: udp\nset: [pkg.A=1, pkg.B=1]\n", encoding="utf-8"
    )
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7"))
    assert meta_transport(plan.meta) == "udp"
    assert plan.meta.names["pkg"]["cmake-args"] == ("-DA=1", "-DB=1")
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", transport="serial", sets=("pkg.B=2",)))
    assert meta_transport(plan.meta) == "serial"
    assert plan.meta.names["pkg"]["cmake-args"] == ("-DA=1", "-DB=2")


def test_idf_build_on_the_command_line(tmp_path: Path) -> None:
    build, ws = make_idf_build(tmp_path / "idf"), _ws(tmp_path)
    plan = plan_build(BuildArgs(workspace=ws, toolchain="esp32s3", idf_build=build))
    assert (
        plan.platform.idf is not None
        and plan.platform.idf.target == "esp32s3"
        and plan.platform.idf.version == (5, 3, 1)
    )
    with pytest.raises(
        ConfigError, match=r"^--idf-build .*IDF_TARGET esp32s3, uros builds for esp32 \(esp32\)"
    ):
        plan_build(BuildArgs(workspace=ws, toolchain="esp32", idf_build=build))
    with pytest.raises(ConfigError, match="target cortex-m7 is not an ESP-IDF target"):
        plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", idf_build=build))
    tc = tmp_path / "mine.cmake"
    tc.write_text("set(CMAKE_SYSTEM_NAME Generic)\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="--idf-build with your own toolchain file mine"):
        plan_build(BuildArgs(workspace=ws, toolchain=str(tc), idf_build=build))


def test_idf_build_in_uros_yaml_is_for_the_esp_idf_target(tmp_path: Path) -> None:
    ws = _ws(tmp_path)
    make_idf_build(ws / "idfproj")
    (ws / "uros.yaml").write_text("distro: humble\nidf_build: idfproj/proj/build\n", encoding="utf-8")
    plan = plan_build(BuildArgs(workspace=ws, toolchain="esp32s3"))
    assert plan.platform.idf is not None and plan.platform.idf.build_dir == str(
        (ws / "idfproj/proj/build").resolve()
    )
    # another target of the same workspace builds without it
    assert plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7")).platform.idf is None
    # the command line wins
    other = make_idf_build(tmp_path / "other")
    assert plan_build(
        BuildArgs(workspace=ws, toolchain="esp32s3", idf_build=other)
    ).platform.idf.build_dir == str(  # type: ignore[union-attr]
        other.resolve()
    )
    (ws / "uros.yaml").write_text("distro: humble\nidf_build: nowhere\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"uros\.yaml: idf_build .*nowhere: no such folder"):
        plan_build(BuildArgs(workspace=ws, toolchain="esp32s3"))


@pytest.mark.parametrize(
    ("version", "own_atomics"), [((5, 3, 1), False), ((5, 2, 3), True), ((4, 4, 8), True)]
)
def test_idf_before_5_3_gets_rcutils_own_64bit_atomics(
    tmp_path: Path, version: tuple[int, int, int], own_atomics: bool
) -> None:
    build = make_idf_build(tmp_path / "idf", version=version)
    plan = plan_build(BuildArgs(workspace=_ws(tmp_path), toolchain="esp32s3", idf_build=build))
    rcutils = plan.meta.names.get("rcutils", {}).get("cmake-args", ())
    assert ("-DRCUTILS_NO_64_ATOMIC=ON" in rcutils) is own_atomics
    profile = target_profile(plan.target)
    assert profile is not None and profile.native_64bit_atomics is not own_atomics
    # micro_ros_espidf_component: C17 from ESP-IDF 5 on, C11 before, for the XRCE-DDS client too
    standard = 11 if version < (5, 0, 0) else 17
    assert profile.c_standard == standard
    assert f"-DUCLIENT_C_STANDARD={standard}" in plan.meta.names["microxrcedds_client"]["cmake-args"]


# -- plan_sources / plan_create ----------------------------------------------------------------


def _distro() -> Distro:
    return Distro(
        name="humble", status="built-here", preset="humble",
        dev=(Repo("ament/ament_cmake", "https://github.com/ament/ament_cmake.git", "humble"),),
        mcu=(Repo("uros/rclc", "https://github.com/ros2/rclc.git", "humble"),
             Repo("eProsima/Micro-CDR", "https://github.com/eProsima/Micro-CDR.git", "ros2")),
        colcon_ignore=(), dev_colcon_ignore=(), build_time_clones=(),
    )  # fmt: skip


def test_plan_sources_applies_mirror_override_and_lock() -> None:
    mirror = Mirror(
        (MirrorRule("https://github.com/{owner}/{repo}", "/m/{owner}+{repo}/repo"),),
        (Override("eProsima/Micro-CDR", None, "humble"),),
    )
    sources = plan_sources(_distro(), mirror, {"mcu_ws/uros/rclc": "a" * 40})
    assert sorted(sources) == ["dev_ws/ament/ament_cmake", "mcu_ws/eProsima/Micro-CDR", "mcu_ws/uros/rclc"]
    assert sources["dev_ws/ament/ament_cmake"].url == "/m/ament+ament_cmake/repo"
    assert sources["mcu_ws/eProsima/Micro-CDR"].version == "humble"
    rclc = sources["mcu_ws/uros/rclc"]
    assert rclc.version == "a" * 40 and rclc.is_commit


def test_plan_create_defaults(tmp_path: Path) -> None:
    plan = plan_create(CreateArgs(directory=tmp_path / "fw"))
    assert plan.distro.name == defaults.DISTRO and not plan.existed and plan.probe is None
    assert all(p.startswith(("dev_ws/", "mcu_ws/")) for p in plan.sources)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"platform": "nuttx"}, "unknown platform 'nuttx'"),
        ({"distro": "ardent"}, "unknown distro 'ardent'"),
        ({"jobs": 0}, "must be 1 or more"),
        ({"locked": True}, "no such lock file"),
        ({"mirrors": ("nonsense",)}, "expected UPSTREAM=LOCAL"),
        ({"toolchain": "cortex-m9"}, "unknown target"),
        ({"extra_packages": (Path("/nope"),)}, "no such folder"),
        ({"config": Path("/nope.yaml")}, "no such file"),
    ],
)
def test_plan_create_refuses_bad_input(tmp_path: Path, change: dict[str, object], message: str) -> None:
    args = CreateArgs(directory=tmp_path / "fw")
    with pytest.raises(ConfigError, match=message):
        plan_create(CreateArgs(**{**args.__dict__, **change}))  # type: ignore[arg-type]
    assert not (tmp_path / "fw").exists()


def test_plan_create_refuses_an_existing_folder_without_force(tmp_path: Path) -> None:
    (tmp_path / "fw").mkdir()
    (tmp_path / "fw" / "notes.txt").write_text("mine", encoding="utf-8")
    with pytest.raises(ConfigError, match="already exists"):
        plan_create(CreateArgs(directory=tmp_path / "fw"))


def test_plan_create_reads_a_config_file(tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("mirror:\n  rules: ['https://github.com/{owner}/{repo}=https://git.example/{repo}']\n")
    plan = plan_create(CreateArgs(directory=tmp_path / "fw", config=cfg))
    assert plan.sources["mcu_ws/uros/rclc"].url == "https://git.example/rclc"


@pytest.mark.parametrize(
    ("text", "message"), [("- a\n- b\n", "expected a mapping"), ("mirror: [\n", "not valid YAML")]
)
def test_plan_create_refuses_a_bad_config_file(tmp_path: Path, text: str, message: str) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=message):
        plan_create(CreateArgs(directory=tmp_path / "fw", config=cfg))


def test_workspace_default_is_the_nearest_uros_yaml_upward(tmp_path: Path) -> None:
    from uros_build.config.resolver import resolve_workspace

    (tmp_path / "fw" / "mcu_ws" / "src").mkdir(parents=True)
    (tmp_path / "fw" / "uros.yaml").write_text("distro: humble\n")
    assert resolve_workspace(None, tmp_path / "fw" / "mcu_ws" / "src") == (tmp_path / "fw").resolve()
    assert resolve_workspace(None, tmp_path) == tmp_path / "firmware"
    assert resolve_workspace(Path("given"), tmp_path / "fw") == Path("given")


# -- package selection: --packages, --for-firmware, uros.yaml packages: ----------------------------


def _pkg(root: Path, name: str, deps: tuple[str, ...] = ()) -> None:
    folder = root / name
    folder.mkdir(parents=True)
    dep_lines = "".join(f"<depend>{d}</depend>" for d in deps)
    (folder / "package.xml").write_text(
        f"<package><name>{name}</name>{dep_lines}</package>", encoding="utf-8"
    )


def _firmware_ws(tmp_path: Path, packages: str = "") -> Path:
    ws = tmp_path / "fw"
    src = ws / "mcu_ws"
    for name in ("rcl", "rclc", "rmw_microxrcedds", "std_msgs", "nav_msgs", "rcutils"):
        _pkg(src / "src", name)
    _pkg(src / "extra_packages", "my_msgs", ("std_msgs",))
    (ws / "uros.yaml").write_text(f"distro: humble\n{packages}", encoding="utf-8")
    return ws


def test_no_selection_builds_everything(tmp_path: Path) -> None:
    plan = plan_build(BuildArgs(workspace=_firmware_ws(tmp_path), toolchain="cortex-m7"))
    assert plan.selection is None and plan.packages_up_to == ()


def test_packages_add_the_core_the_workspace_has_and_the_extra_packages(tmp_path: Path) -> None:
    plan = plan_build(
        BuildArgs(workspace=_firmware_ws(tmp_path), toolchain="cortex-m7", packages=("nav_msgs",))
    )
    assert plan.selection is not None
    assert plan.selection.core == ("rcl", "rclc", "rmw_microxrcedds")  # no micro_ros_utilities here
    assert plan.selection.extra == ("my_msgs",)
    assert plan.requested == ("my_msgs", "nav_msgs", "rcl", "rclc", "rmw_microxrcedds")


def test_uros_yaml_packages_and_the_command_line_overriding_them(tmp_path: Path) -> None:
    ws = _firmware_ws(tmp_path, "packages: [std_msgs]\n")
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7"))
    assert plan.selection is not None and plan.selection.wanted == ("std_msgs",)
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", packages=("nav_msgs",)))
    assert plan.selection is not None and plan.selection.wanted == ("nav_msgs",)
    assert "std_msgs" not in plan.requested


def test_for_firmware_builds_what_the_sources_use(tmp_path: Path) -> None:
    ws = _firmware_ws(tmp_path, "packages: [std_msgs]\n")
    app = tmp_path / "app"
    app.mkdir()
    (app / "main.c").write_text("#include <nav_msgs/msg/odometry.h>\n", encoding="utf-8")
    plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", for_firmware=app))
    assert plan.selection is not None and plan.selection.wanted == ()  # uros.yaml's are replaced
    assert plan.requested == ("my_msgs", "nav_msgs", "rcl", "rclc", "rmw_microxrcedds")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ({"packages": ("nav_msg",)}, "--packages nav_msg: no package nav_msg in"),
        ({"packages": ("nav_msgs",), "packages_up_to": ("rcl",)}, "--packages-up-to and --packages"),
        ({"for_firmware": Path("missing")}, "--for-firmware missing: no such folder"),
    ],
)
def test_bad_selections(tmp_path: Path, args: dict[str, object], message: str) -> None:
    ws = _firmware_ws(tmp_path)
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")) as err:
        plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", **args))  # type: ignore[arg-type]
    if "nav_msg:" in message:
        assert "closest: nav_msgs" in err.value.message


def test_for_firmware_naming_a_package_the_workspace_lacks(tmp_path: Path) -> None:
    ws = _firmware_ws(tmp_path)
    app = tmp_path / "app"
    app.mkdir()
    (app / "main.c").write_text("x = ROSIDL_GET_MSG_TYPE_SUPPORT(sensor_msgs, msg, Imu);\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"the firmware uses sensor_msgs \(main.c\), which is not in the"):
        plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", for_firmware=app))
    (app / "main.c").write_text("int main(void) { return 0; }\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="no interface type found in 1 C/C"):
        plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", for_firmware=app))


def test_an_unedited_workspace_meta_does_not_undo_another_preset(tmp_path: Path) -> None:
    """create-firmware writes the distro's preset into the workspace's colcon.meta; merged over
    `--preset tiny` it put humble's RMW_UXRCE_MAX_HISTORY=4 back over tiny's 1 (the cores helper
    found `--preset tiny` alone did not fit the microbit). An edited file still wins."""
    ws = _ws(tmp_path)
    (ws / "uros.yaml").write_text("distro: humble\n", encoding="utf-8")
    humble = resources.meta_dir() / "presets" / "humble.json"
    (ws / "colcon.meta").write_text(humble.read_text(encoding="utf-8"), encoding="utf-8")

    def history(preset: str) -> str | None:
        plan = plan_build(BuildArgs(workspace=ws, toolchain="cortex-m7", preset=preset))
        return meta_option(plan.meta, "rmw_microxrcedds", "RMW_UXRCE_MAX_HISTORY")

    assert history("tiny") == "1"
    assert history("default") == "4"
    (ws / "colcon.meta").write_text(
        humble.read_text(encoding="utf-8").replace("-DRMW_UXRCE_MAX_HISTORY=4", "-DRMW_UXRCE_MAX_HISTORY=3"),
        encoding="utf-8",
    )
    assert history("tiny") == "3"  # the user's own edit is merged over any preset
