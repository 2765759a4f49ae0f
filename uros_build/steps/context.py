"""The one frozen context every step of a target's build is handed (model: colcon-core's
TaskContext): made once the run is open and the host's facts are known, unchanged to the end.
A step reads it, with what earlier steps returned, and returns a frozen result of its own."""

from __future__ import annotations

from dataclasses import dataclass

from uros_build.colcon.hosttools import HostFacts
from uros_build.config.buildplan import BuildPlan
from uros_build.proc import Runner
from uros_build.steps.target_kind import TargetKind


@dataclass(frozen=True)
class Context:
    plan: BuildPlan  # what the user asked, checked
    runner: Runner  # this run's processes and its log
    facts: HostFacts  # the host's and the target's tools
    kind: TargetKind  # what the target is (a profile's, the user's toolchain file, ESP-IDF's), chosen once
