"""The probe's report kept beside its run: one per variant of the run (bare metal, FreeRTOS) in the
probe's work folder of an output (``report.json``, ``report-freertos.json``), written by `uros
probe` after every run (passed or not) and read by `uros size`, which counts the heap and stack the
firmware measured against a chip's RAM.

A report belongs to one library: it records the sha256 of the library file's own bytes as the probe
ran it (not the one its build-info.json records: a file replaced since is another library), and a
copy of the firmware's map file beside it (``report.map``, ``report-freertos.map``: the firmware's
build folder is shared by the variants), which `uros size` reads as what a firmware links of the
library. A library whose bytes differ, a run of the other variant (a FreeRTOS run's heap is the
kernel's, not newlib's), or a map copy another run replaced is not counted.

A report is a file anyone can put there, so it is read as the team cache reads its entries: only a
regular file, bounded (files.read_regular: a FIFO never hangs, /dev/zero is never read), and every
value typed and ranged (a count is a whole number, not a boolean, 0 or more and within a 32-bit
address space; ``passed`` is the boolean true). A report that fails is "not measured", saying why.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build.colcon.fingerprint import digest
from uros_build.files import read_regular, reason, sha256_regular, write_atomic
from uros_build.loader import is_count, is_sha256
from uros_build.proc import user_log_dir
from uros_build.sources.workspace import workspace_of_output

REPORT = "report.json"  # the bare-metal run's; another variant's is report-<rtos>.json
# where the probe firmware's build writes its map (templates/probe/CMakeLists.txt: -Wl,-Map=uros_probe.map)
MAP = Path("build") / "uros_probe.map"
MAX_REPORT_BYTES = 1024 * 1024  # a report is ~2 KB
MAX_MAP_BYTES = 256 * 1024 * 1024  # the probe firmware's map is ~2 MB
MAX_LIBRARY_BYTES = 1024 * 1024 * 1024  # as the team cache bounds a library (output/team_cache.py)
MAX_MEASURED = 2**32  # heap or stack bytes: a 32-bit address space holds no more
RTOSES = ("freertos",)  # the variants besides bare metal (the probe's --freertos)


def probe_base(out: Path, target: str) -> Path:
    """Where the probes of an output keep their work: the workspace's .uros/, else the user's uros
    folder for an output outside a workspace."""
    ws = workspace_of_output(out, target)
    return ws.state_dir if ws is not None else user_log_dir().parent


def probe_work(base: Path, target: str, out: Path) -> Path:
    """The work folder of the probes of output ``out`` (resolved) of ``target``."""
    return base / "probe" / f"{target}-{digest(str(out))[:10]}"


def report_name(rtos: str | None) -> str:
    """The report of a run on ``rtos`` (None: bare metal)."""
    return REPORT if rtos is None else f"report-{rtos}.json"


def map_name(rtos: str | None) -> str:
    """The copy of a run's map file, beside its report."""
    return report_name(rtos).removesuffix(".json") + ".map"


def variant(rtos: str | None) -> str:
    """What a run on ``rtos`` is called in a line: "bare metal", "FreeRTOS"."""
    return "bare metal" if rtos is None else {"freertos": "FreeRTOS"}.get(rtos, rtos)


def library_sha256(path: Path) -> str | None:
    """The sha256 of the library file's own bytes (a regular file, bounded), or None when it cannot
    be read."""
    try:
        return sha256_regular(path, MAX_LIBRARY_BYTES)
    except (OSError, ValueError):
        return None


def write_report(work: Path, report: Mapping[str, Any], library: Path) -> Path:
    """``report`` (the probe's result as JSON data; its ``rtos`` names the variant) with the sha256
    of ``library``'s bytes and a copy of the firmware's map file (with its sha256), as
    ``work/report[-<rtos>].json`` (sorted keys, written whole or not at all)."""
    rtos = report.get("rtos")
    rtos = rtos if isinstance(rtos, str) else None
    copy = work / map_name(rtos)
    try:
        map_bytes: bytes | None = read_regular(work / MAP, MAX_MAP_BYTES)
    except (OSError, ValueError):
        map_bytes = None
    if map_bytes is not None:
        write_atomic(copy, map_bytes)
    else:
        copy.unlink(missing_ok=True)
    data = {
        **report,
        "library_sha256": library_sha256(library),
        "map_sha256": sha256_of(map_bytes) if map_bytes is not None else None,
    }
    path = work / report_name(rtos)
    write_atomic(path, json.dumps(data, indent=2, sort_keys=True) + "\n")
    return path


def sha256_of(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@dataclass(frozen=True)
class Measured:
    """What a passed probe run of this very library measured, and which run it was."""

    heap: int
    stack: int
    report: str  # the report.json it came from
    map_file: str | None  # the copy of that run's map file, when it is still that run's
    rtos: str | None = None  # the run's variant (None: bare metal)
    machine: str = ""  # the QEMU machine it ran on

    @property
    def run(self) -> str:
        """Which run the figures come from, for a line: "uros probe, bare metal in QEMU mps2-an500"."""
        where = f" in QEMU {self.machine}" if self.machine else ""
        return f"uros probe, {variant(self.rtos)}{where}"


def _shown(value: object, limit: int = 80) -> str:
    """A value from a report as a line may show it: printable characters only, cut to ``limit``."""
    text = value if isinstance(value, str) else repr(value)
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _count(value: object) -> int | None:
    """A byte count from a report: a whole number (JSON's true is no count), 0 to MAX_MEASURED."""
    return value if type(value) is int and is_count(value, MAX_MEASURED) else None


def measured(
    report: bytes | None,
    library: str | None,
    map_sha256: str | None,
    work: Path,
    rtos: str | None = None,
) -> Measured | str:
    """A passed run's heap and stack for the library whose bytes' sha256 is ``library``, on
    ``rtos`` (None: bare metal), or why there are none (pure: ``report`` is the variant's report's
    bytes, ``map_sha256`` that of its map copy now in ``work``)."""
    name = report_name(rtos)
    if report is None:
        return "not measured: run uros probe"
    try:
        data = json.loads(report.decode("utf-8"))
    except UnicodeDecodeError:
        return f"not measured: the probe's {name} is not UTF-8 text (run uros probe)"
    except (ValueError, RecursionError):
        return f"not measured: the probe's {name} is not JSON (run uros probe)"
    if not isinstance(data, dict):
        return f"not measured: the probe's {name} is not a report (run uros probe)"
    if library is None or not is_sha256(data.get("library_sha256")) or data["library_sha256"] != library:
        return "not measured for this library: the last probe ran another build of it (run uros probe)"
    ran_on = data.get("rtos")
    if ran_on != rtos:
        return (
            f"not measured on {variant(rtos)}: the probe's {name} is of a run on "
            f"{variant(ran_on) if isinstance(ran_on, str) else _shown(ran_on)} (run uros probe)"
        )
    # `passed` (uros probe's stages judged too): the boolean true only; a report of before it: the
    # firmware's status 0 (a whole number, not false)
    passed = (
        data["passed"] is True
        if "passed" in data
        else type(data.get("status")) is int and data["status"] == 0
    )
    if not passed:
        verdict = data.get("verdict")
        shown = _shown(verdict) if isinstance(verdict, str) and verdict else "no verdict"
        return f"not measured: the last probe did not pass ({shown}; run uros probe)"
    heap, stack = _count(data.get("heap_bytes")), _count(data.get("stack_bytes"))
    if heap is None or stack is None:
        key, value = (
            ("heap_bytes", data.get("heap_bytes"))
            if heap is None
            else ("stack_bytes", data.get("stack_bytes"))
        )
        if value is None:
            return "not measured: the last probe's firmware reported no heap and stack (run uros probe)"
        return (
            f"not measured: the probe's {name} has {key} {_shown(json.dumps(value), 24)}, not a byte count "
            f"(0 to {MAX_MEASURED:,}) (run uros probe)"
        )
    same_map = map_sha256 is not None and data.get("map_sha256") == map_sha256
    machine = data.get("machine")
    return Measured(
        heap,
        stack,
        str(work / name),
        str(work / map_name(rtos)) if same_map else None,
        rtos,
        _shown(machine, 40) if isinstance(machine, str) else "",
    )


def _read(path: Path, limit: int) -> tuple[bytes | None, str | None]:
    """(the bytes of ``path``, None) or (None, why not: None when it is not there)."""
    try:
        return read_regular(path, limit), None
    except FileNotFoundError:
        return None, None
    except (OSError, ValueError) as exc:
        return None, reason(exc)


def read_measured(out: Path, target: str, library: str | None, rtos: str | None = None) -> Measured | str:
    """The heap and stack the last passed `uros probe` on ``rtos`` (None: bare metal) of output
    ``out`` measured of the library whose bytes' sha256 is ``library`` (:func:`library_sha256` of
    the file, never its build-info's record), or why none."""
    work = probe_work(probe_base(out, target), target, out)
    name = report_name(rtos)
    text, trouble = _read(work / name, MAX_REPORT_BYTES)
    if trouble is not None:
        return f"not measured: {work / name}: {trouble} (run uros probe)"
    if text is None:
        others = [variant(r) for r in (None, *RTOSES) if r != rtos and (work / report_name(r)).exists()]
        if others:
            return f"not measured on {variant(rtos)}: the probe ran only on {others[0]} (run uros probe)"
        return "not measured: run uros probe"
    map_bytes, _ = _read(work / map_name(rtos), MAX_MAP_BYTES)
    map_sha256 = sha256_of(map_bytes) if map_bytes is not None else None
    return measured(text, library, map_sha256, work, rtos)
