"""The firmware workspace: its layout on disk, its data files, and where uros keeps things in it.

    <workspace>/
      uros.yaml          what create-firmware made: distro, mirror rules, extra packages (edit freely)
      uros.lock          the commit of every cloned repository (`--locked` re-creates exactly these)
      colcon.meta        the distro's generate_lib meta, layered into every `uros build` (edit freely)
      mcu_ws/            sources colcon builds for the MCU (or the packages sit in <workspace> itself)
      mcu_ws/extra_packages/   the user's packages, synced from their folders at every build
      dev_ws/            host tools workspace (ament, ...), built once, shared by every target
      build/<target>/    outputs: libmicroros.a, include/, CMake package, build-info.json
      .uros/targets/<target>/{build,install,log}   colcon's trees, kept between runs per target
      .uros/log/         one log per uros run, latest.log the newest

Keeping colcon's trees per target is what makes a second build incremental (micro_ros_setup's
build.sh wipes build/install/log every time) and what lets two targets share one workspace.
This module only reads and writes files; it starts no processes.
"""

from __future__ import annotations

import os
import re
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build import console, proc
from uros_build.errors import ConfigError
from uros_build.sources.wsfiles import (
    CONFIG,
    DEV_WS,
    EXTRA,
    LOCK,
    MCU_WS,
    STATE,
    WorkspaceConfig,
    load_config,
)

USER_META = "colcon.meta"
# written by create-firmware before it clones (a lock without commits), removed when it is done: a
# folder a killed create-firmware left is recognised, and --force finishes it
PENDING = f"{STATE}/create-firmware.pending"
DEV_MARKER = ".uros-dev-built"  # in dev_ws/install: the lock the dev workspace was built from
_IGNORE_NOTE = "uros: colcon must not look for packages here\n"


# ---------------------------------------------------------------------------------------------
# extra packages


def package_name(package_xml: Path) -> str:
    try:
        name = ET.parse(package_xml).getroot().findtext("name")
    except ET.ParseError as exc:
        raise ConfigError(f"{package_xml}: not valid XML: {exc}") from exc
    if not name:
        raise ConfigError(f"{package_xml}: has no <name>")
    return name.strip()


def check_extra_package(path: Path, flag: str) -> str:
    """The package name of the folder ``path``, or a ConfigError naming ``flag``."""
    if not path.is_dir():
        raise ConfigError(f"{flag} {path}: no such folder", "pass the folder of a ROS 2 package")
    xml = path / "package.xml"
    if not xml.is_file():
        raise ConfigError(
            f"{flag} {path}: no package.xml in it",
            "an extra package is a ROS 2 package folder (package.xml, CMakeLists.txt); "
            "`uros interface new` scaffolds one",
        )
    return package_name(xml)


def sync_tree(src: Path, dst: Path) -> int:
    """Make ``dst`` a copy of ``src``, touching only files whose content changed (so the build
    sees exactly what changed); returns how many files were written or removed."""
    changed = 0
    dst.mkdir(parents=True, exist_ok=True)
    wanted = set()
    for path in sorted(src.rglob("*")):
        rel = path.relative_to(src)
        if any(part.startswith(".git") for part in rel.parts):
            continue
        wanted.add(rel)
        target = dst / rel
        if path.is_dir():
            target.mkdir(parents=True, exist_ok=True)
        elif not target.is_file() or target.read_bytes() != path.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
            changed += 1
    for path in sorted(dst.rglob("*"), reverse=True):
        if path.relative_to(dst) not in wanted:
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink()
            changed += 1
    return changed


# ---------------------------------------------------------------------------------------------
# the host dev workspace


def dev_env(env: Mapping[str, str], install: Path) -> dict[str, str]:
    """What sourcing dev_ws/install/setup.bash provides, without a shell (pure)."""
    out = dict(env)
    prefix = str(install)
    out["AMENT_PREFIX_PATH"] = prefix
    out["CMAKE_PREFIX_PATH"] = prefix
    out["PATH"] = os.pathsep.join(p for p in (str(install / "bin"), env.get("PATH", "")) if p)
    sites = sorted(str(p) for p in install.glob("lib/python3*/site-packages"))
    out["PYTHONPATH"] = os.pathsep.join(
        [*sites, *(p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p)]
    )
    return out


# ---------------------------------------------------------------------------------------------
# the workspace


@dataclass(frozen=True)
class Workspace:
    root: Path

    @classmethod
    def open(cls, path: Path, flag: str = "--workspace") -> Workspace:
        """A folder holding packages (a firmware workspace or any colcon workspace)."""
        root = path.resolve()
        if not root.is_dir():
            raise ConfigError(
                f"{flag} {path}: no such folder",
                "pass a colcon workspace, or create one with `uros create-firmware generate_lib`",
            )
        check_build_folder(root, flag)
        ws = cls(root)
        if not ws.has_packages():
            raise ConfigError(
                f"{flag} {path}: not a uros workspace (no {CONFIG}) and no package.xml under {ws.source_dir}",
                "create one with `uros create-firmware generate_lib -w DIR`; a colcon workspace holds "
                "packages (folders with package.xml) in mcu_ws/ or in the folder itself",
            )
        return ws

    @classmethod
    def open_firmware(cls, path: Path, flag: str = "--workspace") -> tuple[Workspace, WorkspaceConfig]:
        """A workspace made by `uros create-firmware` (it has a uros.yaml)."""
        root = path.resolve()
        cfg = load_config(root)
        if cfg is None:
            raise ConfigError(
                f"{flag} {path}: not a firmware workspace (no {CONFIG})",
                "create one with `uros create-firmware generate_lib`, "
                "or copy the package into your workspace",
            )
        return cls(root), cfg

    # -- layout --------------------------------------------------------------------------------

    @property
    def mcu_dir(self) -> Path:
        return self.root / MCU_WS

    @property
    def source_dir(self) -> Path:
        return self.mcu_dir if self.mcu_dir.is_dir() else self.root

    @property
    def extra_dir(self) -> Path:
        return self.mcu_dir / EXTRA

    @property
    def state_dir(self) -> Path:
        return self.root / STATE

    @property
    def log_dir(self) -> Path:
        return self.state_dir / "log"

    @property
    def stages_dir(self) -> Path:
        """The host stages (colcon/hoststage.py), one folder per stage key, shared by every target."""
        return self.state_dir / "shared"

    @property
    def user_meta(self) -> Path:
        return self.root / USER_META

    @property
    def lock_path(self) -> Path:
        return self.root / LOCK

    @property
    def pending(self) -> Path:
        return self.root / PENDING

    @property
    def dev_dir(self) -> Path:
        return self.root / DEV_WS

    @property
    def dev_install(self) -> Path:
        return self.dev_dir / "install"

    @property
    def dev_marker(self) -> Path:
        return self.dev_install / DEV_MARKER

    def dev_built(self) -> bool:
        return self.dev_marker.is_file()

    def dev_built_from(self) -> str:
        """The uros.lock text dev_ws was built from ("" when it is not built)."""
        return self.dev_marker.read_text(encoding="utf-8") if self.dev_marker.is_file() else ""

    def mark_dev_built(self) -> None:
        lock = self.lock_path.read_text(encoding="utf-8") if self.lock_path.is_file() else ""
        self.dev_marker.write_text(lock, encoding="utf-8")

    def target_dir(self, key: str) -> Path:
        return _target_folder(self.state_dir / "targets", key)

    @property
    def outputs_dir(self) -> Path:
        return self.root / "build"

    def default_output(self, key: str) -> Path:
        return _target_folder(self.outputs_dir, key)

    def tree_keys(self) -> list[str]:
        """The targets uros has trees of here (.uros/targets/<key>); outputs.target_keys adds
        those with only an output."""
        trees = self.state_dir / "targets"
        return sorted(p.name for p in trees.iterdir() if p.is_dir()) if trees.is_dir() else []

    def new_log(self, command: str, key: str = "") -> Path:
        return proc.new_run_log(self.log_dir, command, key)

    def has_packages(self) -> bool:
        for _dirpath, dirnames, filenames in os.walk(self.source_dir):
            if "COLCON_IGNORE" in filenames:
                dirnames[:] = []
                continue
            if "package.xml" in filenames:
                return True
            dirnames[:] = [
                d for d in dirnames if not d.startswith(".") and d not in ("build", "install", "log")
            ]
        return False

    def mark_ignored(self) -> None:
        """Keep colcon from finding installed package.xml files in uros's own folders."""
        for folder in (self.state_dir, self.outputs_dir):
            folder.mkdir(parents=True, exist_ok=True)
            marker = folder / "COLCON_IGNORE"
            if not marker.exists():
                marker.write_text(_IGNORE_NOTE, encoding="utf-8")

    # -- extra packages ------------------------------------------------------------------------

    def kept_copy(self, src: Path) -> Path | None:
        """The copy in mcu_ws/extra_packages of an extra package whose folder ``src`` is gone (the
        copy is named by its package; a package named as its folder is found), else None."""
        copy = self.extra_dir / src.name
        return copy if (copy / "package.xml").is_file() else None

    def check_extra_sources(self, cfg: WorkspaceConfig) -> None:
        """uros.yaml's extra packages are folders, or were (their copy builds on): one that never
        was is refused before anything runs, not left out of the build."""
        for entry in cfg.extra_packages:
            self._source_or_copy(Path(entry))

    def _source_or_copy(self, src: Path) -> Path:
        """An extra package's folder, else the copy uros kept of it, else one line."""
        found = src if src.is_dir() else self.kept_copy(src)
        if found is None:
            raise ConfigError(
                f"{self.root / CONFIG}: extra_packages: {src} is no folder, and mcu_ws/{EXTRA} has no "
                "copy of it",
                "fix the path (a ROS 2 package's folder), or remove it from extra_packages:",
            )
        return found

    def sync_extra_packages(self, cfg: WorkspaceConfig) -> None:
        """Copy each extra package's folder into mcu_ws/extra_packages, changed files only."""
        for entry in cfg.extra_packages:
            src = Path(entry)
            found = self._source_or_copy(src)
            if found != src:
                console.warn(
                    f"{self.root / CONFIG}: extra package {src} is gone; building the copy uros made of it, "
                    f"{found.relative_to(self.root)}"
                )
                continue
            name = check_extra_package(src, f"{self.root / CONFIG}: extra_packages")
            changed = sync_tree(src, self.extra_dir / name)
            if changed:
                console.info(f"extra package {name}: {changed} file(s) updated from {src}")


# What colcon and CMake cannot build in. colcon's generated environment scripts source paths in
# double quotes (colcon_core/shell/template/command_prefix.sh.em: . "<prefix>/share/<pkg>/package.sh"),
# where the shell expands '$' and '`' and ends at '"'; CMake writes folder paths unescaped into
# files it reads back (CMakeFiles/<version>/CMakeSystem.cmake), where '\' and ';' break them.
# Spaces, "'", '#', parentheses and '=' were built through: tests/integration/test_escaping_build.py.
_FOLDER_UNUSABLE = re.compile(r'[$`"\\;\x00-\x1f\x7f]')


def check_build_folder(root: Path, flag: str) -> None:
    """A workspace's folder is where colcon and CMake build: refuse a path they cannot use."""
    bad = _FOLDER_UNUSABLE.search(str(root))
    if bad is not None:
        raise ConfigError(
            f"{flag} {root}: colcon and CMake cannot build in a folder whose path holds {bad.group(0)!r}",
            "rename or move the folder (spaces and ' are fine)",
        )


# ---------------------------------------------------------------------------------------------
# target keys, locks, generated files, outputs


# One folder name: .uros/targets/<key> and build/<key>. Never '.', '..' or hidden, never a path.
_KEY = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


def target_key(name: str, where: str = "--toolchain") -> str:
    """The folder name of a target: its profile's name (an identifier already), or the stem of the
    user's toolchain file with anything but letters, digits, '.', '_' and '-' made '_'."""
    key = re.sub(r"[^A-Za-z0-9_.-]", "_", name)
    if not _KEY.fullmatch(key):
        raise ConfigError(
            f"{where}: {name!r} cannot name a target folder (it must start with a letter or digit)",
            "rename the file, e.g. my-board.cmake",
        )
    return key


def _target_folder(base: Path, key: str) -> Path:
    """``base/key``, checked to be one folder directly inside ``base``: whatever made ``key``, the
    trees and outputs of a target never land on the workspace or outside it."""
    path = base / key
    if not _KEY.fullmatch(key) or path.parent != base:
        raise ConfigError(f"{key!r} cannot name a target folder", "name targets with letters, digits, '.-_'")
    return path


def workspace_of_output(out: Path, key: str) -> Workspace | None:
    """The workspace an output was built in: <ws>/build/<key> beside <ws>/.uros/targets/<key>."""
    if out.parent.name != "build":
        return None
    ws = Workspace(out.parent.parent)
    return ws if ws.target_dir(key).is_dir() else None


def tree_bytes(path: Path) -> int:
    """Bytes of the files under ``path`` (links counted as links, not followed)."""
    if path.is_symlink() or path.is_file():
        return path.lstat().st_size
    total = 0
    for dirpath, _dirnames, filenames in os.walk(path):
        total += sum(os.lstat(os.path.join(dirpath, name)).st_size for name in filenames)
    return total


def nearest_existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_folder_target(path: Path, flag: str) -> None:
    """A folder uros will create or fill: it, or the nearest of its parents that exists, must
    be a folder, not a file (else a traceback from mkdir after the work is done)."""
    found = nearest_existing(path)
    if found.exists() and not found.is_dir():
        what = "is a file" if found == path else f"is inside {found}, which is a file"
        raise ConfigError(f"{flag} {path}: {what}", "pass a folder (it is created if missing)")


def check_file_target(path: Path, flag: str) -> None:
    """A file uros will write: not a folder, and the nearest existing parent is a folder."""
    if path.is_dir():
        raise ConfigError(f"{flag} {path}: is a folder", f"pass a file name, e.g. {path / 'out.txt'}")
    found = nearest_existing(path.parent)
    if found.exists() and not found.is_dir():
        raise ConfigError(f"{flag} {path}: {found} is a file, not a folder", "pass a path in a folder")
