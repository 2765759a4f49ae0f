"""`uros export cmake` and `uros export esp-idf`: packages around a build output."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from uros_build import console, export, outputs
from uros_build.buildinfo import BuildInfo, read_build_info
from uros_build.errors import ConfigError
from uros_build.workspace import check_folder_target


def _prepare(source: Path | None, output: Path) -> tuple[BuildInfo, Path]:
    """Read the build-info of the output to export and copy that output to ``output``."""
    src = (source or output).resolve()
    out = output.resolve()
    for folder in {src, out}:  # a swap a killed build left half-way is finished or undone first
        for line in outputs.recover(folder):
            console.info(line)
    info = read_build_info(src, "--from" if source else "--output")
    flag = "--from" if source else "--output"
    for name, present in (
        (info.library.file, (src / info.library.file).is_file()),
        (info.include.dir + "/", (src / info.include.dir).is_dir()),
    ):
        if not present:
            raise ConfigError(
                f"{flag} {src}: its build-info.json names {name}, which is not there (an incomplete output)",
                f"build it again: uros build --toolchain {info.target}",
            )
    if src != out:
        check_folder_target(out, "--output")
        outputs.check_output_dir(out, force=False, offers_force=False)
        earlier = outputs.owned_entries(out) or frozenset()  # an earlier export's files stay uros's
        outputs.write_marker(out, info.target, {*earlier, *export.copy_build_output(src, out)})
    return info, out


def _record(out: Path, written: list[Path]) -> None:
    if outputs.owned_entries(out) is not None:
        outputs.add_to_marker(out, [p.name for p in written])


def export_cmake(source: Path | None, output: Path) -> Path:
    info, out = _prepare(source, output)
    written = export.write_cmake_package(out, info)
    _record(out, written)
    console.step(f"wrote {', '.join(p.name for p in written)} in {out}")
    return out


def export_esp_idf(source: Path | None, output: Path) -> Path:
    src = (source or output).resolve()
    info = read_build_info(src, "--from" if source else "--output")
    if not info.idf_target:
        raise ConfigError(
            f"{src}: built for {info.target}, which is not an ESP-IDF target",
            "build for esp32, esp32s2, esp32s3 or esp32c3 first: uros build --toolchain esp32s3",
        )
    info, out = _prepare(source, output)
    written = export.write_esp_idf_component(out, info)
    _record(out, written)
    console.step(
        f"wrote the ESP-IDF component {out} ({', '.join(p.name for p in written)}): copy it into your "
        f"project's components/ and add its folder name to PRIV_REQUIRES"
    )
    return out


def _simple(
    source: Path | None, output: Path, write: Callable[[Path, BuildInfo], list[Path]], use: str
) -> Path:
    info, out = _prepare(source, output)
    written = write(out, info)
    _record(out, written)
    console.step(f"wrote {', '.join(p.name for p in written)} in {out}: {use}")
    return out


def export_make(source: Path | None, output: Path) -> Path:
    return _simple(source, output, export.write_make_fragment, "include it from your Makefile (README: Make)")


def export_pkg_config(source: Path | None, output: Path) -> Path:
    return _simple(
        source,
        output,
        export.write_pkg_config,
        "PKG_CONFIG_PATH=<that folder> pkg-config --cflags --libs microros",
    )


def export_meson(source: Path | None, output: Path) -> Path:
    src = (source or output).resolve()
    if read_build_info(src, "--from" if source else "--output").compiler is None:
        raise ConfigError(
            f"{src}: built with your own toolchain file, so uros does not know the compiler to name",
            "use `uros export pkg-config` with your own Meson cross file",
        )
    return _simple(source, output, export.write_meson_cross, "meson setup build --cross-file <that file>")
