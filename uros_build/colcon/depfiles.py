"""The headers a build read from outside the workspace, from the compiler's own dependency output
as ninja keeps it (`ninja -t deps`), and whether their content changed since.

A build's fingerprint covers the workspace's files; the C library's headers, an ESP-IDF
component's, and a folder named by `-I`/`-include` in a profile's flags live elsewhere. A package
upgrade or an edit restored with an old mtime changes them with no newer mtime than the objects,
so ninja would not recompile: uros compares their content and drops the build folders of the
packages that read a changed one.

Pure functions over text and a reader of files; starts no process.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping
from pathlib import Path

RECORD = "outside-headers.json"


def parse_ninja_deps(text: str) -> set[str]:
    """Every dependency path in ``ninja -t deps`` output: indented lines under each
    ``<target>: #deps N, deps mtime M (VALID)`` line (https://ninja-build.org/manual.html#_extra_tools)."""
    return {line.strip() for line in text.splitlines() if line.startswith("    ") and line.strip()}


def outside(paths: Iterable[str], roots: Iterable[Path]) -> list[str]:
    """The absolute paths not under any of ``roots`` (relative ones are inside the build folder)."""
    tops = [str(r).rstrip("/") + "/" for r in roots]
    return sorted(p for p in paths if p.startswith("/") and not any(p.startswith(t) for t in tops))


def content(path: str) -> str:
    """sha256 of a file, or "missing"."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return "missing"


def snapshot(per_package: Mapping[str, Iterable[str]]) -> dict[str, dict[str, str]]:
    """package -> {header -> sha256}; a header read by several packages is hashed once."""
    cache: dict[str, str] = {}
    out: dict[str, dict[str, str]] = {}
    for package, paths in sorted(per_package.items()):
        out[package] = {p: cache.setdefault(p, content(p)) for p in sorted(paths)}
    return out


def read_record(path: Path) -> dict[str, dict[str, str]]:
    """The last build's record (empty when there is none or it is unreadable: a cache)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return {str(k): {str(p): str(s) for p, s in v.items()} for k, v in data["packages"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def record_text(snap: Mapping[str, Mapping[str, str]]) -> str:
    data = {"generated_by": "uros build", "packages": {k: dict(v) for k, v in snap.items()}}
    return json.dumps(data, indent=1, sort_keys=True) + "\n"


def changed_packages(record: Mapping[str, Mapping[str, str]]) -> tuple[list[str], str]:
    """(packages that read a header whose content changed since the record, a digest of every
    recorded header's current content for the build's fingerprint)."""
    cache: dict[str, str] = {}
    changed = []
    h = hashlib.sha256()
    for package, headers in sorted(record.items()):
        stale = False
        for path, sha in sorted(headers.items()):
            now = cache.setdefault(path, content(path))
            h.update(f"{package}\0{path}\0{now}\n".encode("utf-8", "surrogateescape"))
            stale = stale or now != sha
        if stale:
            changed.append(package)
    return changed, h.hexdigest()
