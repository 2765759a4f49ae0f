"""The `uros` command line: option parsing, one call into uros_build.commands per command, and the
one place that turns errors into a message and an exit code.

One vocabulary across commands: the target is ``--toolchain`` (a target name, or for `uros build`
also a profile or a .cmake file), a workspace folder is ``-w/--workspace``, what a command writes
goes to ``-o/--output``. Earlier spellings (``--target``, ``--dir``) still work and are hidden.
"""

from __future__ import annotations

import errno
import json
import signal
import sys
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
from click.shell_completion import CompletionItem

from uros_build import __version__, console, defaults, proc
from uros_build.commands import add_package as add_package_cmd
from uros_build.commands import build as build_cmd
from uros_build.commands import check as check_cmd
from uros_build.commands import clean as clean_cmd
from uros_build.commands import create_firmware as create_cmd
from uros_build.commands import doctor as doctor_cmd
from uros_build.commands import export as export_cmd
from uros_build.commands import info as info_cmd
from uros_build.commands import interface as interface_cmd
from uros_build.commands import listings
from uros_build.commands import probe as probe_cmd
from uros_build.commands import size as size_cmd
from uros_build.commands import update as update_cmd
from uros_build.errors import DiskFull, Signalled, UrosError, did_you_mean, interrupted
from uros_build.settings import BuildArgs
from uros_build.sourceplan import CreateArgs, UpdateArgs

_PATH = click.Path(path_type=Path)
_Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]


class _Option(click.Option):
    """An option whose old spellings (``aliases``) keep working but stay out of ``--help``."""

    def __init__(self, *args: Any, aliases: tuple[str, ...] = (), **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.hidden_aliases = aliases

    def get_help_record(self, ctx: click.Context) -> tuple[str, str] | None:
        shown = self.opts
        self.opts = [o for o in shown if o not in self.hidden_aliases]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = shown


class _Group(click.Group):
    """A command group that answers a mistyped command with the closest names."""

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        name = args[0] if args else ""
        if (
            name
            and not name.startswith("-")
            and not ctx.resilient_parsing
            and not self.get_command(ctx, name)
        ):
            ctx.fail(f"No such command {name!r}{did_you_mean(name, self.list_commands(ctx))}.")
        return super().resolve_command(ctx, args)


# Shell completion (click's: `_UROS_COMPLETE=bash_source uros`, see the README): the names a value
# can take, filtered by what was typed so far.
def _matching(names: list[str], incomplete: str) -> list[CompletionItem]:
    return [CompletionItem(n) for n in names if n.startswith(incomplete)]


def _complete_targets(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return _matching(listings.target_names(), incomplete)


def _complete_distros(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return _matching(listings.distro_names(), incomplete)


def _complete_packages(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return _matching(listings.package_names(ctx.params.get("workspace")), incomplete)


def _complete_sets(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return _matching(listings.set_candidates(ctx.params.get("workspace")), incomplete)


def _toolchain_option(help_text: str) -> _Decorator:
    return click.option(
        "--toolchain", "--target", "toolchain", cls=_Option, aliases=("--target",), help=help_text,
        shell_complete=_complete_targets,
    )  # fmt: skip


def _workspace_option(help_text: str) -> _Decorator:
    # One default everywhere, resolved by plan.resolve_workspace (None here: "not given").
    return click.option(
        "-w", "--workspace", "--dir", "workspace", cls=_Option, aliases=("--dir",), type=_PATH,
        default=None, show_default=defaults.WORKSPACE_HELP, help=help_text,
    )  # fmt: skip


def _output_option(help_text: str, required: bool = False) -> _Decorator:
    return click.option("-o", "--output", type=_PATH, required=required, help=help_text)


_VERBOSE = click.option("-v", "--verbose", is_flag=True, help="Stream the tools' output.")
_JSON = click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
_METAS = click.option(
    "--meta", "metas", multiple=True, type=_PATH, help="A colcon.meta merged on top (repeatable)."
)
_SETS = click.option(
    "--set", "sets", multiple=True, metavar="PKG.OPTION=VALUE", help="Set a CMake option of a package.",
    shell_complete=_complete_sets,
)  # fmt: skip
_TRANSPORT = click.option(
    "--transport", help="XRCE-DDS transport: custom, udp or serial (default: the target's)."
)
_PRESET = click.option(
    "--preset", default=defaults.PRESET, show_default=True, help="colcon.meta starting point (meta/presets/)."
)
# `--from` names the build output to copy; without it, --output is that output, rewritten in place.
_FROM = click.option(
    "--from", "source", type=_PATH, help="A `uros build` output to copy (default: --output itself)."
)


def _table(rows: list[dict[str, Any]], as_json: bool, columns: tuple[tuple[str, str], ...]) -> None:
    """Rows as JSON (sorted keys, every field) or as aligned text columns under a header;
    ``columns``: (key, title) of what the text shows."""
    if as_json:
        click.echo(json.dumps(rows, indent=2, sort_keys=True))
        return
    lines = [[title for _key, title in columns], *([str(r[key]) for key, _title in columns] for r in rows)]
    widths = [max(len(line[i]) for line in lines) for i in range(len(columns) - 1)]
    for line in lines:
        cells = [f"{cell:<{w}}" for cell, w in zip(line, widths, strict=False)]
        click.echo("  ".join([*cells, line[-1]]).rstrip())


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="uros")
@click.option("--debug", is_flag=True, help="Show Python tracebacks on errors.")
def cli(debug: bool) -> None:
    """Cross-compile micro-ROS into libmicroros.a, its include tree and a CMake package."""
    # --debug is read by main() from the command line before click runs: it decides how errors
    # that happen during option parsing print too. Declared here for --help and completion.
    del debug


@click.group(cls=_Group, invoke_without_command=True, subcommand_metavar="[show NAME]")
@_JSON
@click.pass_context
def targets(ctx: click.Context, as_json: bool) -> None:
    """List the shipped target profiles (`uros targets show NAME` prints one)."""
    if ctx.invoked_subcommand is None:
        columns = (("name", "TARGET"), ("compiler", "COMPILER"), ("transport", "TRANSPORT"))
        _table(listings.targets_table(), as_json, (*columns, ("description", "DESCRIPTION")))


@click.command("show")
@click.argument("name", shell_complete=_complete_targets)
def targets_show(name: str) -> None:
    """Print the profile of target NAME, to copy and edit: uros targets show cortex-m7 > my-board.yaml"""
    click.echo(listings.target_profile_text(name), nl=False)


@click.command()
@_JSON
def distros(as_json: bool) -> None:
    """List the micro-ROS distro manifests (meta/distros/)."""
    columns = (("name", "DISTRO"), ("status", "STATUS"), ("dev_repositories", "DEV REPOS"))
    _table(listings.distros_table(), as_json, (*columns, ("mcu_repositories", "MCU REPOS")))


@click.group(cls=_Group)
def toolchain() -> None:
    """CMake toolchain files."""


@click.command("render")
@click.argument("target", shell_complete=_complete_targets)
@_output_option("Write here instead of standard output.")
@click.option(
    "--for", "purpose", type=click.Choice(["firmware", "micro-ros"]), default="firmware", show_default=True,
    help="firmware: no micro-ROS-only flags; micro-ros: with them (what `uros build` uses).",
)  # fmt: skip
@click.option("--gcc-major", type=int, help="The cross GCC's major version (decides GCC<6 workarounds).")
def toolchain_render(target: str, output: Path | None, purpose: str, gcc_major: int | None) -> None:
    """Render the CMake toolchain file of TARGET (a target name or a profile .yaml)."""
    listings.render_toolchain_file(target, output, micro_ros=purpose == "micro-ros", gcc_major=gcc_major)


@click.group(cls=_Group)
def meta() -> None:
    """colcon.meta files."""


@click.command("write")
@_PRESET
@_toolchain_option("Add what this target needs (transport, atomics).")
@_TRANSPORT
@_METAS
@_SETS
@_output_option("Write here instead of standard output.")
def meta_write(
    preset: str,
    toolchain: str | None,
    transport: str | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    output: Path | None,
) -> None:
    """Write a colcon.meta (JSON, sorted keys)."""
    listings.write_meta(preset, toolchain, transport, metas, sets, output)


@click.command()
@click.option(
    "--toolchain", "--target", "toolchains", cls=_Option, aliases=("--target",), multiple=True,
    help="A target name (see `uros targets`) or your own CMake toolchain file; repeat it to build "
    "several targets in one run (default: uros.yaml's target or targets).",
    shell_complete=_complete_targets,
)  # fmt: skip
@click.option(
    "--profile",
    type=_PATH,
    help="Your own target profile (.yaml; `uros targets show NAME` prints one to start from).",
)
@_workspace_option("The firmware workspace.")
@_METAS
@_SETS
@_PRESET
@_TRANSPORT
@_output_option("Output folder (default: <workspace>/build/<target>).")
@click.option(
    "--packages",
    "packages",
    multiple=True,
    metavar="PKG",
    help="The packages the firmware wants (repeatable); the core and the extra packages are added, "
    "and only their closure is built (default: uros.yaml's packages:, else every package).",
    shell_complete=_complete_packages,
)
@click.option(
    "--for-firmware",
    type=_PATH,
    metavar="DIR",
    help="Build what the firmware in DIR uses: the interface packages its C/C++ sources include "
    "(<pkg/msg/...>) or take type support of, plus the core and the extra packages.",
)
@click.option(
    "--packages-up-to",
    multiple=True,
    help="Build exactly these packages and their dependencies (colcon's).",
    shell_complete=_complete_packages,
)
@click.option("-j", "--jobs", type=int, help="Packages built in parallel (colcon --parallel-workers).")
@click.option(
    "--compiler-prefix",
    help="Derive a target: this compiler prefix (e.g. arm-none-eabi-) instead of the profile's.",
)
@click.option(
    "--cflags", multiple=True, metavar="FLAG",
    help="Derive a target: one more compiler flag (repeatable; one flag each, never split).",
)  # fmt: skip
@click.option(
    "--idf-build", type=_PATH, metavar="DIR",
    help="An ESP-IDF project's build folder (after idf.py reconfigure): compile micro-ROS against "
    "its components, sdkconfig.h and C flags (default: uros.yaml's idf_build).",
)  # fmt: skip
@click.option(
    "--cache", metavar="URL",
    help="A team cache of outputs: file:///DIR or http(s)://HOST/PATH (GET/PUT: nginx WebDAV, "
    "bazel-remote, Artifactory...). An output built elsewhere with the same build key is taken "
    "from it, checked, instead of building (default: uros.yaml's cache:; none: no cache).",
)  # fmt: skip
@click.option(
    "--cache-upload", is_flag=True,
    help="Upload this build's output to the cache (CI); without it the cache is only read. "
    "Credentials: $UROS_CACHE_TOKEN or ~/.netrc, never in the URL.",
)  # fmt: skip
@click.option(
    "--ccache/--no-ccache", default=None,
    help="Compile through ccache (default: when it is installed); the library is the same either way.",
)  # fmt: skip
@click.option("--force", is_flag=True, help="Write into an --output folder holding other files (kept).")
@click.option(
    "--rebuild", is_flag=True, help="Run every step even when no input changed (the cache is not read)."
)
@_VERBOSE
def build(
    toolchains: tuple[str, ...],
    profile: Path | None,
    workspace: Path | None,
    metas: tuple[Path, ...],
    sets: tuple[str, ...],
    preset: str,
    transport: str | None,
    output: Path | None,
    packages: tuple[str, ...],
    for_firmware: Path | None,
    packages_up_to: tuple[str, ...],
    jobs: int | None,
    compiler_prefix: str | None,
    cflags: tuple[str, ...],
    idf_build: Path | None,
    cache: str | None,
    cache_upload: bool,
    ccache: bool | None,
    force: bool,
    rebuild: bool,
    verbose: bool,
) -> None:
    """Build libmicroros.a, its include tree and a CMake package for a target (default: the
    target or targets in the workspace's uros.yaml)."""
    build_cmd.build_all(
        BuildArgs(
            workspace=workspace,
            toolchain=toolchains[0] if len(toolchains) == 1 else None,
            toolchains=toolchains,
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
            idf_build=idf_build,
            rebuild=rebuild,
            packages=packages,
            for_firmware=for_firmware,
            cache=cache,
            cache_upload=cache_upload,
            ccache=ccache,
        )
    )


@click.command()
@click.argument("library", type=_PATH)
@_toolchain_option("The target the library must fit (see `uros targets`).")
@click.option("--profile", type=_PATH, help="Or your own target profile (.yaml).")
@_VERBOSE
@click.option("--json", "as_json", is_flag=True, help="Print the verdict as JSON.")
def check(library: Path, toolchain: str | None, profile: Path | None, verbose: bool, as_json: bool) -> None:
    """Check that every object in LIBRARY has the ELF facts of a target (exit 5 if not)."""
    check_cmd.check_library(library, toolchain, profile, verbose, as_json)


@click.command()
@_toolchain_option("The target whose trees and output to remove (default: uros.yaml's target).")
@click.option("--all", "everything", is_flag=True, help="Every target built in the workspace.")
@_workspace_option("The workspace to clean.")
def clean(toolchain: str | None, everything: bool, workspace: Path | None) -> None:
    """Remove uros's per-target trees (.uros/targets/<target>) and outputs (build/<target>), never
    anything uros did not write, and say how much that freed."""
    clean_cmd.clean(workspace, toolchain, everything)


@click.command()
@_toolchain_option("Also check this target's compiler, C library and C++ headers (default: uros.yaml's).")
@_workspace_option("The workspace whose state to check.")
@click.option("--json", "as_json", is_flag=True, help="Print the checks as JSON.")
def doctor(toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """Check that this host can build (tools, target compiler, disk) and the workspace's state;
    one line per check with its fix, exit 5 when a build would fail."""
    doctor_cmd.doctor(workspace, toolchain, as_json)


@click.command()
@click.argument("output", type=_PATH, required=False)
@_toolchain_option("Or the output of this target in the workspace (default: uros.yaml's target).")
@_workspace_option("The workspace whose output to read.")
@_JSON
def info(output: Path | None, toolchain: str | None, workspace: Path | None, as_json: bool) -> None:
    """What a built library contains: ROS 2 types, packages and their commits, options in force,
    flags, sizes (OUTPUT: a `uros build` output folder)."""
    info_cmd.show_info(output, workspace, toolchain, as_json)


@click.command()
@click.argument("library", type=_PATH, required=False)
@_toolchain_option("Or the library built for this target in the workspace (default: uros.yaml's).")
@_workspace_option("The workspace whose library to measure.")
@click.option("--elf", type=_PATH, help="The firmware ELF linked against the library (with --map).")
@click.option("--map", "map_file", type=_PATH, help="The firmware's GNU ld map file (-Wl,-Map=app.map).")
@click.option("--objects", is_flag=True, help="Also list every object of the library.")
@_JSON
def size(
    library: Path | None,
    toolchain: str | None,
    workspace: Path | None,
    elf: Path | None,
    map_file: Path | None,
    objects: bool,
    as_json: bool,
) -> None:
    """text/data/bss of libmicroros.a per package (LIBRARY: the .a or its output folder), and with
    the firmware's map file what each package costs once linked (after --gc-sections)."""
    size_cmd.show_size(library, workspace, toolchain, elf, map_file, objects, as_json)


@click.command("options")
@_JSON
def meta_options(as_json: bool) -> None:
    """The memory and entity options per package (RMW_UXRCE_MAX_*, history, MTU): upstream default,
    what uros's default preset builds with, and what a larger value costs; --set is checked
    against them."""
    columns = (("package", "PACKAGE"), ("option", "OPTION"), ("default", "DEFAULT"), ("preset", "PRESET"))
    _table(listings.options_table(), as_json, (*columns, ("cost", "COST")))


@click.group(cls=_Group)
def export() -> None:
    """Packages for firmware build systems."""


def _export_command(
    name: str, what: str, output_help: str, run: Callable[[Path | None, Path], Path]
) -> click.Command:
    """One `uros export KIND --output DIR [--from DIR]` command: every kind but arduino has this shape."""

    @click.command(name, help=what)
    @_output_option(output_help, required=True)
    @_FROM
    def command(output: Path, source: Path | None) -> None:
        run(source, output)

    return command


# kind, what it writes (its --help), where (--output's help), the command
_EXPORTS = (
    ("cmake", "Write microrosConfig.cmake (find_package) and microros.cmake (include) for a build output.",
     "Folder of the CMake package.", export_cmd.export_cmake),
    ("esp-idf", "Write an ESP-IDF component (CMakeLists.txt, idf_component.yml, the library) for ESP32.",
     "Folder of the ESP-IDF component.", export_cmd.export_esp_idf),
    ("make", "Write microros.mk (MICROROS_CFLAGS, MICROROS_LIBS, MICROROS_CPU_FLAGS) for a Make firmware.",
     "Folder of microros.mk (and a copy of the output with --from).", export_cmd.export_make),
    ("pkg-config", "Write microros.pc (relocatable) for pkg-config.", "Folder of microros.pc.",
     export_cmd.export_pkg_config),
    ("meson", "Write a Meson cross file (compiler, CPU flags) and microros.pc for dependency('microros').",
     "Folder of microros-cross.ini and microros.pc.", export_cmd.export_meson),
    ("platformio", "Write library.json: the output as a PlatformIO library for lib_deps = file://...",
     "Folder of the PlatformIO library (library.json).", export_cmd.export_platformio),
    ("zephyr", "Write a Zephyr module (zephyr/module.yml, CMakeLists.txt, Kconfig) around the library.",
     "Folder of the Zephyr module.", export_cmd.export_zephyr),
)  # fmt: skip
_EXPORT_COMMANDS = tuple(_export_command(*row) for row in _EXPORTS)


@click.command("arduino")
@_output_option("Folder of the Arduino library.", required=True)
@click.option(
    "--from", "sources", type=_PATH, multiple=True, required=True,
    help="A `uros build` output (repeat: one per board, e.g. cortex-m4f and cortex-m7).",
)  # fmt: skip
def export_arduino(output: Path, sources: tuple[Path, ...]) -> None:
    """Write a precompiled Arduino library (library.properties, src/<mcu>/<fpu>-<abi>/libmicroros.a)."""
    export_cmd.export_arduino(sources, output)


@click.command("create-firmware")
@click.argument("platform", default=defaults.PLATFORM)
@click.option(
    "--distro",
    default=defaults.DISTRO,
    show_default=True,
    help="micro-ROS distro (see `uros distros`).",
    shell_complete=_complete_distros,
)
@_workspace_option("Workspace folder to create.")
@click.option(
    "--mirror", "mirrors", multiple=True, metavar="UPSTREAM=LOCAL",
    help="Rewrite URLs, e.g. 'https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo'.",
)  # fmt: skip
@click.option(
    "--mirror-override", "overrides", multiple=True, metavar="REPO=URL[@VERSION]",
    help="One repository from elsewhere (REPO: workspace path like uros/rclc, or owner/repo).",
)  # fmt: skip
@click.option("--config", type=_PATH, help="A uros.yaml with a mirror: section (rules, overrides).")
@click.option("--locked", is_flag=True, help="Clone exactly the commits in <workspace>/uros.lock.")
@click.option("--lock-file", type=_PATH, help="Clone exactly the commits in this lock file.")
@click.option(
    "--extra-package", "extra_packages", multiple=True, type=_PATH,
    help="A package folder (e.g. custom interfaces) to build with micro-ROS (repeatable).",
)  # fmt: skip
@click.option("--force", is_flag=True, help="Re-clone the repositories its uros.lock lists (keeps the rest).")
@click.option("--keep-partial", is_flag=True, help="Keep what was created when a step fails.")
@click.option(
    "--no-dev-build", is_flag=True, help="Do not build the host tools now (the first `uros build` will)."
)
@_toolchain_option("Check this target's compiler, C library and C++ headers before cloning.")
@click.option(
    "--git-jobs", "jobs", type=int, default=defaults.CLONE_JOBS, show_default=True,
    help="Parallel git clones (`uros build -j` is colcon's parallel packages).",
)  # fmt: skip
@_VERBOSE
def create_firmware(
    platform: str,
    distro: str,
    workspace: Path | None,
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
    create_cmd.create_firmware(
        CreateArgs(
            workspace,
            distro,
            platform,
            mirrors,
            overrides,
            config,
            locked,
            lock_file,
            extra_packages,
            force,
            keep_partial,
            not no_dev_build,
            toolchain,
            jobs,
            verbose,
        )
    )


@click.command("update")
@_workspace_option("Firmware workspace.")
@click.option(
    "--distro",
    default=None,
    help="Move to this distro's branches (default: the workspace's own, from uros.yaml).",
    shell_complete=_complete_distros,
)
@click.option(
    "--before",
    metavar="YYYY-MM-DD",
    help="The newest commits before this day instead (a consistent snapshot of branches that move apart).",
)
@click.option("--dry-run", is_flag=True, help="Fetch and show what would move; change nothing.")
@click.option(
    "--git-jobs", "jobs", type=int, default=defaults.CLONE_JOBS, show_default=True,
    help="Parallel git fetches (`uros build -j` is colcon's parallel packages).",
)  # fmt: skip
@_VERBOSE
def update(
    workspace: Path | None, distro: str | None, before: str | None, dry_run: bool, jobs: int, verbose: bool
) -> None:
    """Move the workspace's clones to the newest commits of their branches (no re-clone), show what
    moved and write uros.lock."""
    update_cmd.update(
        UpdateArgs(
            directory=workspace, distro=distro, before=before, dry_run=dry_run, jobs=jobs, verbose=verbose
        )
    )


@click.command("probe")
@click.argument("output", required=False, type=_PATH)
@_workspace_option("Firmware workspace (its output of --toolchain, or its only one).")
@_toolchain_option("The target whose output to probe.")
@click.option("--agent", help="A MicroXRCEAgent program (default: $UROS_AGENT).")
@click.option(
    "--timeout", type=float, default=60.0, show_default=True, help="Seconds the firmware may take in QEMU."
)
@click.option("--json", "as_json", is_flag=True, help="The result as JSON on stdout.")
@_VERBOSE
def probe(
    output: Path | None,
    workspace: Path | None,
    toolchain: str | None,
    agent: str | None,
    timeout: float,
    as_json: bool,
    verbose: bool,
) -> None:
    """Run a built library: boot a probe firmware in QEMU against a real Micro XRCE-DDS Agent."""
    probe_cmd.probe(output, workspace, toolchain, agent, timeout, as_json, verbose)


@click.command("add-package")
@click.argument("source")
@_workspace_option("Firmware workspace.")
@click.option("--version", help="Branch or tag, for a git URL.")
@_VERBOSE
def add_package(source: str, workspace: Path | None, version: str | None, verbose: bool) -> None:
    """Add a package (a folder, kept in sync at every build, or a git URL) to the MCU workspace."""
    add_package_cmd.add_package(source, workspace, version, verbose)


@click.group(cls=_Group)
def interface() -> None:
    """Custom interface packages (.msg, .srv)."""


@click.command("new")
@click.argument("name")
@click.option("--msg", "msgs", multiple=True, type=_PATH, help="A .msg file (repeatable).")
@click.option("--srv", "srvs", multiple=True, type=_PATH, help="A .srv file (repeatable).")
@_output_option("Package folder (default: ./NAME).")
@click.option("--force", is_flag=True, help="Write into an existing folder.")
def interface_new(
    name: str, msgs: tuple[Path, ...], srvs: tuple[Path, ...], output: Path | None, force: bool
) -> None:
    """Scaffold an interface package NAME from .msg/.srv files (package.xml, CMakeLists.txt)."""
    interface_cmd.interface_new(name, list(msgs), list(srvs), output, force)


# The one registry: (group, command), in the order `uros --help` lists them.
_REGISTRY: tuple[tuple[click.Group, click.Command], ...] = (
    (cli, build),
    (cli, create_firmware),
    (cli, update),
    (cli, add_package),
    (cli, check),
    (cli, clean),
    (cli, doctor),
    (cli, info),
    (cli, size),
    (cli, probe),
    (cli, targets),
    (targets, targets_show),
    (cli, distros),
    (cli, toolchain),
    (toolchain, toolchain_render),
    (cli, meta),
    (meta, meta_write),
    (meta, meta_options),
    (cli, export),
    *((export, command) for command in _EXPORT_COMMANDS),
    (export, export_arduino),
    (cli, interface),
    (interface, interface_new),
)
for _group, _command in _REGISTRY:
    _group.add_command(_command)


def _internal_error(exc: BaseException) -> None:
    """An exception uros did not expect: one line on the console, the traceback in the run log."""
    log = proc.current_log() or proc.new_run_log(proc.user_log_dir(), "error")
    try:
        with log.open("a", encoding="utf-8") as handle:
            handle.write("\n" + "".join(traceback.format_exception(exc)))
        where = f"the traceback is in {log}"
    except OSError:
        where = "rerun with --debug for the traceback"
    console.error(f"internal error: {type(exc).__name__}: {exc}", f"{where}; please report it")


def _on_signal(signum: int, _frame: object) -> None:
    raise Signalled(signum)


def main(argv: list[str] | None = None) -> None:
    debug = "--debug" in (argv if argv is not None else sys.argv[1:])
    # SIGTERM (`timeout`, a cancelled CI job, `docker stop`) and SIGHUP stop uros like Ctrl-C: the
    # tools it runs are stopped, the previous output stays, and the exit code is 128 + the signal.
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, _on_signal)
    try:
        cli.main(args=argv, prog_name="uros", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        # click turns KeyboardInterrupt into Abort; the signal is on the original exception
        cause = exc if isinstance(exc, KeyboardInterrupt) else exc.__context__
        stopped = interrupted(cause, "interrupted", "the previous output was left untouched")
        console.error(stopped.message, stopped.hint)
        sys.exit(stopped.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except UrosError as exc:
        if debug:
            traceback.print_exc()
        console.error(exc.message, exc.hint)
        sys.exit(exc.exit_code)
    except OSError as exc:
        if debug:
            traceback.print_exc()
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
            _internal_error(exc)
            sys.exit(1)
        # uros's own writes (the log, a staging folder, build-info.json) on a full disk
        where = exc.filename or proc.current_log() or Path.cwd()
        full = DiskFull.at(where, f"writing {where}: {exc.strerror}")
        console.error(full.message, full.hint)
        sys.exit(full.exit_code)
    except Exception as exc:
        if debug:
            traceback.print_exc()
        _internal_error(exc)
        sys.exit(1)
    sys.exit(0)
