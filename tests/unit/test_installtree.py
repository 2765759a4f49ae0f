"""A target's trees package by package: manifests, dropping removed packages, archives and
headers of one build's set, flag stamps (over files in a temporary folder; no process)."""

from __future__ import annotations

from pathlib import Path

from uros_build.colcon import installtree


def _tree(tmp_path: Path) -> tuple[Path, Path]:
    build, install = tmp_path / "build", tmp_path / "install"
    files = {
        "fx_core": ["lib/libfx_core.a", "include/fx_core/fx_core/core.h", "share/fx_core/cmake/x.cmake"],
        "fx_gone": ["lib/libfx_gone.a", "include/fx_gone/fx_gone/gone.h", "include/fx_gone/fx_gone/sub/a.h"],
        "fx_py": ["lib/python3.11/site-packages/fx_py/__init__.py"],
    }
    for package, paths in files.items():
        (build / package).mkdir(parents=True)
        for rel in paths:
            (install / rel).parent.mkdir(parents=True, exist_ok=True)
            (install / rel).write_text(rel)
        name = "install.log" if package == "fx_py" else "install_manifest.txt"
        (build / package / name).write_text("\n".join(str(install / rel) for rel in paths))
        marker = install / "share" / "colcon-core" / "packages" / package
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.write_text("")
    (install / "lib" / "libstale.a").write_text("nobody's")
    return build, install


def test_installed_files_from_cmake_and_setuptools_records(tmp_path: Path) -> None:
    build, install = _tree(tmp_path)
    assert installtree.installed_files(build, "fx_core")[0] == install / "lib" / "libfx_core.a"
    assert installtree.installed_files(build, "fx_py") == (
        install / "lib/python3.11/site-packages/fx_py/__init__.py",
    )
    assert installtree.installed_files(build, "nothing") == ()


def test_drop_removed_takes_out_files_markers_and_build_folder(tmp_path: Path) -> None:
    build, install = _tree(tmp_path)
    outside = tmp_path / "outside.txt"
    outside.write_text("not uros's")
    (build / "fx_gone" / "install_manifest.txt").write_text(
        (build / "fx_gone" / "install_manifest.txt").read_text() + f"\n{outside}\n"
    )
    assert installtree.drop_removed(build, install, {"fx_core", "fx_py"}) == ["fx_gone"]
    assert not (install / "lib" / "libfx_gone.a").exists()
    assert not (install / "include" / "fx_gone").exists()  # emptied folders go too
    assert not (install / "share" / "colcon-core" / "packages" / "fx_gone").exists()
    assert not (build / "fx_gone").exists()
    assert outside.read_text() == "not uros's"  # never outside the install tree
    assert (install / "lib" / "libfx_core.a").is_file() and (install / "include" / "fx_core").is_dir()
    assert installtree.tree_packages(build) == {"fx_core", "fx_py"}


def test_archives_and_headers_of_a_package_set(tmp_path: Path) -> None:
    build, install = _tree(tmp_path)
    found = installtree.archives(build, install, ["fx_core", "fx_py"])
    assert found == {"fx_core": (install / "lib" / "libfx_core.a",), "fx_py": ()}  # not libstale.a
    assert installtree.headers(build, install, ["fx_core"]) == frozenset(
        {install / "include" / "fx_core" / "fx_core" / "core.h"}
    )


def test_stamps(tmp_path: Path) -> None:
    build, _install = _tree(tmp_path)
    a = installtree.package_stamp("flags-1", "fx_core", {"cmake-args": ("-DX=1",)})
    assert a == installtree.package_stamp("flags-1", "fx_core", {"cmake-args": ["-DX=1"]})
    assert a != installtree.package_stamp("flags-2", "fx_core", {"cmake-args": ("-DX=1",)})
    assert a != installtree.package_stamp("flags-1", "fx_core", {"cmake-args": ("-DX=2",)})
    installtree.write_stamp(build, "fx_core", a)
    installtree.write_stamp(build, "not_built", a)  # no build folder: nothing to vouch for
    assert installtree.read_stamp(build, "fx_core") == a
    assert installtree.read_stamp(build, "not_built") is None
    assert installtree.stale(build, {"fx_core": a, "fx_py": a}) == ["fx_py"]
    (build / "fx_core" / installtree.STAMP).write_text("{broken")
    assert installtree.stale(build, {"fx_core": a}) == ["fx_core"]
