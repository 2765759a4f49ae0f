"""`uros interface new`: an interface package from .msg/.srv files."""

from __future__ import annotations

from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError
from uros_build.sources import interfaces
from uros_build.sources.workspace import check_folder_target


def interface_new(name: str, msgs: list[Path], srvs: list[Path], output: Path | None, force: bool) -> Path:
    files = [interfaces.read_interface(p, "msg") for p in msgs] + [
        interfaces.read_interface(p, "srv") for p in srvs
    ]
    texts = interfaces.package_files(name, files)
    dest = (output or Path(name)).resolve()
    check_folder_target(dest, "--output")
    if dest.exists() and any(dest.iterdir()) and not force:
        raise ConfigError(f"interface new: {dest} already exists", "choose another --output, or pass --force")
    for rel, text in texts.items():
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        (dest / rel).write_text(text, encoding="utf-8")
    console.step(f"wrote interface package {name} in {dest}; add it with `uros add-package {dest}`")
    return dest
