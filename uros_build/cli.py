"""The `uros` command line. Callbacks parse options and call one pipeline function; no logic here."""

from __future__ import annotations

import json
import sys
import traceback
from pathlib import Path
from typing import Any

import click

from uros_build import __version__, console, pipeline, tasks
from uros_build.errors import Interrupted, UrosError

_PATH = click.Path(path_type=Path)


def _table(rows: list[dict[str, Any]], as_json: bool, columns: tuple[str, ...]) -> None:
    """Rows as JSON (sorted keys) or as aligned text columns."""
    if as_json:
        click.echo(json.dumps(rows, indent=2, sort_keys=True))
        return
    widths = [max(len(str(r[c])) for r in rows) for c in columns[:-1]]
    for r in rows:
        cells = [f"{r[c]!s:<{w}}" for c, w in zip(columns, widths, strict=False)]
        click.echo("  ".join([*cells, str(r[columns[-1]])]))


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="uros")
@click.option("--debug", is_flag=True, help="Show Python tracebacks on errors.")
@click.pass_context
def cli(ctx: click.Context, debug: bool) -> None:
    """Cross-compile micro-ROS into libmicroros.a, its include tree and a CMake package."""
    ctx.obj = {"debug": debug}


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
def targets(as_json: bool) -> None:
    """List the shipped target profiles (toolchains/*.yaml)."""
    _table(tasks.targets_table(), as_json, ("name", "compiler", "description"))


@cli.group()
def toolchain() -> None:
    """CMake toolchain files."""


@toolchain.command("render")
@click.argument("target")
@click.option("-o", "--output", type=_PATH, help="Write here instead of standard output.")
@click.option(
    "--for",
    "purpose",
    type=click.Choice(["firmware", "micro-ros"]),
    default="firmware",
    show_default=True,
    help="firmware: no micro-ROS-only flags; micro-ros: with them (what `uros build` uses).",
)
@click.option("--gcc-major", type=int, help="The cross GCC's major version (decides GCC<6 workarounds).")
def toolchain_render(target: str, output: Path | None, purpose: str, gcc_major: int | None) -> None:
    """Render the CMake toolchain file of TARGET (a target name or a profile .yaml)."""
    tasks.render_toolchain_file(target, output, micro_ros=purpose == "micro-ros", gcc_major=gcc_major)


@cli.group()
def meta() -> None:
    """colcon.meta files."""


@meta.command("write")
@click.option("--preset", default="default", show_default=True, help="Starting point (meta/presets/).")
@click.option("--target", "target", help="Add what this target needs (transport, atomics).")
@click.option("--transport", help="XRCE-DDS transport: custom, udp or serial (default: the target's).")
@click.option("--meta", "metas", multiple=True, type=_PATH, help="A colcon.meta merged on top (repeatable).")
@click.option(
    "--set", "sets", multiple=True, metavar="PKG.OPTION=VALUE", help="Set a CMake option of a package."
)
@click.option("-o", "--output", type=_PATH, help="Write here instead of standard output.")
def meta_write(
    preset: str,
    target: str | None,
    transport: str | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    output: Path | None,
) -> None:
    """Write a colcon.meta (JSON, sorted keys)."""
    from uros_build import meta as meta_mod

    resolved = pipeline.resolve_target(target, None) if target else None
    merged = pipeline.meta_for(preset, resolved, transport, list(metas), list(sets))
    tasks.write_output_file(output, meta_mod.dump_meta(merged, f"uros meta write --preset {preset}"))


@cli.command()
@click.option("--toolchain", help="A target name (see `uros targets`) or your own CMake toolchain file.")
@click.option("--profile", type=_PATH, help="Your own target profile (.yaml, as in toolchains/).")
@click.option("--workspace", type=_PATH, default=Path("."), show_default=True, help="The firmware workspace.")
@click.option("--meta", "metas", multiple=True, type=_PATH, help="A colcon.meta merged on top (repeatable).")
@click.option(
    "--set", "sets", multiple=True, metavar="PKG.OPTION=VALUE", help="Set a CMake option of a package."
)
@click.option("--preset", default="default", show_default=True, help="colcon.meta starting point.")
@click.option("--transport", help="XRCE-DDS transport: custom, udp or serial (default: the target's).")
@click.option("--output", type=_PATH, help="Output folder (default: <workspace>/build/<target>).")
@click.option("--packages-up-to", multiple=True, help="Build only these packages and their dependencies.")
@click.option("-j", "--jobs", type=int, help="Packages built in parallel (colcon --parallel-workers).")
@click.option(
    "--compiler-prefix",
    help="Derive a target: this compiler prefix (e.g. arm-none-eabi-) instead of the profile's.",
)
@click.option(
    "--cflags",
    multiple=True,
    metavar="FLAG",
    help="Derive a target: one more compiler flag (repeatable; one flag each, never split).",
)
@click.option("--force", is_flag=True, help="Replace an --output folder that is not a uros output.")
@click.option("-v", "--verbose", is_flag=True, help="Stream colcon's and the compilers' output.")
def build(
    toolchain: str | None,
    profile: Path | None,
    workspace: Path,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    preset: str,
    transport: str | None,
    output: Path | None,
    packages_up_to: tuple[str, ...],
    jobs: int | None,
    compiler_prefix: str | None,
    cflags: tuple[str, ...],
    force: bool,
    verbose: bool,
) -> None:
    """Build libmicroros.a, its include tree and a CMake package for one target."""
    pipeline.build(
        pipeline.BuildOptions(
            workspace=workspace,
            toolchain=toolchain,
            profile=profile,
            metas=metas,
            sets=sets,
            preset=preset,
            transport=transport,
            output=output,
            verbose=verbose,
            force=force,
            packages_up_to=packages_up_to,
            jobs=jobs,
            compiler_prefix=compiler_prefix,
            cflags=cflags,
        )
    )


@cli.command()
@click.argument("library", type=_PATH)
@click.option("--target", help="The target the library must fit (see `uros targets`).")
@click.option("--profile", type=_PATH, help="Or your own target profile (.yaml).")
@click.option("-v", "--verbose", is_flag=True, help="Stream readelf's output.")
def check(library: Path, target: str | None, profile: Path | None, verbose: bool) -> None:
    """Check that every object in LIBRARY has the ELF facts of a target (exit 5 if not)."""
    tasks.check_library(library, target, profile, verbose)


@cli.group()
def export() -> None:
    """Packages for firmware build systems."""


# `--from` names the build output to copy; without it, --output is that output, rewritten in place.
_FROM = click.option(
    "--from", "source", type=_PATH, help="A `uros build` output to copy (default: --output itself)."
)


@export.command("cmake")
@click.option("--output", type=_PATH, required=True, help="Folder of the CMake package.")
@_FROM
def export_cmake(output: Path, source: Path | None) -> None:
    """Write microrosConfig.cmake (find_package) and microros.cmake (include) for a build output."""
    tasks.export_cmake(source, output)


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
def distros(as_json: bool) -> None:
    """List the micro-ROS distro manifests (meta/distros/)."""
    _table(tasks.distros_table(), as_json, ("name", "status", "dev_repositories", "mcu_repositories"))


@cli.command("create-firmware")
@click.argument("platform", default="generate_lib")
@click.option("--distro", default="humble", show_default=True, help="micro-ROS distro (see `uros distros`).")
@click.option(
    "--dir", "directory", type=_PATH, default=Path("firmware"), show_default=True, help="Workspace folder."
)
@click.option(
    "--mirror",
    "mirrors",
    multiple=True,
    metavar="UPSTREAM=LOCAL",
    help="Rewrite URLs, e.g. 'https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo'.",
)
@click.option(
    "--mirror-override",
    "overrides",
    multiple=True,
    metavar="REPO=URL[@VERSION]",
    help="One repository from elsewhere (REPO: workspace path like uros/rclc, or owner/repo).",
)
@click.option("--config", type=_PATH, help="A uros.yaml with a mirror: section (rules, overrides).")
@click.option("--locked", is_flag=True, help="Clone exactly the commits in <dir>/uros.lock.")
@click.option("--lock-file", type=_PATH, help="Clone exactly the commits in this lock file.")
@click.option(
    "--extra-package",
    "extra_packages",
    multiple=True,
    type=_PATH,
    help="A package folder (e.g. custom interfaces) to build with micro-ROS (repeatable).",
)
@click.option(
    "--force", is_flag=True, help="Re-create an existing workspace's sources (keeps your meta and extras)."
)
@click.option("--keep-partial", is_flag=True, help="Keep what was created when a step fails.")
@click.option(
    "--no-dev-build", is_flag=True, help="Do not build the host tools now (the first `uros build` will)."
)
@click.option("--toolchain", help="Check this target's compiler, C library and C++ headers before cloning.")
@click.option("-j", "--jobs", type=int, default=4, show_default=True, help="Parallel clones.")
@click.option("-v", "--verbose", is_flag=True, help="Stream the tools' output.")
def create_firmware(
    platform: str,
    distro: str,
    directory: Path,
    mirrors: tuple[str, ...],
    overrides: tuple[str, ...],
    config: Path | None,
    locked: bool,
    lock_file: Path | None,
    extra_packages: tuple[Path, ...],
    force: bool,
    keep_partial: bool,
    no_dev_build: bool,
    toolchain: str | None,
    jobs: int,
    verbose: bool,
) -> None:
    """Create a micro-ROS firmware workspace (PLATFORM: generate_lib, a library for any MCU)."""
    from uros_build.firmware import CreateOptions

    pipeline.create_firmware(
        CreateOptions(
            directory=directory,
            distro=distro,
            platform=platform,
            mirrors=mirrors,
            overrides=overrides,
            config=config,
            locked=locked,
            lock_file=lock_file,
            extra_packages=extra_packages,
            force=force,
            keep_partial=keep_partial,
            build_dev=not no_dev_build,
            toolchain=toolchain,
            jobs=jobs,
            verbose=verbose,
        )
    )


@cli.command("add-package")
@click.argument("source")
@click.option(
    "--workspace", type=_PATH, default=Path("firmware"), show_default=True, help="Firmware workspace."
)
@click.option("--version", help="Branch or tag, for a git URL.")
@click.option("-v", "--verbose", is_flag=True, help="Stream git's output.")
def add_package(source: str, workspace: Path, version: str | None, verbose: bool) -> None:
    """Add a package (a folder, kept in sync at every build, or a git URL) to the MCU workspace."""
    tasks.add_package(source, workspace, version, verbose)


@cli.group()
def interface() -> None:
    """Custom interface packages (.msg, .srv)."""


@interface.command("new")
@click.argument("name")
@click.option("--msg", "msgs", multiple=True, type=_PATH, help="A .msg file (repeatable).")
@click.option("--srv", "srvs", multiple=True, type=_PATH, help="A .srv file (repeatable).")
@click.option("--output", type=_PATH, help="Package folder (default: ./NAME).")
@click.option("--force", is_flag=True, help="Write into an existing folder.")
def interface_new(
    name: str, msgs: tuple[Path, ...], srvs: tuple[Path, ...], output: Path | None, force: bool
) -> None:
    """Scaffold an interface package NAME from .msg/.srv files (package.xml, CMakeLists.txt)."""
    tasks.interface_new(name, list(msgs), list(srvs), output, force)


@export.command("esp-idf")
@click.option("--output", type=_PATH, required=True, help="Folder of the ESP-IDF component.")
@_FROM
def export_esp_idf(output: Path, source: Path | None) -> None:
    """Write an ESP-IDF component (CMakeLists.txt, libmicroros.a, include/) for an ESP32 build."""
    tasks.export_esp_idf(source, output)


def main(argv: list[str] | None = None) -> None:
    debug = "--debug" in (argv if argv is not None else sys.argv[1:])
    try:
        cli.main(args=argv, prog_name="uros", standalone_mode=False)
    except click.exceptions.Abort:
        console.error("interrupted", "the previous output was left untouched")
        sys.exit(Interrupted.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except UrosError as exc:
        if debug:
            traceback.print_exc()
        console.error(exc.message, exc.hint)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        console.error("interrupted", "the previous output was left untouched")
        sys.exit(Interrupted.exit_code)
    sys.exit(0)
