"""Find a target compiler that is not on PATH: the profile's ``compiler_search`` folders (pure).

ESP-IDF's ``install.sh`` puts Espressif's compilers under ``$IDF_TOOLS_PATH`` (default
``~/.espressif``) in ``tools/<tool>/<version>/<tool>/bin`` and only ``export.sh`` puts them on
PATH (https://docs.espressif.com/projects/esp-idf/en/stable/esp32s3/api-guides/tools/idf-tools.html).
Several versions may sit side by side: the one ``$IDF_PATH/tools/tools.json`` names (the IDF
checkout in use) wins, then the newest GCC. Nothing here starts a process.
"""

from __future__ import annotations

import glob
import json
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from uros_build.target.profiles import TargetProfile


@dataclass(frozen=True)
class BinTools:
    """The target's binutils (as the toolchain names them): what merges and reads its archives,
    and measures its firmware (`uros probe --app`)."""

    ar: str
    ranlib: str
    nm: str
    size: str = "size"


def bintools_beside(compiler_path: str | None) -> BinTools:
    """The binutils beside a GNU compiler (``.../arm-none-eabi-gcc`` -> ``.../arm-none-eabi-size``:
    the host's read only the host's object formats on most distributions), else the host's."""
    if compiler_path is not None and compiler_path.endswith("gcc"):
        prefix = compiler_path[: -len("gcc")]
        return BinTools(ar=prefix + "ar", ranlib=prefix + "ranlib", nm=prefix + "nm", size=prefix + "size")
    return BinTools("ar", "ranlib", "nm")


def search_roots(env: Mapping[str, str], home: Path) -> dict[str, str | None]:
    """The values of the placeholders compiler_search patterns may use."""
    return {
        "{IDF_TOOLS_PATH}": env.get("IDF_TOOLS_PATH") or str(home / ".espressif"),
        "{IDF_PATH}": env.get("IDF_PATH") or None,
    }


def expand(pattern: str, env: Mapping[str, str], home: Path) -> str | None:
    """A glob with its placeholders and ~ replaced; None when a placeholder has no value."""
    for placeholder, value in search_roots(env, home).items():
        if placeholder in pattern:
            if value is None:
                return None
            pattern = pattern.replace(placeholder, value.rstrip("/"))
    if pattern.startswith("~/"):
        pattern = str(home / pattern[2:])
    return pattern


def pinned_versions(idf_path: str | None) -> set[str]:
    """Toolchain versions the ESP-IDF checkout at ``idf_path`` asks for (its tools/tools.json)."""
    if not idf_path:
        return set()
    try:
        data = json.loads((Path(idf_path) / "tools" / "tools.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    tools = data.get("tools", []) if isinstance(data, dict) else []
    return {
        str(version.get("name"))
        for tool in tools
        if isinstance(tool, dict)
        for version in tool.get("versions", [])
        if isinstance(version, dict)
    }


def version_key(name: str) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Order ESP toolchain folder names by GCC version, then by the rest of their numbers:
    esp-2021r2-patch5-8.4.0 < esp-2022r1-11.2.0 < esp-12.2.0_20230208 < esp-14.2.0_20241119."""
    gcc = re.findall(r"(\d+)\.(\d+)\.(\d+)", name)
    numbers = tuple(int(n) for n in re.findall(r"\d+", name))
    return (tuple(int(x) for x in gcc[-1]) if gcc else (), numbers)


def _wildcard_part(path: str, pattern: str) -> str:
    """The path component the pattern's first wildcard matched (the version folder)."""
    parts, pattern_parts = Path(path).parts, Path(pattern).parts
    for part, pat in zip(parts, pattern_parts, strict=False):
        if any(c in pat for c in "*?["):
            return part
    return path


def search_compiler(profile: TargetProfile, env: Mapping[str, str], home: Path) -> Path | None:
    """The folder holding ``<prefix>gcc`` per the profile's compiler_search, or None."""
    gcc = profile.tool("gcc")
    pinned = pinned_versions(env.get("IDF_PATH"))
    for raw in profile.compiler_search:
        pattern = expand(raw, env, home)
        if pattern is None:
            continue
        found = [d for d in glob.glob(pattern) if os.access(Path(d) / gcc, os.X_OK)]
        if not found:
            continue

        def rank(d: str, pattern: str = pattern) -> tuple[bool, tuple[tuple[int, ...], tuple[int, ...]]]:
            version = _wildcard_part(d, pattern)
            return (version in pinned, version_key(version))

        return Path(max(found, key=rank))
    return None


def searched_places(profile: TargetProfile, env: Mapping[str, str], home: Path) -> list[str]:
    """For the error message: where the compiler was looked for besides PATH."""
    return [p for p in (expand(raw, env, home) for raw in profile.compiler_search) if p]
