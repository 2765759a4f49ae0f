"""`uros info`: what a built library contains, from its output folder alone (its build-info.json
and include tree): the ROS 2 types it offers, its packages with the clones and commits they were
built from, the CMake options in force, flags and sizes. micro_ros_stm32cubemx_utils ships a
hand-kept available_ros2_types file; this is the same, derived from what was built."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path
from typing import Any

from uros_build import console
from uros_build.config.outputs import finish_killed_swaps, resolve_output
from uros_build.output import contents
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.run.report import library_sha256


def gather(out: Path) -> dict[str, Any]:
    """Everything from the output's own build-info.json: a workspace that was built again, into
    another output or with other options since, or whose clones moved, says nothing about this
    library."""
    info: BuildInfo = read_build_info(out, "OUTPUT")
    # the file's own bytes: a library replaced since is not the one build-info.json describes
    own = library_sha256(out / info.library.file)
    rows = [
        {
            "name": p,
            "repository": info.sources.get(p, {}).get("repository"),
            "commit": info.sources.get(p, {}).get("commit"),
            "stand_in": info.sources.get(p, {}).get("stand_in"),
        }
        for p in info.packages
    ]
    return {
        "output": str(out),
        "generated_by": info.generated_by,
        "build_key": info.build_key or None,
        "from_cache": dict(info.from_cache) or None,
        "ccache": dict(info.ccache) or None,
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
            "sha256": info.library.sha256,
            "file_sha256": own,  # None: not there, or not a regular file uros can read
            "matches_build_info": own == info.library.sha256,
        },
        "include": {"dir": info.include.dir, "files": info.include.files},
        "transport": info.transport,
        "rtos": dataclasses.asdict(info.rtos) if info.rtos else None,
        "ip_stack": dataclasses.asdict(info.ip_stack) if info.ip_stack else None,
        "options": {k: dict(v) for k, v in info.cmake_options.items()},
        "packages": rows,
        "types": list(contents.interface_types(out / info.include.dir)),
    }


def render(data: dict[str, Any]) -> str:
    lines = [f"output     {data['output']} ({data['generated_by']})"]
    if data["build_key"]:
        lines.append(f"build key  {data['build_key']}")
    if data["from_cache"]:  # built elsewhere: say so before anything that reads like this machine's
        lines.append(f"from the cache  {data['from_cache']['url']} (not built here)")
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
    if lib.get("matches_build_info", True):
        lines.append(f"library    {lib['file']}: {lib['bytes']:,} bytes, {lib['members']:,} objects{sizes}")
    else:  # never the old figures as if they were this file's
        now = f"its sha256 is {lib['file_sha256'][:16]}" if lib["file_sha256"] else "it is gone or unreadable"
        lines.append(
            f"library    {lib['file']}: CHANGED since the build: {now}, not {lib['sha256'][:16]} as "
            f"build-info.json records; the build's was {lib['bytes']:,} bytes, {lib['members']:,} objects "
            "(uros build again, or put its library back)"
        )
    lines.append(f"headers    {data['include']['files']:,} files in {data['include']['dir']}/")
    if data["ccache"]:
        hits, misses = data["ccache"].get("hits", 0), data["ccache"].get("misses", 0)
        remote = data["ccache"].get("remote_hits", 0)
        remote_text = f" ({remote} from its remote storage)" if remote else ""
        lines.append(
            f"ccache     {hits} of {hits + misses} compiles of this build taken from the cache{remote_text}"
        )
    lines.append(f"transport  {data['transport'] or '-'}")
    rtos = data["rtos"]
    if rtos:
        lines.append(
            f"rtos       {rtos['name']}: kernel {rtos['kernel']}, port {rtos['port']}, "
            f"config {rtos['config']} "
            f"(headers sha256 {rtos['headers_sha256'][:16]})"
        )
    else:
        lines.append("rtos       none (bare metal)")
    stack = data.get("ip_stack")
    if stack:
        lines.append(
            f"ip stack   {stack['name']} (PLATFORM_NAME {stack['platform']}): {stack['dir']}, "
            f"config {stack['config']} (headers sha256 {stack['headers_sha256'][:16]})"
        )
    memory = contents.memory_options(data["options"])
    for i, (pkg, opts) in enumerate(memory.items()):
        values = ", ".join(f"{k}={v}" for k, v in opts.items())
        lines.append(f"{'options' if i == 0 else '':<10} {pkg}: {values}")
    lines.append(f"packages ({len(data['packages'])}):")
    width = max((len(r["name"]) for r in data["packages"]), default=0)
    for row in data["packages"]:
        source = f"{row['repository']} @ {row['commit'][:12]}" if row["commit"] else ""
        if row.get("stand_in"):
            source += f" (stand-in: {row['stand_in']}, not the manifest's branch)"
        lines.append(f"  {row['name']:<{width}}  {source}".rstrip())
    lines.append(f"types ({len(data['types'])}):")
    lines += [f"  {t}" for t in data["types"]]
    return "\n".join(lines) + "\n"


def show_info(output: Path | None, workspace: Path | None, toolchain: str | None, as_json: bool) -> None:
    finish_killed_swaps(output, workspace)
    out = resolve_output(output, workspace, toolchain).resolve()
    data = gather(out)
    if not data["library"]["matches_build_info"]:
        console.warn(
            f"{out / data['library']['file']}: not the library build-info.json describes "
            "(its bytes' sha256 differs): its sizes and objects are the build's, not this file's"
        )
    if as_json:
        console.print_json(data)
    else:
        sys.stdout.write(render(data))
