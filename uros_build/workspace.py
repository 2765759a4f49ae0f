"""A firmware workspace on disk and where uros keeps things in it.

    <workspace>/
      mcu_ws/            sources colcon builds for the MCU (or the packages sit in <workspace> itself)
      dev_ws/            host tools workspace (real micro-ROS only, `uros create-firmware`)
      build/<target>/    outputs: libmicroros.a, include/, CMake package, build-info.json
      .uros/targets/<target>/{build,install,log}   colcon's trees, kept between runs per target
      .uros/log/         one log per uros run

Keeping colcon's trees per target is what makes a second build incremental (micro_ros_setup's
build.sh wipes build/install/log every time) and what lets two targets share one workspace.
"""

from __future__ import annotations

import fcntl
import os
import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from uros_build.errors import ConfigError

_IGNORE_NOTE = "uros: colcon must not look for packages here\n"


@dataclass(frozen=True)
class Workspace:
    root: Path

    @classmethod
    def open(cls, path: Path, flag: str = "--workspace") -> Workspace:
        root = path.resolve()
        if not root.is_dir():
            raise ConfigError(
                f"{flag} {path}: no such folder",
                "pass a colcon workspace, or create one with `uros create-firmware generate_lib`",
            )
        ws = cls(root)
        if not ws.has_packages():
            raise ConfigError(
                f"{flag} {path}: no package.xml found under {ws.source_dir}",
                "a workspace holds packages (folders with package.xml) in mcu_ws/ or in the folder itself",
            )
        return ws

    @property
    def source_dir(self) -> Path:
        mcu = self.root / "mcu_ws"
        return mcu if mcu.is_dir() else self.root

    @property
    def state_dir(self) -> Path:
        return self.root / ".uros"

    @property
    def log_dir(self) -> Path:
        return self.state_dir / "log"

    def target_dir(self, key: str) -> Path:
        return self.state_dir / "targets" / key

    def default_output(self, key: str) -> Path:
        return self.root / "build" / key

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
        for folder in (self.state_dir, self.root / "build"):
            folder.mkdir(parents=True, exist_ok=True)
            marker = folder / "COLCON_IGNORE"
            if not marker.exists():
                marker.write_text(_IGNORE_NOTE, encoding="utf-8")

    def new_log(self, command: str, key: str = "") -> Path:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        name = "-".join(x for x in (stamp, command, key) if x)
        return self.log_dir / f"{name}-{os.getpid()}.log"


def target_key(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


@contextmanager
def locked(folder: Path) -> Iterator[None]:
    """One build per target tree at a time: a second `uros build` waits, then reuses the trees."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / ".lock").open("w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def write_if_changed(path: Path, text: str) -> bool:
    """Write only when the content differs, so CMake sees no change and rebuilds nothing."""
    if path.is_file() and path.read_text(encoding="utf-8") == text:
        return False
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return True
