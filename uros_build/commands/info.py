"""`uros info`: what a built library contains, from its output folder and the workspace it came
from: the ROS 2 types it offers, its packages with their source commits (uros.lock), the CMake
options in force (the target's colcon.meta), flags and sizes. micro_ros_stm32cubemx_utils ships a
hand-kept available_ros2_types file; this is the same, derived from what was built."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from uros_build import contents
from uros_build import meta as meta_mod
from uros_build import packages as packages_mod
from uros_build.buildinfo import BuildInfo, read_build_info
from uros_build.plan import resolve_output
from uros_build.workspace import LOCK, Lock, read_lock, workspace_of_output


def package_sources(
    built: tuple[str, ...], locations: dict[str, Path], root: Path, lock: Lock | None
) -> list[dict[str, str | None]]:
    """Each built package with the locked repository it sits in and that repository's commit
    (None for packages no lock lists: extra packages, a plain colcon workspace)."""
    rows: list[dict[str, str | None]] = []
    for name in built:
        repo = commit = None
        where = locations.get(name)
        if where is not None and lock is not None:
            rel = where.relative_to(root).as_posix() if where.is_relative_to(root) else ""
            for path, locked in lock.repositories.items():
                if rel == path or rel.startswith(path + "/"):
                    repo, commit = path, locked.commit
        rows.append({"name": name, "repository": repo, "commit": commit})
    return rows


def gather(out: Path) -> dict[str, Any]:
    info: BuildInfo = read_build_info(out, "OUTPUT")
    ws = workspace_of_output(out, info.target)
    options: dict[str, dict[str, str]] = {}
    rows = [{"name": p, "repository": None, "commit": None} for p in info.packages]
    if ws is not None:
        meta_path = ws.target_dir(info.target) / "colcon.meta"
        if meta_path.is_file():
            options = contents.cmake_options(meta_mod.load_meta_file(meta_path, "colcon.meta"))
        lock = read_lock(ws.lock_path, LOCK) if ws.lock_path.is_file() else None
        if lock is not None:
            found = {p.name: p.path.resolve() for p in packages_mod.discover(ws.source_dir)}
            rows = package_sources(info.packages, found, ws.root, lock)
    return {
        "output": str(out),
        "generated_by": info.generated_by,
        "target": info.target,
        "profile": info.profile,
        "toolchain_file": info.toolchain_file,
        "compiler": {"path": info.compiler.path, "version": info.compiler.version} if info.compiler else None,
        "flags": {
            "cpu": list(info.flags.cpu),
            "c": list(info.flags.c),
            "cxx": list(info.flags.cxx),
            "optimization": info.flags.optimization,
            "micro_ros_only": list(info.flags.micro_ros_only),
        },
        "library": {
            "file": info.library.file,
            "bytes": info.library.bytes,
            "members": info.library.members,
            "size": dict(info.library.size) if info.library.size else None,
        },
        "include": {"dir": info.include.dir, "files": info.include.files},
        "transport": info.transport,
        "options": options,
        "packages": rows,
        "types": list(contents.interface_types(out / info.include.dir)),
    }


def render(data: dict[str, Any]) -> str:
    lines = [f"output     {data['output']} ({data['generated_by']})"]
    compiler = data["compiler"]
    made_by = f"{compiler['path']} {compiler['version']}" if compiler else data["toolchain_file"]
    lines.append(f"target     {data['target']} ({data['profile'] or 'own toolchain file'}), {made_by}")
    flags = data["flags"]
    shown = [*flags["cpu"], *flags["c"], *([flags["optimization"]] if flags["optimization"] else [])]
    lines.append(f"flags      {' '.join(shown) or '-'}")
    if flags["micro_ros_only"]:
        lines.append(f"           micro-ROS only: {' '.join(flags['micro_ros_only'])}")
    lib = data["library"]
    size = lib["size"]
    sizes = f"; text {size['text']:,}, data {size['data']:,}, bss {size['bss']:,} bytes" if size else ""
    lines.append(f"library    {lib['file']}: {lib['bytes']:,} bytes, {lib['members']:,} objects{sizes}")
    lines.append(f"headers    {data['include']['files']:,} files in {data['include']['dir']}/")
    lines.append(f"transport  {data['transport'] or '-'}")
    memory = contents.memory_options(data["options"])
    for i, (pkg, opts) in enumerate(memory.items()):
        values = ", ".join(f"{k}={v}" for k, v in opts.items())
        lines.append(f"{'options' if i == 0 else '':<10} {pkg}: {values}")
    lines.append(f"packages ({len(data['packages'])}):")
    width = max((len(r["name"]) for r in data["packages"]), default=0)
    for row in data["packages"]:
        source = f"{row['repository']} @ {row['commit'][:12]}" if row["commit"] else ""
        lines.append(f"  {row['name']:<{width}}  {source}".rstrip())
    lines.append(f"types ({len(data['types'])}):")
    lines += [f"  {t}" for t in data["types"]]
    return "\n".join(lines) + "\n"


def show_info(output: Path | None, workspace: Path | None, toolchain: str | None, as_json: bool) -> None:
    out = resolve_output(output, workspace, toolchain).resolve()
    data = gather(out)
    sys.stdout.write(json.dumps(data, indent=2, sort_keys=True) + "\n" if as_json else render(data))
