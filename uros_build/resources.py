"""The only module that knows where the shipped data folders live.

In a wheel they are ``uros_build/_data/{toolchains,meta,templates}`` (see pyproject's
force-include); in a source checkout or an editable install they are the top-level folders
of the repository.
"""

from __future__ import annotations

from pathlib import Path

_PKG = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    for candidate in (_PKG / "_data" / name, _PKG.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"uros data folder {name!r} is missing from this installation")


def toolchains_dir() -> Path:
    return data_dir("toolchains")


def meta_dir() -> Path:
    return data_dir("meta")


def templates_dir() -> Path:
    return data_dir("templates")


def transports() -> tuple[str, ...]:
    """The XRCE-DDS transports uros knows: one colcon.meta fragment each in meta/transports/
    (the one list: profiles, uros.yaml, --transport and the toolchain all read it)."""
    return tuple(sorted(p.stem for p in (meta_dir() / "transports").glob("*.json")))
