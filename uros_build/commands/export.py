"""`uros export ...`: packages around build outputs, for each firmware build system."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError, VerifyError
from uros_build.output import exports, swap, symbols
from uros_build.output import folders as outputs
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.output.exports import arduino
from uros_build.output.exports.base import copy_build_output
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.sources.workspace import check_folder_target


def _check_complete(src: Path, info: BuildInfo, flag: str) -> None:
    """The library and the include tree its build-info.json names are there."""
    for name, present in (
        (info.library.file, (src / info.library.file).is_file()),
        (info.include.dir + "/", (src / info.include.dir).is_dir()),
    ):
        if not present:
            raise ConfigError(
                f"{flag} {src}: its build-info.json names {name}, which is not there (an incomplete output)",
                f"build it again: uros build --toolchain {info.target}",
            )


def _check_folder(out: Path, kind: str) -> None:
    """A folder whose package the consumer of ``kind`` could not use is refused before anything is
    written (the consumers cannot be told the folder escaped: they find it themselves)."""
    exports.refuse_package_folder(kind, out, "--output", "export into a folder without it")


def export_format(kind: str, source: Path | None, output: Path) -> Path:
    """`uros export KIND --output DIR [--from DIR]` for a format of ``exports.FORMATS``: the folder
    checked, the build-info read, the format's own check (it raises: refused before anything is
    copied), the output copied to ``output`` (with --from), the format's files written beside it."""
    fmt = exports.by_kind(kind)
    flag = "--from" if source else "--output"
    src = (source or output).resolve()
    out = output.resolve()
    _check_folder(out, kind)
    for folder in {src, out}:  # a swap a killed build left half-way is finished or undone first
        for line in swap.recover(folder):
            console.info(line)
    info = read_build_info(src, flag)
    _check_complete(src, info, flag)
    fmt.check(info, src)
    if src != out:
        check_folder_target(out, "--output")
        outputs.check_output_dir(out, force=False, offers_force=False)
        earlier = outputs.owned_entries(out) or frozenset()  # an earlier export's files stay uros's
        outputs.write_marker(out, info.target, {*earlier, *copy_build_output(src, out)})
    written = fmt.write(out, info, out)
    if outputs.owned_entries(out) is not None:
        outputs.add_to_marker(out, written)
    console.step(fmt.done(info, out, written))
    return out


def _tree_digest(folder: Path) -> dict[str, str]:
    return {
        p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _refuse_duplicates(runner: Runner, library: Path) -> None:
    """Arduino's cores link precompiled libraries with --whole-archive (micro_ros_arduino#910,
    #1300, #847), so a global symbol two members define fails every sketch with "multiple
    definition": refused before anything is written, judged by the library's own symbols (nm)."""
    found = symbols.parse_nm(symbols.read_nm(runner, "nm", library), library.name)
    duplicates = symbols.duplicate_globals(found)
    if duplicates:
        raise VerifyError(
            f"--from {library.parent}: {symbols.describe_duplicates(duplicates, library.name)}",
            symbols.DUPLICATE_HINT,
        )


def export_arduino(sources: tuple[Path, ...], output: Path) -> Path:
    """One precompiled Arduino library from one or more outputs (one per target): each archive in
    the folder Arduino's builder looks in for its board, one include tree (it must be the same)."""
    if not sources:
        raise ConfigError(
            "export arduino: no --from", "name each `uros build` output: --from DIR [--from DIR ...]"
        )
    out = output.resolve()
    placed: dict[str, Path] = {}
    includes: tuple[Path, dict[str, str]] | None = None
    targets: list[str] = []
    architectures: list[str] = []
    runner = Runner(new_run_log(user_log_dir(), "export"))
    for given in sources:
        src = given.resolve()
        info = read_build_info(src, "--from")
        _check_complete(src, info, "--from")
        _refuse_duplicates(runner, src / info.library.file)
        folders = arduino.arduino_folders(info.flags.cpu)
        if not folders:
            raise ConfigError(
                f"--from {src}: built for {info.target} ({' '.join(info.flags.cpu)}), the flags of none of "
                "the Arduino cores uros knows (README, Arduino: Teensy 4, STM32duino, Arduino mbed)",
                "build for the board's flags: cortex-m7 (Teensy 4), cortex-m7-sp, cortex-m4f, cortex-m33, "
                "cortex-m3, cortex-m0plus or rp2040",
            )
        for folder in folders:
            if folder in placed:
                raise ConfigError(
                    f"--from {src}: {placed[folder]} is for src/{folder} too", "one output per board"
                )
            placed[folder] = src
        architectures += [core.architecture for core in arduino.arduino_cores(info.flags.cpu)]
        tree = _tree_digest(src / info.include.dir)
        if includes is None:
            includes = (src, tree)
        elif tree != includes[1]:
            differs = sorted(k for k in set(tree) | set(includes[1]) if tree.get(k) != includes[1].get(k))
            raise ConfigError(
                f"--from {src}: its headers differ from {includes[0]}'s (first: include/{differs[0]})",
                "one Arduino library has one include tree: build the targets with the same colcon.meta",
            )
        targets.append(info.target)
    assert includes is not None
    check_folder_target(out, "--output")
    outputs.check_output_dir(out, force=False, offers_force=False)
    out.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(out / "src", ignore_errors=True)  # uros's (the guard above said so)
    shutil.copytree(includes[0] / "include", out / "src")
    for folder, src in sorted(placed.items()):
        (out / "src" / folder).mkdir(parents=True, exist_ok=True)
        shutil.copy2(src / "libmicroros.a", out / "src" / folder / "libmicroros.a")
    (out / "src" / f"{arduino.ARDUINO_NAME}.h").write_text(arduino.arduino_header(), encoding="utf-8")
    (out / "library.properties").write_text(
        arduino.arduino_properties(targets, architectures), encoding="utf-8"
    )
    outputs.write_marker(out, "arduino", ["library.properties", "src"])
    console.step(
        f"wrote the Arduino library {out} ({', '.join(f'src/{f}' for f in sorted(placed))}): put it in your "
        f"sketchbook's libraries/ and #include <{arduino.ARDUINO_NAME}.h>"
    )
    return out
