"""A firmware built against an output, as a user's project would build it: the output's
`toolchain.cmake` and its CMake package (`microros::microros`), configured and built afresh in a work
folder. The probe firmware is one; `uros probe --app` builds another from the same board files."""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from uros_build.errors import StepFailed
from uros_build.proc import Runner
from uros_build.run.machines import Machine, board_files, ram_overflow


@dataclass(frozen=True)
class FirmwareBuild:
    """One firmware's build: its sources, the name of its ELF, the machine whose board files it takes,
    the output it is built against, the work folder it is built in, and what its configure is given."""

    sources: Path
    name: str
    machine: Machine
    out: Path
    work: Path
    defines: tuple[str, ...] = ()  # -DNAME=VALUE
    folders: tuple[str, ...] = ()  # the sub-folders of sources copied too (the FreeRTOS variant's)
    links: Mapping[str, Path] = field(default_factory=dict)  # names in work/src linking to folders


def build_firmware(runner: Runner, spec: FirmwareBuild, verbose: bool) -> Path:
    """Copy `spec.sources` (its files, and the sub-folders named in `spec.folders`) to work/src and the
    machine's board files (start-up, UART, memory map) to work/src/board, configure and build it
    against `spec.out` (with `spec.defines`); the ELF called `spec.name`. `spec.links`: names in
    work/src that link to folders (an app's: its path is then in no build file)."""
    sources, name, machine, out, work = spec.sources, spec.name, spec.machine, spec.out, spec.work
    defines, folders, links = spec.defines, spec.folders, spec.links
    cmake = runner.which("cmake")
    src, build = work / "src", work / "build"
    # afresh every time (it takes a second): another output of the target has another toolchain file
    shutil.rmtree(src, ignore_errors=True)
    shutil.rmtree(build, ignore_errors=True)
    shutil.copytree(
        sources,
        src,
        ignore=lambda folder, names: [
            n for n in names if (Path(folder) / n).is_dir() and Path(folder) == sources and n not in folders
        ],
    )
    for link, target in links.items():
        (src / link).symlink_to(target, target_is_directory=True)
    (src / "board").mkdir()
    for file_name, text in board_files(machine).items():
        (src / "board" / file_name).write_text(text, encoding="utf-8")
    runner.run(
        [cmake, "-S", str(src), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
         f"-DCMAKE_TOOLCHAIN_FILE={out / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={out}", *defines],
        step=f"configure the {name} firmware", quiet=not verbose,
    )  # fmt: skip
    try:
        runner.run([cmake, "--build", str(build)], step=f"build the {name} firmware", quiet=not verbose)
    except StepFailed as failed:
        log = (
            runner.log_path.read_text(encoding="utf-8", errors="replace") if runner.log_path.is_file() else ""
        )
        over = ram_overflow(log)
        if over is None:
            raise
        board = machine.board
        fix = (
            "a smaller library: uros build --preset tiny (fewer entities, a smaller history and MTU; "
            "docs/probe.md)"
        )
        if "freertos" in folders:  # the kernel's heap (heap_4, 256 KB) is in .bss
            fix = (
                "on FreeRTOS the kernel's heap alone is 256 KB (the probe's FreeRTOSConfig.h, "
                "configTOTAL_HEAP_SIZE): probe on the target's own board, without --board (docs/rtos.md)"
            )
        raise StepFailed(
            f"the {name} firmware does not fit {board.name}'s {board.ram.length:,} bytes of RAM: "
            f"its .data and .bss alone are {over:,} bytes over, before heap and stack",
            fix,
        ) from failed
    elf = next(iter(sorted(p for p in build.glob(f"{name}*") if p.suffix in ("", ".elf"))), None)
    if elf is None or not elf.is_file():
        raise StepFailed(
            f"build the {name} firmware: no {name} ELF was made", f"the log is {runner.log_path}"
        )
    return elf
