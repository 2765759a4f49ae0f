"""The probe's report kept beside its run: ``report.json`` in the probe's work folder of an output,
written by `uros probe` after every run (passed or not) and read by `uros size`, which counts the
heap and stack the firmware measured against a chip's RAM.

A report belongs to one library: it records the sha256 of the libmicroros.a it ran (and of the
firmware's map file, which `uros size` reads as what a firmware links of the library); a library
built since, or a map file another run replaced, is not that run's and is never counted.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build.colcon.fingerprint import digest
from uros_build.files import write_atomic
from uros_build.proc import user_log_dir
from uros_build.sources.workspace import workspace_of_output

REPORT = "report.json"
# where the probe firmware's build writes its map (templates/probe/CMakeLists.txt: -Wl,-Map=uros_probe.map)
MAP = Path("build") / "uros_probe.map"


def probe_base(out: Path, target: str) -> Path:
    """Where the probes of an output keep their work: the workspace's .uros/, else the user's uros
    folder for an output outside a workspace."""
    ws = workspace_of_output(out, target)
    return ws.state_dir if ws is not None else user_log_dir().parent


def probe_work(base: Path, target: str, out: Path) -> Path:
    """The work folder of the probes of output ``out`` (resolved) of ``target``."""
    return base / "probe" / f"{target}-{digest(str(out))[:10]}"


def _sha256(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def write_report(work: Path, report: Mapping[str, Any], library_sha256: str) -> Path:
    """``report`` (the probe's result as JSON data) with the library's and the map file's sha256,
    as ``work/report.json`` (sorted keys, written whole or not at all)."""
    data = {**report, "library_sha256": library_sha256, "map_sha256": _sha256(work / MAP)}
    path = work / REPORT
    write_atomic(path, json.dumps(data, indent=2, sort_keys=True) + "\n")
    return path


@dataclass(frozen=True)
class Measured:
    """What a passed probe run of this very library measured."""

    heap: int
    stack: int
    report: str  # the report.json it came from
    map_file: str | None  # the probe firmware's map file, when it is still that run's


def measured(
    report_text: str | None, library_sha256: str, map_sha256: str | None, work: Path
) -> Measured | str:
    """A passed run's heap and stack for the library whose sha256 is ``library_sha256``, or why there
    are none (pure: ``report_text`` is work/report.json's text, ``map_sha256`` that of the map file
    now in ``work``)."""
    if report_text is None:
        return "not measured: run uros probe"
    try:
        data = json.loads(report_text)
    except ValueError:
        return "not measured: the probe's report.json is not JSON (run uros probe)"
    if not isinstance(data, dict) or data.get("library_sha256") != library_sha256:
        return "not measured for this library: the last probe ran another build of it (run uros probe)"
    heap, stack = data.get("heap_bytes"), data.get("stack_bytes")
    # `passed` (uros probe's stages judged too); a report of before it: the firmware's status
    if (
        not data.get("passed", data.get("status") == 0)
        or not isinstance(heap, int)
        or not isinstance(stack, int)
    ):
        verdict = data.get("verdict") or "no verdict"
        return f"not measured: the last probe did not pass ({verdict}; run uros probe)"
    same_map = map_sha256 is not None and data.get("map_sha256") == map_sha256
    return Measured(heap, stack, str(work / REPORT), str(work / MAP) if same_map else None)


def read_measured(out: Path, target: str, library_sha256: str) -> Measured | str:
    """The heap and stack the last passed `uros probe` of output ``out`` measured, or why none."""
    work = probe_work(probe_base(out, target), target, out)
    try:
        text: str | None = (work / REPORT).read_text(encoding="utf-8")
    except OSError:
        text = None
    return measured(text, library_sha256, _sha256(work / MAP), work)
