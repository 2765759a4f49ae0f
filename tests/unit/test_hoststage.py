"""The host stage's pure choices and its file copy (hoststage.py): which packages it may build, the
key and folder of a stage, and a package taken into a target's trees with the stage's folder
replaced by the target's in what it installed."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uros_build.colcon import hoststage, installtree
from uros_build.colcon.command import ColconPlan, colcon_argv
from uros_build.errors import ConfigError
from uros_build.sources.packages import PackageInfo


def _pkg(
    name: str, configure: tuple[str, ...] = (), groups: tuple[str, ...] = (), group_deps: tuple[str, ...] = ()
) -> PackageInfo:
    return PackageInfo(
        name,
        "ament_cmake",
        frozenset(configure),
        Path("/ws/mcu_ws/src") / name,
        frozenset(group_deps),
        frozenset(groups),
        frozenset(configure),
    )


def test_the_shipped_list_names_the_rosidl_tools() -> None:
    listed = hoststage.load_list().packages
    assert {"rosidl_cli", "rosidl_adapter", "rosidl_parser", "rosidl_typesupport_interface"} <= set(listed)
    # never a package whose objects are in the library
    assert not {"rcutils", "rosidl_runtime_c", "rosidl_typesupport_c", "std_msgs"} & set(listed)


def test_a_list_of_another_format_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "host-stage.yaml"
    bad.write_text("format: 2\npackages: {a: b}\n")
    with pytest.raises(ConfigError, match="format: expected 1"):
        hoststage.load_list(bad)


def test_choose_keeps_only_packages_whose_configure_needs_no_target_package() -> None:
    packages = [
        _pkg("cli"),
        _pkg("adapter", ("cli", "ament_cmake")),  # needs a chosen package and a dev_ws one
        _pkg("gen", ("adapter", "rcutils")),  # needs a compiled package
        _pkg("defaults", group_deps=("generators",)),  # a group with a compiled member
        _pkg("typesupport_c", groups=("generators",)),
        _pkg("rcutils"),
        _pkg("user_of_gen", ("gen",)),
        _pkg("not_built"),
    ]
    building = {p.name for p in packages} - {"not_built"}
    listed = {"cli", "adapter", "gen", "defaults", "user_of_gen", "not_built"}
    # user_of_gen falls with gen (the loop runs until nothing more falls)
    assert hoststage.choose(packages, building, listed) == ("adapter", "cli")


def _stage(tmp_path: Path, meta: dict[str, dict[str, object]], sources: dict[str, str]) -> hoststage.Stage:
    return hoststage.plan_stage(
        tmp_path / ".uros" / "shared", ("a", "b"), meta, ("cmake 3.25",), sources, "lock"
    )


def test_the_stage_folder_is_named_by_what_builds_it_and_the_key_adds_the_sources(tmp_path: Path) -> None:
    one = _stage(tmp_path, {}, {"a": "1", "b": "2"})
    changed_source = _stage(tmp_path, {}, {"a": "1", "b": "3"})
    other_meta = _stage(tmp_path, {"a": {"cmake-args": ["-DX=1"]}}, {"a": "1", "b": "2"})
    unrelated_meta = _stage(tmp_path, {"zzz": {"cmake-args": ["-DX=1"]}}, {"a": "1", "b": "2"})
    assert one.folder == changed_source.folder and one.key != changed_source.key
    assert other_meta.folder != one.folder
    assert unrelated_meta.folder == one.folder and unrelated_meta.key == one.key
    assert one.folder.parent == tmp_path / ".uros" / "shared"
    # the workspace moved or copied: the same folder name, another key (what the stage installed
    # names its folder, so it is built again where it is now: issue 34, item 1)
    moved = _stage(tmp_path / "moved", {}, {"a": "1", "b": "2"})
    assert moved.folder.name == one.folder.name and moved.key != one.key


def _installed(stage: hoststage.Stage, package: str, files: dict[str, bytes]) -> None:
    """A package as colcon leaves it in a stage: its files and its install manifest."""
    listed = []
    for rel, data in files.items():
        path = stage.install_base / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        if not rel.startswith("share/colcon-core"):
            listed.append(str(path))
    (stage.build_base / package).mkdir(parents=True, exist_ok=True)
    (stage.build_base / package / "install_manifest.txt").write_text("\n".join(listed) + "\n")


def test_take_copies_a_package_with_the_targets_folder_in_place_of_the_stages(tmp_path: Path) -> None:
    ws = tmp_path
    stage = _stage(ws, {}, {})
    stage_rel = str(stage.folder.relative_to(ws))
    prefix = str(stage.install_base).encode()
    _installed(
        stage,
        "b",
        {
            "include/b/b.h": b"#define B 1\n",
            "share/b/package.sh": b'_colcon_package_sh_COLCON_CURRENT_PREFIX="' + prefix + b'"\n',
            "share/b/cmake/bConfig.cmake": b"set(B_FOUND 1)\n",
            "share/colcon-core/packages/b": b"a\n",
            "lib/python3/site-packages/b.egg-info/SOURCES.txt": f"../../../../{stage_rel}/build/b/x\n".encode(),
        },
    )
    target_build, target_install = (
        ws / ".uros" / "targets" / "m7" / "build",
        ws / ".uros" / "targets" / "m7" / "install",
    )
    # what the target built of b itself before: its own files go first
    (target_build / "b").mkdir(parents=True)
    old = target_install / "include" / "b" / "old.h"
    old.parent.mkdir(parents=True)
    old.write_text("old\n")
    (target_build / "b" / "install_manifest.txt").write_text(f"{old}\n")
    (target_build / "b" / "CMakeCache.txt").write_text("cache\n")

    assert hoststage.take(stage, "b", target_build, target_install, ws) == 5
    assert not old.exists() and not (target_build / "b" / "CMakeCache.txt").exists()
    assert (target_install / "include/b/b.h").read_bytes() == b"#define B 1\n"
    sh = (target_install / "share/b/package.sh").read_bytes()
    assert str(target_install).encode() in sh and b".uros/shared" not in sh
    sources = (target_install / "lib/python3/site-packages/b.egg-info/SOURCES.txt").read_text()
    assert sources == "../../../../.uros/targets/m7/build/b/x\n"
    # the target's trees now trace every file to b, as if colcon had installed it there
    assert {str(p) for p in installtree.installed_files(target_build, "b")} == {
        str(target_install / rel)
        for rel in (
            "include/b/b.h",
            "share/b/package.sh",
            "share/b/cmake/bConfig.cmake",
            "share/colcon-core/packages/b",
            "lib/python3/site-packages/b.egg-info/SOURCES.txt",
        )
    }
    assert installtree.headers(target_build, target_install, ["b"]) == {target_install / "include/b/b.h"}
    assert hoststage.taken(target_build, "b", stage.key)
    assert not hoststage.taken(target_build, "b", "another key")
    (target_install / "include/b/b.h").unlink()  # a file gone: taken again
    assert not hoststage.taken(target_build, "b", stage.key)


def test_a_package_that_compiled_anything_is_found(tmp_path: Path) -> None:
    stage = _stage(tmp_path, {}, {})
    _installed(stage, "headers", {"include/h.h": b""})
    _installed(stage, "objects", {"share/objects/x.cmake": b""})
    (stage.build_base / "objects" / "CMakeFiles" / "o.dir").mkdir(parents=True)
    (stage.build_base / "objects" / "CMakeFiles" / "o.dir" / "o.c.o").write_bytes(b"")
    _installed(stage, "library", {"lib/libl.so.1": b""})
    found = [
        p
        for p in ("headers", "objects", "library")
        if hoststage.compiled_code(stage.build_base, stage.install_base, p)
    ]
    assert found == ["objects", "library"]


def test_a_marker_round_trips_and_a_damaged_one_is_none(tmp_path: Path) -> None:
    stage = _stage(tmp_path, {}, {})
    stage.folder.mkdir(parents=True)
    marker = hoststage.Marker(stage.key, ("a",), ("b",))
    hoststage.write_marker(stage, marker, "uros test")
    assert hoststage.read_marker(stage) == marker
    assert json.loads((stage.folder / hoststage.MARKER).read_text())["_generated_by"] == "uros test"
    (stage.folder / hoststage.MARKER).write_text("{")
    assert hoststage.read_marker(stage) is None


def test_the_stage_colcon_command_is_the_firmware_one_without_a_toolchain_and_targets_skip_it() -> None:
    stage_plan = ColconPlan(
        base_paths=(Path("/ws/mcu_ws"),),
        build_base=Path("/ws/.uros/shared/k/build"),
        install_base=Path("/ws/.uros/shared/k/install"),
        log_base=Path("/ws/.uros/shared/k/log"),
        metas=(Path("/ws/.uros/shared/k/colcon.meta"),),
        toolchain_file=None,
        python="/venv/bin/python3",
        ignore_regex=None,
        packages_ignore=("rcutils",),
    )
    argv = colcon_argv(stage_plan)
    cmake_args = argv[argv.index("--cmake-args") + 1 :]
    assert "-DBUILD_SHARED_LIBS=OFF" in cmake_args and "-DTHIRDPARTY=ON" in cmake_args
    assert not any(a.startswith("-DCMAKE_TOOLCHAIN_FILE") for a in argv)
    target = ColconPlan(**{**stage_plan.__dict__, "packages_skip": ("a", "b"), "packages_ignore": ()})
    argv = colcon_argv(target)
    assert argv[argv.index("--packages-skip") + 1 : argv.index("--packages-skip") + 3] == ["a", "b"]
