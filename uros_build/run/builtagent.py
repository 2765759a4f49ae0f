"""The agent `uros agent build` made, as the commands that use it find it: under the ROS 2
environment's root (``UROS_ROS2_VENV``), ``agent/current.json`` names the agent in use, a folder whose
``uros-agent.json`` (written last) records which program it is (``micro_ros_agent``, or
``MicroXRCEAgent`` and why), the sources' commits and the venv, and whose ``bin/uros-agent`` runs it
with its libraries. `uros probe`, `uros doctor` and `uros agent run` read it; run/agentbuild.py
writes it. Nothing here starts a process.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import loader
from uros_build.errors import ConfigError

AGENT_DIR = "agent"  # under the ROS 2 environment's root (UROS_ROS2_VENV)
CURRENT = "current.json"  # in AGENT_DIR: the agent in use
RECORD = "uros-agent.json"  # in an agent's folder, written last: the folder is complete
WRAPPER = "bin/uros-agent"  # what runs the agent: its libraries' paths set, then exec

XRCE, GRAPH, MSGS = "xrce_agent", "micro_ros_agent", "micro_ros_msgs"
PROGRAMS = {XRCE: "MicroXRCEAgent", GRAPH: "micro_ros_agent"}


@dataclass(frozen=True)
class BuiltAgent:
    folder: Path
    program: str  # micro_ros_agent or MicroXRCEAgent
    why: str  # why this program (micro_ros_agent's build failure, or the pin naming none)
    distro: str
    commits: dict[str, str]  # role -> commit
    venv: str
    seconds: float

    @property
    def run(self) -> Path:
        """The program to start (the wrapper, with its libraries' paths)."""
        return self.folder / WRAPPER

    def describe(self) -> str:
        commits = ", ".join(f"{r} {c[:12]}" for r, c in sorted(self.commits.items()))
        return f"{self.program} ({self.distro}: {commits}) in {self.folder}"


def parse_record(data: Any, source: str, folder: Path) -> BuiltAgent:
    top = loader.mapping(data, source, required=("program", "why", "distro", "commits", "venv", "seconds"))
    commits = loader.mapping(top["commits"], f"{source}: commits")
    program = loader.one_of(top, "program", source, tuple(PROGRAMS.values()), "MicroXRCEAgent")
    seconds = top["seconds"]
    if not isinstance(seconds, int | float):
        raise ConfigError(f"{source}: seconds: expected a number, got {seconds!r}")
    return BuiltAgent(
        folder=folder,
        program=program,
        why=loader.string(top, "why", source),
        distro=loader.string(top, "distro", source),
        commits={str(k): str(v) for k, v in commits.items()},
        venv=loader.string(top, "venv", source),
        seconds=float(seconds),
    )


def current_agent(root: Path) -> BuiltAgent | None:
    """The agent `uros agent build` last built under ``root`` (UROS_ROS2_VENV), or None: none built,
    or its folder gone or unfinished."""
    pointer = root / AGENT_DIR / CURRENT
    try:
        name = json.loads(pointer.read_text(encoding="utf-8"))["folder"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    folder = root / AGENT_DIR / str(name)
    record = folder / RECORD
    if not isinstance(name, str) or "/" in name or not record.is_file() or not (folder / WRAPPER).is_file():
        return None
    return parse_record(loader.load_json(record), str(record), folder)


def program_path(folder: Path, program: str) -> Path:
    """Where the program is installed in an agent's folder (pure): micro_ros_agent as ament
    installs it, MicroXRCEAgent in bin/."""
    return folder / "lib" / GRAPH / GRAPH if program == PROGRAMS[GRAPH] else folder / "bin" / PROGRAMS[XRCE]


def program_name(path: str, built: BuiltAgent | None) -> str:
    """Which agent a program path is (pure): the built one's program when it is that agent's
    wrapper, else the file's name (micro_ros_agent, MicroXRCEAgent, ...)."""
    return built.program if built is not None and Path(path) == built.run else Path(path).name
