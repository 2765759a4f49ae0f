"""`uros export meson`: a Meson cross file (compiler, CPU flags) and microros.pc for
dependency('microros')."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from uros_build import __version__, templating
from uros_build.errors import ConfigError
from uros_build.output.exports.base import ExportFormat, plain, write_files
from uros_build.output.exports.pkgconfig import PC_FILE, check_pkg_config, pkg_config_file

if TYPE_CHECKING:  # types only: every start reads the formats (start-up cost)
    from uros_build.output.buildinfo import BuildInfo

MESON_FILE = "microros-cross.ini"


def tool_prefix(compiler: str) -> str:
    """``/usr/bin/arm-none-eabi-gcc`` -> ``/usr/bin/arm-none-eabi-`` (pure)."""
    folder, _, name = compiler.rpartition("/")
    stem = name[: -len("gcc")] if name.endswith("gcc") else name
    return f"{folder}/{stem}" if folder else stem


def meson_cpu_family(prefix: str) -> str:
    """Meson's cpu_family for a GCC triplet (https://mesonbuild.com/Reference-tables.html#cpu-families)."""
    name = prefix.rpartition("/")[2]
    for start, family in (
        ("arm", "arm"),
        ("xtensa", "xtensa"),
        ("riscv32", "riscv32"),
        ("riscv64", "riscv64"),
    ):
        if name.startswith(start):
            return family
    return name.split("-", 1)[0] or "arm"


def meson_cross_file(target: str, compiler: str, cpu_flags: tuple[str, ...], folder: str) -> dict[str, str]:
    """microros-cross.ini beside microros.pc: the compiler, the CPU flags and pkg-config's folder (pure)."""
    prefix = tool_prefix(compiler)
    text = templating.render(
        f"{MESON_FILE}.j2",
        version=__version__,
        target=target,
        prefix=prefix,
        cpu_flags=list(cpu_flags),
        link_flags=list(cpu_flags),
        cpu_family=meson_cpu_family(prefix),
        cpu=target,
        folder=folder,
    )
    return {MESON_FILE: text, **pkg_config_file(target, cpu_flags)}


def _check(info: BuildInfo, src: Path) -> None:
    if info.compiler is None:
        raise ConfigError(
            f"{src}: built with your own toolchain file, so uros does not know the compiler to name",
            "use `uros export pkg-config` with your own Meson cross file",
        )
    check_pkg_config(info, src)


def write_meson_cross(out: Path, info: BuildInfo, folder: Path | None = None) -> list[str]:
    """``folder``: where the files will be read from (pkg_config_libdir), when not ``out``."""
    compiler = info.compiler.path if info.compiler else ""
    return write_files(out, meson_cross_file(info.target, compiler, info.flags.cpu, str(folder or out)))


FORMAT = ExportFormat(
    kind="meson",
    what="Write a Meson cross file (compiler, CPU flags) and microros.pc for dependency('microros').",
    output_help="Folder of microros-cross.ini and microros.pc.",
    folder_rule="meson",
    write=write_meson_cross,
    done=plain("meson setup build --cross-file <that file>"),
    check=_check,
    marks=(MESON_FILE,),
    replaces=("pkg-config",),  # its microros.pc is pkg-config's, with the cross file's folder
)

__all__ = ["FORMAT", "MESON_FILE", "PC_FILE", "meson_cpu_family", "meson_cross_file", "tool_prefix"]
