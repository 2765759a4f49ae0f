"""`uros size`: text/data/bss of libmicroros.a per package, and with a firmware's ELF and GNU ld
map file, what each package really costs once linked (after --gc-sections). With a budget (--ram,
--flash, or the chip a target's profile names): does it fit, counting the heap and stack the last
`uros probe` of this library measured, and which colcon.meta options cost most RAM (exit 5 when it
does not fit: a CI gate)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uros_build import console
from uros_build.config.outputs import finish_killed_swaps, resolve_output
from uros_build.errors import ConfigError, VerifyError
from uros_build.files import read_regular, reason
from uros_build.output import budget, sizes, symbols
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.output.folders import is_uros_output
from uros_build.output.sizes import Sizes
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.run.report import MAX_MAP_BYTES, Measured, library_sha256, read_measured
from uros_build.sources.options import known_options
from uros_build.sources.workspace import Workspace, workspace_of_output
from uros_build.target.memsize import show_bytes
from uros_build.target.profiles import Chip, TargetProfile, find_profile


@dataclass(frozen=True)
class SizeRequest:
    """`uros size`'s command line, as given (cli/build.py hands every option by its own name)."""

    library: Path | None = None  # LIBRARY: the .a or its output folder
    workspace: Path | None = None
    toolchain: str | None = None
    elf: Path | None = None  # --elf: the firmware linked against the library
    map_file: Path | None = None  # --map: its GNU ld map file
    objects: bool = False  # --objects: every object of the library too
    ram: str | None = None  # --ram SIZE, as typed
    flash: str | None = None  # --flash SIZE, as typed
    as_json: bool = False


@dataclass(frozen=True)
class MemoryBudget:
    """What the library must fit: --ram/--flash in bytes, else the chip the target's profile names
    (``from_chip``: neither flag was given)."""

    ram: int | None
    flash: int | None
    chip: Chip
    from_chip: bool


def size_tool(info: BuildInfo | None) -> str:
    """The target's ``size`` beside the compiler that built the library (host ``size`` reads only
    the host's object formats on most distributions), else the host's."""
    if info is not None and info.compiler is not None and info.compiler.path.endswith("gcc"):
        return info.compiler.path[: -len("gcc")] + "size"
    return "size"


def _library(
    library: Path | None, workspace: Path | None, toolchain: str | None
) -> tuple[Path, BuildInfo | None]:
    if library is not None and library.is_file():
        out = library.parent
        return library, read_build_info(out, "LIBRARY") if is_uros_output(out) else None
    out = resolve_output(library, workspace, toolchain)
    info = read_build_info(out, "LIBRARY")
    return out / info.library.file, info


def _installed_by(ws: Workspace | None, key: str) -> dict[str, str]:
    if ws is None:
        return {}
    manifests = {
        path.parent.name: path.read_text(encoding="utf-8", errors="replace")
        for path in sorted((ws.target_dir(key) / "build").glob("*/install_manifest.txt"))
    }
    return sizes.manifest_archives(manifests)


def measure(runner: Runner, library: Path, info: BuildInfo | None, request: SizeRequest) -> dict[str, Any]:
    elf, map_file = request.elf, request.map_file
    tool = size_tool(info)
    members = sizes.parse_berkeley(runner.query([tool, str(library)], step=f"size {library.name}"))
    archives = info.library.inputs if info else ()
    packages = info.packages if info else ()
    ws = workspace_of_output(library.parent, info.target) if info else None
    installed_by = _installed_by(ws, info.target) if info else {}
    in_library = sizes.by_package(members, archives, packages, installed_by)
    linked_members: dict[str, Sizes] | None = None
    rest = None
    if map_file is not None:
        try:
            text = read_regular(map_file, MAX_MAP_BYTES).decode("utf-8", errors="replace")
        except OSError as exc:
            raise ConfigError(f"--map {map_file}: {reason(exc)}") from None
        entries = sizes.parse_map(text)
        if not entries:
            raise ConfigError(
                f"--map {map_file}: no linker memory map in it",
                "pass the file GNU ld wrote for -Wl,-Map=FILE",
            )
        linked_members, rest = sizes.linked_members(entries, library.name)
    linked = (
        sizes.by_package(linked_members, archives, packages, installed_by)
        if linked_members is not None
        else {}
    )
    rows: list[dict[str, Any]] = []
    for name, (lib_sizes, count) in in_library.items():
        got = linked.get(name)
        rows.append(
            {
                "package": name,
                "objects": count,
                "library": lib_sizes.as_dict(),
                "linked": got[0].as_dict()
                if got
                else (Sizes().as_dict() if linked_members is not None else None),
                "linked_objects": got[1] if got else (0 if linked_members is not None else None),
            }
        )
    key = "linked" if linked_members is not None else "library"
    rows.sort(key=lambda r: (-sum(r[key].values()), r["package"]))
    data: dict[str, Any] = {
        "library": str(library),
        "target": info.target if info else None,
        "packages": rows,
        "total": sum((Sizes(**r["library"]) for r in rows), Sizes()).as_dict(),
        "linked_total": sum((Sizes(**r["linked"]) for r in rows), Sizes()).as_dict()
        if linked_members is not None
        else None,
        "rest_of_firmware": rest.as_dict() if rest is not None else None,
        "elf": None,
    }
    if elf is not None:
        whole = sum(
            sizes.parse_berkeley(runner.query([tool, str(elf)], step=f"size {elf.name}")).values(), Sizes()
        )
        data["elf"] = {"file": str(elf), **whole.as_dict()}
    if request.objects:
        data["objects"] = [
            {
                "member": m,
                "library": s.as_dict(),
                "linked": linked_members.get(m, Sizes()).as_dict() if linked_members is not None else None,
            }
            for m, s in sorted(members.items())
        ]
    return data


def _cells(values: dict[str, int] | None) -> list[str]:
    if values is None:
        return []
    return [f"{values[k]:,}" for k in sizes.KINDS] + [f"{sum(values.values()):,}"]


def render(data: dict[str, Any]) -> str:
    linked = data["linked_total"] is not None
    head = ["PACKAGE", "OBJECTS", "TEXT", "DATA", "BSS", "TOTAL"]
    if linked:
        head += ["LINKED TEXT", "DATA", "BSS", "TOTAL"]
    rows = [head]
    for r in data["packages"]:
        rows.append(
            [r["package"], str(r["objects"]), *_cells(r["library"]), *(_cells(r["linked"]) if linked else [])]
        )
    rows.append(
        [
            "total",
            str(sum(r["objects"] for r in data["packages"])),
            *_cells(data["total"]),
            *_cells(data["linked_total"]),
        ]
    )
    if data.get("objects"):
        rows.append([])
        rows.append(
            [
                "OBJECT",
                "",
                "TEXT",
                "DATA",
                "BSS",
                "TOTAL",
                *(["LINKED TEXT", "DATA", "BSS", "TOTAL"] if linked else []),
            ]
        )
        for o in data["objects"]:
            rows.append([o["member"], "", *_cells(o["library"]), *(_cells(o["linked"]) if linked else [])])
    widths = [max(len(r[i]) for r in rows if len(r) > i) for i in range(len(head))]
    lines = [f"{data['library']} ({data['target'] or 'no build-info.json'}), bytes:"]
    for r in rows:
        cells = (
            [r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:], widths[1:], strict=False)]
            if r
            else []
        )
        lines.append("  ".join(cells).rstrip())
    if data["rest_of_firmware"] is not None:
        rest = data["rest_of_firmware"]
        lines.append(
            f"rest of the firmware: text {rest['text']:,}, data {rest['data']:,}, bss {rest['bss']:,}"
        )
    if data["elf"] is not None:
        e, mine = data["elf"], data["linked_total"]
        line = f"{e['file']}: text {e['text']:,}, data {e['data']:,}, bss {e['bss']:,}"
        if mine is not None and e["text"] + e["data"]:
            flash = 100 * (mine["text"] + mine["data"]) / (e["text"] + e["data"])
            ram = 100 * (mine["data"] + mine["bss"]) / max(1, e["data"] + e["bss"])
            line += (
                f"; micro-ROS: {flash:.0f}% of its flash (text+data), {ram:.0f}% of its static RAM (data+bss)"
            )
        lines.append(line)
    return "\n".join(lines) + "\n"


def show_size(request: SizeRequest) -> None:
    library, elf, ram, flash = request.library, request.elf, request.ram, request.flash
    ram_budget, flash_budget = budget.budget_value(ram, "--ram"), budget.budget_value(flash, "--flash")
    if elf is not None and request.map_file is None:
        raise ConfigError("--elf without --map", "link with -Wl,-Map=app.map and pass --map app.map too")
    for path, flag in ((elf, "--elf"), (request.map_file, "--map")):
        if path is not None and not path.is_file():  # a FIFO or a device is never read
            raise ConfigError(f"{flag} {path}: {'not a regular file' if path.exists() else 'no such file'}")
    finish_killed_swaps(library, request.workspace)
    lib, info = _library(library, request.workspace, request.toolchain)
    if not lib.is_file():
        raise ConfigError(
            f"{lib}: no such file", "pass libmicroros.a, a `uros build` output folder, or --toolchain NAME"
        )
    if elf is not None:
        check_elf(elf, profile_of(info))
    own = library_sha256(lib)  # the file's own bytes: a replaced file is another library
    if info is not None and own != info.library.sha256:
        console.warn(
            f"{lib}: not the library its build-info.json describes (its bytes' sha256 differs): "
            "the sizes are this file's; a probe of the library built then is not counted"
        )
    runner = Runner(new_run_log(user_log_dir(), "size"))
    data = measure(runner, lib.resolve(), info, request)
    data["library_sha256"] = own
    data["matches_build_info"] = info.library.sha256 == own if info is not None else None
    chip = profile_chip(info)
    ram_budget = ram_budget if ram_budget is not None else chip.ram_bytes
    flash_budget = flash_budget if flash_budget is not None else chip.flash_bytes
    fits, line = True, ""
    if ram_budget is not None or flash_budget is not None:
        asked = MemoryBudget(ram_budget, flash_budget, chip, from_chip=ram is None and flash is None)
        data["budget"], fits, line = check_budget(runner, lib.resolve(), info, data, asked)
    if request.as_json:
        console.print_json(data)
    else:
        # the verdict is the last line: on standard output when it fits, as the error when not
        sys.stdout.write(render(data) + (render_budget(data["budget"]) if "budget" in data else ""))
        if fits and line:
            sys.stdout.write(line + "\n")
    if not fits:
        raise VerifyError(line, _hint(data["budget"]))


def _hint(b: dict[str, Any]) -> str:
    """What to change: the options that cost most RAM, and a value of one that alone would fit."""
    costs = b["options"]
    if not costs or "ram" not in b["over"]:
        return "build fewer packages (--packages), or link with --gc-sections and pass --map"
    hint = "the options that cost most RAM: " + ", ".join(
        f"{c['package']}.{c['option']}={c['value']} {c['bytes']:,} B" for c in costs[:3]
    )
    fit = b["would_fit"]
    if fit:
        hint += "; alone enough: " + ", ".join(
            f"--set {f['package']}.{f['option']}={f['value']} (frees {f['frees']:,} B)" for f in fit[:2]
        )
    return hint


def profile_of(info: BuildInfo | None) -> TargetProfile | None:
    """The library's shipped profile (none for the user's own profile or toolchain file:
    build-info.json records only a profile's file name)."""
    if info is None or info.profile != f"{info.target}.yaml":
        return None
    try:
        return find_profile(info.target, alternative="")
    except ConfigError:
        return None


def profile_chip(info: BuildInfo | None) -> Chip:
    """The chip the library's shipped profile names."""
    profile = profile_of(info)
    return profile.chip if profile is not None else Chip()


def float_abi(profile: TargetProfile) -> str | None:
    """ "hard" or "soft": the float ABI a profile's objects must show, where its ELF facts say one."""
    elf = profile.elf
    if ("Tag_ABI_VFP_args", "VFP registers") in elf.attributes or any(
        "double-float ABI" in f or "single-float ABI" in f for f in elf.header_flags
    ):
        return "hard"
    if "Tag_ABI_VFP_args" in elf.attributes_absent or "soft-float ABI" in elf.header_flags:
        return "soft"
    return None


def check_elf(elf: Path, profile: TargetProfile | None) -> None:
    """--elf is a linked firmware (an ELF executable: not an archive, an object or another file),
    for the library's machine, class and float ABI when its profile is known."""
    try:
        head = _head(elf)
    except OSError as exc:
        raise ConfigError(f"--elf {elf}: cannot read: {exc.strerror or exc}") from None
    problem = sizes.elf_problem(
        head,
        profile.elf.machine if profile is not None else None,
        profile.elf.elf_class if profile is not None else "ELF32",
        float_abi(profile) if profile is not None else None,
    )
    if problem is not None:
        hint = "pass the ELF your firmware's link wrote (-o app.elf), with this library"
        raise ConfigError(f"--elf {elf}: {problem}", hint)


def _head(path: Path) -> bytes:
    """The first 64 bytes of a regular file (a FIFO is refused, never waited on)."""
    with path.open("rb") as handle:
        return handle.read(64)


def _linked_by_probe(map_file: str, library: str) -> Sizes:
    """What the probe firmware linked of the library, from its map file's copy (bounded: it was
    checked by its sha256 in the report, read again here)."""
    try:
        text = read_regular(map_file, MAX_MAP_BYTES).decode("utf-8", errors="replace")
    except OSError:
        text = ""
    members, _ = sizes.linked_members(sizes.parse_map(text), library)
    return sum(members.values(), Sizes())


def _headers(out: Path, info: BuildInfo | None, names: set[str]) -> dict[str, dict[str, str]]:
    """header -> its whole-number defines, for the configured headers of the output's include tree
    that hold the options' values (rmw_microxrcedds_c/config.h, uxr/client/config.h)."""
    return budget.configured_headers(out / info.include.dir, names) if info is not None else {}


def check_budget(
    runner: Runner, library: Path, info: BuildInfo | None, data: dict[str, Any], asked: MemoryBudget
) -> tuple[dict[str, Any], bool, str]:
    """The budget's part of `uros size`: what the firmware needs against ``asked``, the probe's
    heap and stack when a passed run of this very library (``data``'s library_sha256) measured them,
    the options that cost most RAM (their pools' sizes from the library's symbols)."""
    ram, flash, chip, library_sha256 = asked.ram, asked.flash, asked.chip, data.get("library_sha256")
    # the run of this library's own variant: a FreeRTOS run's heap is the kernel's, not newlib's
    found: Measured | str = (
        read_measured(library.parent, info.target, library_sha256, info.rtos.name if info.rtos else None)
        if info is not None
        else "not measured: run uros probe"
    )
    measured = found if isinstance(found, Measured) else None
    rest = None
    if data["linked_total"] is not None:
        library_sizes, source = Sizes(**data["linked_total"]), "linked into your firmware (--map)"
        rest = Sizes(**data["rest_of_firmware"]) if data["rest_of_firmware"] is not None else None
    elif measured is not None and measured.map_file is not None:
        library_sizes = _linked_by_probe(measured.map_file, library.name)
        source = "linked by the probe firmware (a node, a publisher, a subscription)"
    else:
        library_sizes = Sizes(**data["total"])
        source = "the whole archive: a firmware links less (pass --map, or run uros probe)"
    need = budget.Need(
        library_sizes, rest, measured.heap if measured else None, measured.stack if measured else None
    )
    fits, line = budget.verdict(need, ram, flash, None if measured else str(found))
    nm_sizes = budget.symbol_sizes(symbols.read_nm(runner, "nm", library))
    cmake_options = info.cmake_options if info is not None else {}
    transport = cmake_options.get("rmw_microxrcedds", {}).get("RMW_UXRCE_TRANSPORT") or (
        info.transport if info is not None else None
    )
    known = known_options()
    costs = budget.option_costs(
        known, cmake_options, transport, nm_sizes, _headers(library.parent, info, {o.header for o in known})
    )
    result = {
        "ram": ram,
        "flash": flash,
        "chip": chip.name if asked.from_chip and chip.known else None,
        "library": {**library_sizes.as_dict(), "counted": source},
        "rest_of_firmware": rest.as_dict() if rest is not None else None,
        "heap": need.heap,
        "stack": need.stack,
        "probe": {
            "report": measured.report,
            "map": measured.map_file,
            "rtos": measured.rtos,
            "machine": measured.machine or None,
            "run": measured.run,
        }
        if measured
        else str(found),
        "need": {"static_ram": need.static_ram, "ram": need.ram, "flash": need.flash},
        "over": budget.over_by(need, ram, flash),
        "fits": fits,
        "verdict": line,
        "options": [
            {
                "package": c.package,
                "option": c.option,
                "value": c.value,
                "bytes": c.bytes,
                "pools": list(c.pools),
                "each": c.each,
                "value_from": c.value_from,
            }
            for c in costs
        ],
        "would_fit": [
            {"package": c.package, "option": c.option, "value": str(value), "frees": frees}
            for c, value, frees in budget.values_that_fit(
                costs, budget.over_by(need, ram, flash).get("ram", 0)
            )
        ],
    }
    return result, fits, line


def render_budget(b: dict[str, Any]) -> str:
    lib = b["library"]
    given = [
        f"RAM {show_bytes(b['ram'])}" if b["ram"] else "",
        f"flash {show_bytes(b['flash'])}" if b["flash"] else "",
    ]
    lines = [
        f"budget: {', '.join(g for g in given if g)}"
        + (f" (the {b['chip']} of the target's profile)" if b["chip"] else "")
    ]
    ram = f"  RAM:   {lib['data'] + lib['bss']:,} B static (data+bss, {lib['counted']})"
    if b["rest_of_firmware"] is not None:
        rest = b["rest_of_firmware"]
        ram += f" + {rest['data'] + rest['bss']:,} B the rest of your firmware"
    if b["heap"] is not None:
        ram += (
            f" + heap {b['heap']:,} B + stack {b['stack']:,} B ({b['probe']['run']}) = {b['need']['ram']:,} B"
        )
    else:
        ram += f"; heap and stack {b['probe']}"
    lines.append(ram)
    flash = f"  flash: {lib['text'] + lib['data']:,} B (text+rodata+data)"
    if b["rest_of_firmware"] is not None:
        flash += f", {b['need']['flash']:,} B with the rest of your firmware"
    lines.append(flash)
    if b["options"]:
        lines.append("  options that cost most RAM: " + ", ".join(budget_option(c) for c in b["options"][:3]))
    return "\n".join(lines) + "\n"


def budget_option(c: dict[str, Any]) -> str:
    return f"{c['package']}.{c['option']}={c['value']} {c['bytes']:,} B ({', '.join(c['pools'])})"
