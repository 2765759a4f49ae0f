"""Output folders: what uros wrote there and the guard that keeps everything else (the swap that
puts a new output in place is swap.py).

An output (default ``<workspace>/build/<target>``) holds what `uros build` wrote: libmicroros.a,
include/, the CMake package files, toolchain.cmake, build-info.json, and ``.uros-output``, a
marker naming those entries. The marker is how uros tells its own output from a folder that merely
holds a file called build-info.json, and which entries are its to replace: a user's files beside
them are kept.

This module starts no processes.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Collection
from pathlib import Path

from uros_build import __version__
from uros_build.colcon.fingerprint import file_sha256
from uros_build.defaults import BUILD_INFO
from uros_build.errors import ConfigError
from uros_build.output.buildinfo import parse_build_info
from uros_build.sources.workspace import Workspace, nearest_existing
from uros_build.sources.wsfiles import CONFIG, DEV_WS, LOCK, MCU_WS, STATE

MARKER = ".uros-output"
JOURNAL = ".uros-swap"  # a swap of the entries inside an output folder (swap.py)
# uros's own temporary names inside an output folder (a swap of its entries): never the user's
TEMP_INSIDE = re.compile(r"^\.uros-(staging|new|old)-(\d+)$")
# Outputs of uros before the marker existed: these names, recognised by build-info.json.
_LEGACY_NAMES = (
    "libmicroros.a",
    "include",
    "toolchain.cmake",
    BUILD_INFO,
    "microrosConfig.cmake",
    "microrosConfigVersion.cmake",
    "microros.cmake",
)
_OWN_NAMES = frozenset([*_LEGACY_NAMES, MARKER])
# What an output folder must never be, or hold, even with --force: a workspace or its sources.
_WORKSPACE_SIGNS = (CONFIG, LOCK, STATE, MCU_WS, DEV_WS, "package.xml", "COLCON_IGNORE")
_SEARCH_DEPTH = 3
_SEARCH_LIMIT = 20000


# ---------------------------------------------------------------------------------------------
# the marker


def marker_text(target: str, names: Collection[str]) -> str:
    data = {"generated_by": f"uros {__version__} build", "target": target, "files": sorted(names)}
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def parse_marker(text: str) -> frozenset[str] | None:
    """The entries a marker names, or None when it is not one uros wrote (pure)."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if not isinstance(data, dict) or not str(data.get("generated_by", "")).startswith("uros "):
        return None
    files = data.get("files")
    if not isinstance(files, list) or not all(_entry_name(f) for f in files):
        return None
    return frozenset([*files, MARKER])


def _entry_name(name: object) -> bool:
    return isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\0" not in name


def entries_of(folder: Path) -> list[str]:
    """What uros writes into an output (build-info.json's folder, or an assembled one, into which the
    delivery writes build-info.json later: it is named either way), its marker left out."""
    return sorted({p.name for p in folder.iterdir() if p.name != MARKER} | {BUILD_INFO})


def owned_entries(out: Path) -> frozenset[str] | None:
    """The entries of ``out`` that uros wrote, or None when ``out`` is not a uros output.

    Its marker says so; an output of uros before the marker is one whose build-info.json was
    written by uros and records the sha256 of the libmicroros.a beside it (a file that is merely
    called build-info.json is not enough)."""
    try:
        return parse_marker((out / MARKER).read_text(encoding="utf-8"))
    except FileNotFoundError:
        pass
    except (OSError, UnicodeDecodeError):
        return None
    try:
        info = parse_build_info(json.loads((out / BUILD_INFO).read_text(encoding="utf-8")), str(out))
        if info.generated_by.startswith("uros ") and info.library.sha256 == file_sha256(
            out / "libmicroros.a"
        ):
            return frozenset(n for n in _LEGACY_NAMES if (out / n).exists())
    except (OSError, ValueError, ConfigError):
        pass
    return None


def entries(folder: Path) -> set[str]:
    """The entries of a folder that are not uros's temporary ones."""
    claimed = f"{JOURNAL}.claimed-"  # a swap's journal that a run carries out (swap.finish_swaps)
    return {
        p.name
        for p in folder.iterdir()
        if not TEMP_INSIDE.match(p.name) and p.name != JOURNAL and not p.name.startswith(claimed)
    }


def write_marker(out: Path, target: str, names: Collection[str]) -> None:
    (out / MARKER).write_text(marker_text(target, {*names} - {MARKER}), encoding="utf-8")


def add_to_marker(out: Path, names: Collection[str]) -> None:
    """Record more entries uros wrote into an existing output (`uros export` in place)."""
    owned = owned_entries(out) or frozenset()
    try:
        target = str(json.loads((out / MARKER).read_text(encoding="utf-8")).get("target", ""))
    except (OSError, ValueError, AttributeError):
        target = ""
    write_marker(out, target, {*owned, *names})


# ---------------------------------------------------------------------------------------------
# the guard


def _workspace_sign(folder: Path) -> Path | None:
    """A file or folder below ``folder`` (a few levels deep) showing sources or a workspace."""
    seen = 0
    for dirpath, dirnames, filenames in os.walk(folder):
        depth = len(Path(dirpath).relative_to(folder).parts)
        for name in sorted([*filenames, *dirnames]):
            if name in _WORKSPACE_SIGNS:
                return Path(dirpath) / name
        seen += len(filenames) + len(dirnames)
        if depth >= _SEARCH_DEPTH or seen > _SEARCH_LIMIT:
            dirnames[:] = []
    return None


def _other_output(folder: Path) -> Path | None:
    """A subfolder of ``folder`` that is a uros output (another target's)."""
    with contextlib.suppress(OSError):
        for sub in sorted(folder.iterdir()):
            if sub.is_dir() and not sub.is_symlink() and owned_entries(sub) is not None:
                return sub
    return None


def mount_points(mountinfo: str) -> set[str]:
    """The mount points listed in /proc/self/mountinfo (field 5, with spaces and the like written
    as octal escapes: https://man7.org/linux/man-pages/man5/proc_pid_mountinfo.5.html) (pure)."""
    points = set()
    for line in mountinfo.splitlines():
        fields = line.split(" ")
        if len(fields) > 4:
            points.add(re.sub(r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)), fields[4]))
    return points


def is_mount_point(folder: Path) -> bool:
    """Whether ``folder`` is a mount point; a bind mount of a folder of the same file system too,
    which os.path.ismount misses (it compares devices), and which rename(2) refuses all the same."""
    if os.path.ismount(folder):
        return True
    try:
        return str(folder) in mount_points(Path("/proc/self/mountinfo").read_text(encoding="utf-8"))
    except OSError:
        return False


def _writable(folder: Path) -> bool:
    # access(2) answers EROFS for a read-only mount, for root too
    return os.access(folder, os.W_OK | os.X_OK)


def output_target(out: Path) -> str | None:
    """The target whose output ``out`` is, from its marker (None: no marker, or one that names none)."""
    try:
        target = json.loads((out / MARKER).read_text(encoding="utf-8")).get("target")
    except (OSError, ValueError, AttributeError):
        return None
    return str(target) if target else None


def check_output_owner(out: Path, target: str, force: bool, flag: str = "--output") -> None:
    """An output belongs to one target: building another target into it would replace that
    target's library without a word (issue 16). Checked when the build is planned and again, under
    the output's lock, just before the swap (another build may have written it meanwhile)."""
    owner = output_target(out) if out.is_dir() else None
    if owner is not None and owner != target and not force:
        raise ConfigError(
            f"{flag} {out}: is the output of target {owner}, not {target}",
            f"choose another folder (the default is <workspace>/build/{target}), or pass --force to "
            f"replace {owner}'s output with {target}'s",
        )


def check_output_dir(
    out: Path, force: bool, flag: str = "--output", workspace: Path | None = None, offers_force: bool = True
) -> None:
    """Refuse, before anything is built, an output folder uros could not write or would have to
    take from the user. ``out`` is resolved. Never, even with --force: the workspace, a folder
    holding it, its sources or other targets' outputs. Without --force: a folder holding files uros
    did not write (with it, uros writes its own entries there and keeps the rest)."""
    fix = "choose a new or empty folder (the default is <workspace>/build/<target>)"
    if workspace is not None:
        ws = workspace.resolve()
        if ws == out or ws.is_relative_to(out):
            raise ConfigError(f"{flag} {out}: is the workspace {ws} or holds it", fix)
        for part in (STATE, MCU_WS, DEV_WS):
            if out.is_relative_to(ws / part):
                raise ConfigError(f"{flag} {out}: is inside the workspace's {part}/", fix)
        for parent in out.parents:
            if (parent / "package.xml").is_file():
                raise ConfigError(f"{flag} {out}: is inside the package {parent}", fix)
            if parent == ws:
                break
    if out.is_dir() and not out.is_symlink():
        owned = owned_entries(out)
        if owned is None and (out / JOURNAL).is_file():
            owned = frozenset()  # a swap uros left half-done: the build recovers it first
        if owned is None and entries(out):
            other = _other_output(out)
            if other is not None:
                raise ConfigError(f"{flag} {out}: holds the uros output {other.name}/ of another target", fix)
            sign = _workspace_sign(out)
            if sign is not None:
                raise ConfigError(
                    f"{flag} {out}: holds {sign.relative_to(out)}, so it is a workspace or its sources; "
                    "uros never writes there",
                    fix,
                )
            if not force:
                foreign = sorted(entries(out))
                shown = ", ".join(foreign[:4]) + (", ..." if len(foreign) > 4 else "")
                raise ConfigError(
                    f"{flag} {out}: the folder holds files uros did not write ({shown})",
                    f"{fix}, or pass --force to write uros's files into it (libmicroros.a, include/, "
                    "the CMake files, toolchain.cmake, build-info.json) and keep the others"
                    if offers_force
                    else "choose a new or empty folder",  # `uros export` has no --force to offer
                )
        # Replaced with one rename where uros can write beside it; entry by entry where it cannot,
        # where it is a mount point, or where the user's files stay in it.
        mount = is_mount_point(out)
        keeps = not entries(out) <= _OWN_NAMES | (owned or frozenset())
        if (mount or keeps or not _writable(out.parent)) and not _writable(out):
            why = (
                "it is a mount point, so uros replaces what is inside it"
                if mount
                else "it holds files uros keeps, so uros replaces what is inside it"
                if keeps
                else f"nor in {out.parent}"
            )
            raise ConfigError(
                f"{flag} {out}: cannot write in this folder ({why})",
                "make it writable (its permissions, or a read-write mount), or choose another folder",
            )
    elif out.exists() or out.is_symlink():
        raise ConfigError(f"{flag} {out}: is not a folder", fix)
    else:
        parent = nearest_existing(out.parent)
        if not _writable(parent):
            raise ConfigError(f"{flag} {out}: cannot create it (cannot write in {parent})", fix)


def staging_dir(out: Path) -> Path:
    """Where the new output is built: beside ``out`` (so that it can replace it with one rename),
    or inside it where uros cannot write beside it or ``out`` is a mount point."""
    if out.is_dir() and (is_mount_point(out) or not _writable(out.parent)):
        return out / f".uros-staging-{os.getpid()}"
    return out.with_name(f".{out.name}.staging-{os.getpid()}")


def is_uros_output(folder: Path) -> bool:
    """A folder `uros build` wrote (its marker, or an older output's build-info.json that
    vouches for the library beside it)."""
    return folder.is_dir() and not folder.is_symlink() and owned_entries(folder) is not None


def target_keys(ws: Workspace) -> list[str]:
    """The targets uros has trees or outputs of in ``ws`` (.uros/targets/<key>, build/<key>)."""
    keys = set(ws.tree_keys())
    outputs = ws.outputs_dir
    if outputs.is_dir():
        # not the hidden folders of a swap beside an output (.cortex-m7.old-PID): never a target's
        keys |= {p.name for p in outputs.iterdir() if not p.name.startswith(".") and is_uros_output(p)}
    return sorted(keys)
