"""Every setting of uros, in one table (issue 30 item 4; model: pypa/cibuildwheel's options.py,
where every option goes through one ``OptionsReader.get``): where each can be given (a flag, a
uros.yaml key, an environment variable), its default and what it means.

The precedence, the same for every row: **the command line, then the environment, then the
workspace's uros.yaml, then uros's default**. The environment comes before uros.yaml because it is
this machine's or this run's say (a cache folder, a switch for a comparison), while uros.yaml is the
project's, shared by everyone who checks it out: the nearer one wins, as in cibuildwheel
(``CIBW_*`` over pyproject.toml), cargo and pip. A row that adds up (``set``) takes uros.yaml's
values first and the command line's after them, so that a later value of an option wins. A row's
``unless`` names the flags whose presence makes uros.yaml's value not apply (``--for-firmware``
reads what the firmware wants: uros.yaml's ``packages:`` is not added to it).

Every command resolves what it reads through config/resolver.py (`uros build` and the commands
that find a target's folders: clean, info, size, probe, doctor); `uros build`'s command line is
config/buildargs.py. The table is printed in docs/settings.md (:func:`markdown_table`; a unit test
keeps the page and the code the same). Nothing here starts a process; plan.py validates the values
(profiles, metas, packages, folders).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

from uros_build import defaults
from uros_build.output.team_cache import TIMEOUT_SECONDS
from uros_build.sources.wsfiles import WorkspaceConfig

T = TypeVar("T")

# ---------------------------------------------------------------------------------------------
# the table

DEFAULT = "default"  # the source of a value no one gave


@dataclass(frozen=True)
class Setting(Generic[T]):
    """One row of the table: where a setting can be given, its default and what it means."""

    name: str  # the field of BuildArgs it comes from on the command line (and its name in `-v`)
    flag: str | None  # the command line's spelling (None: no flag)
    key: str | None  # the uros.yaml key (None: none)
    env: str | None  # the environment variable (None: none)
    default: T
    default_text: str  # the default as the docs and `-v` say it
    meaning: str
    commands: tuple[str, ...] = ("build",)  # the commands that read it
    adds: bool = False  # a list: uros.yaml's values first, then the command line's
    unless: tuple[str, ...] = ()  # rows whose flag makes uros.yaml's (and the environment's) value not apply
    # the environment's text as a value (None: the text itself)
    from_env: Callable[[str], T] | None = None
    # uros.yaml's value and the key it came from (None: getattr(config, key), when not None/empty)
    from_config: Callable[[WorkspaceConfig, Path], tuple[T, str] | None] | None = None
    # a default that depends on the environment (the XDG cache folder)
    default_from_env: Callable[[Mapping[str, str]], T] | None = None


_ON = ("on", "1", "true", "yes")
_OFF = ("off", "0", "false", "no")


def _switch(text: str) -> bool:
    """An on/off switch of the environment: on/1/true/yes or off/0/false/no (any case); any other
    word is refused (ValueError), never taken as on: a switch that says ``0`` means off."""
    word = text.strip().lower()
    if word in _ON or word in _OFF:
        return word in _ON
    raise ValueError(f"set it to off (or 0, false, no) or on (or 1, true, yes), not {text.strip()!r}")


def _path(text: str) -> Path:
    return Path(text).expanduser()


def _targets_of(cfg: WorkspaceConfig, root: Path) -> tuple[tuple[str, ...], str] | None:
    if cfg.targets:
        return cfg.targets, "targets"
    return ((cfg.target,), "target") if cfg.target else None


def _distro_of(cfg: WorkspaceConfig, root: Path) -> tuple[str | None, str] | None:
    return (cfg.distro, "distro") if cfg.distro else None  # "": the file has no distro: line


def _idf_build_of(cfg: WorkspaceConfig, root: Path) -> tuple[Path | None, str] | None:
    # relative to the workspace (or absolute)
    return (root / cfg.idf_build, "idf_build") if cfg.idf_build else None


def _rtos_folder(key: str) -> Callable[[WorkspaceConfig, Path], tuple[Path | None, str] | None]:
    """uros.yaml's rtos_dir / rtos_config / ip_stack_dir / ip_stack_config: a folder relative to the
    workspace (or absolute)."""

    def read(cfg: WorkspaceConfig, root: Path) -> tuple[Path | None, str] | None:
        value = getattr(cfg, key)
        return (root / Path(value).expanduser(), key) if value else None

    return read


def _seconds(text: str) -> float:
    """A wait in seconds, more than 0 and less than a day; anything else is refused (ValueError):
    a typo in a CI variable must neither make the team cache wait forever or never, nor be
    replaced by the default without a word."""
    try:
        seconds = float(text)
    except ValueError:
        seconds = float("nan")
    if not 0 < seconds < 86400:  # nan and inf too
        raise ValueError(f"give seconds, more than 0 and less than 86400 (a day), not {text.strip()!r}")
    return seconds


def _user_cache(env: Mapping[str, str]) -> Path:
    """uros/gen in the XDG cache folder (~/.cache), beside ccache's own."""
    return Path(env.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")) / "uros" / "gen"


def _ros2_cache(env: Mapping[str, str]) -> Path:
    """uros/ros2 in the XDG cache folder (~/.cache): the peer's ROS 2 environments."""
    return Path(env.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")) / "uros" / "ros2"


_TARGETED = ("build", "clean", "doctor", "info", "size", "probe")

WORKSPACE: Setting[Path | None] = Setting(
    "workspace", "-w/--workspace", None, None, None, defaults.WORKSPACE_HELP,
    "the firmware workspace (a folder with mcu_ws/, or a colcon workspace)",
    commands=("build", "clean", "doctor", "info", "size", "probe", "create-firmware", "update",
              "add-package"),
)  # fmt: skip
TARGETS: Setting[tuple[str, ...]] = Setting(
    "toolchains", "--toolchain", "target / targets", None, (), "none: an error",
    "the target(s): a shipped target name, a profile file (.yaml, as --profile) or your own CMake "
    "toolchain file; several build one after the other, each into build/<target>",
    commands=_TARGETED, unless=("profile", "compiler_prefix", "cflags"), from_config=_targets_of,
)  # fmt: skip
PROFILE: Setting[Path | None] = Setting(
    "profile", "--profile", None, None, None, "none",
    "your own target profile (.yaml) instead of a target name",
)  # fmt: skip
COMPILER_PREFIX: Setting[str | None] = Setting(
    "compiler_prefix", "--compiler-prefix", None, None, None, "the profile's",
    "derive a target with this compiler prefix",
)  # fmt: skip
CFLAGS: Setting[tuple[str, ...]] = Setting(
    "cflags", "--cflags", None, None, (), "none", "derive a target with these compiler flags (repeatable)"
)
OUTPUT: Setting[Path | None] = Setting(
    "output", "-o/--output", None, None, None, "<workspace>/build/<target>", "the output folder"
)
DISTRO: Setting[str | None] = Setting(
    "distro", "--distro", "distro", None, None,
    f"none: uros's own preset (create-firmware: {defaults.DISTRO})",
    "the micro-ROS distro: which clones create-firmware makes and update moves to (update needs one); "
    "a build takes its colcon.meta preset",
    commands=("build", "update"), from_config=_distro_of,
)  # fmt: skip
TRANSPORT: Setting[str | None] = Setting(
    "transport", "--transport", "transport", None, None, "the target's",
    "the XRCE-DDS transport: custom, udp or serial",
)  # fmt: skip
PRESET: Setting[str] = Setting(
    "preset", "--preset", None, None, defaults.PRESET, defaults.PRESET,
    "the colcon.meta starting point (meta/presets/; the distro's own when it has one)",
    commands=("build", "meta write"),
)  # fmt: skip
METAS: Setting[tuple[Path, ...]] = Setting(
    "metas", "--meta", None, None, (), "the workspace's colcon.meta",
    "colcon.meta files merged on top: the workspace's colcon.meta first, then each --meta",
    commands=("build", "meta write"),
)  # fmt: skip
SETS: Setting[tuple[str, ...]] = Setting(
    "sets", "--set", "set", None, (), "none",
    "PKG.OPTION=VALUE, CMake options of packages: uros.yaml's first, then --set's (adds up)",
    commands=("build", "meta write"), adds=True,
)  # fmt: skip
PACKAGES: Setting[tuple[str, ...]] = Setting(
    "packages", "--packages", "packages", None, (), "every package",
    "what the firmware wants (the core and the extra packages are added); not read from uros.yaml "
    "with --for-firmware",
    unless=("for_firmware",),
)  # fmt: skip
FOR_FIRMWARE: Setting[Path | None] = Setting(
    "for_firmware", "--for-firmware", None, None, None, "none",
    "build what the firmware's C/C++ sources in this folder use",
)  # fmt: skip
PACKAGES_UP_TO: Setting[tuple[str, ...]] = Setting(
    "packages_up_to", "--packages-up-to", None, None, (), "none",
    "exactly these packages and their dependencies (colcon's)",
)  # fmt: skip
JOBS: Setting[int | None] = Setting(
    "jobs", "-j/--jobs", None, None, None, "colcon's", "packages built in parallel"
)
IDF_BUILD: Setting[Path | None] = Setting(
    "idf_build", "--idf-build", "idf_build", None, None, "none",
    "an ESP-IDF project's build folder to compile against (uros.yaml's: for an ESP-IDF target only, "
    "relative to the workspace)",
    from_config=_idf_build_of,
)  # fmt: skip
RTOS: Setting[str | None] = Setting(
    "rtos", "--rtos", "rtos", None, None, "none (bare metal)",
    "the RTOS micro-ROS is compiled against: freertos (needs rtos_dir and rtos_config; docs/rtos.md)",
)  # fmt: skip
RTOS_DIR: Setting[Path | None] = Setting(
    "rtos_dir", "--rtos-dir", "rtos_dir", None, None, "none",
    "the RTOS kernel's folder (FreeRTOS-Kernel: holds include/FreeRTOS.h and portable/; uros.yaml's: "
    "relative to the workspace)",
    from_config=_rtos_folder("rtos_dir"),
)  # fmt: skip
RTOS_CONFIG: Setting[Path | None] = Setting(
    "rtos_config", "--rtos-config", "rtos_config", None, None, "none",
    "the folder holding your FreeRTOSConfig.h (uros.yaml's: relative to the workspace)",
    from_config=_rtos_folder("rtos_config"),
)  # fmt: skip
RTOS_PORT: Setting[str | None] = Setting(
    "rtos_port", "--rtos-port", "rtos_port", None, None, "the core's (meta/rtos/freertos.yaml)",
    "the kernel's port folder under portable/ (GCC/ARM_CM4F), or an absolute folder",
)  # fmt: skip
IP_STACK: Setting[str | None] = Setting(
    "ip_stack", "--ip-stack", "ip_stack", None, None, "none",
    "the IP stack the udp transport is compiled against: lwip or freertos-tcp (needs an RTOS, "
    "ip_stack_dir and ip_stack_config; docs/network.md)",
)  # fmt: skip
IP_STACK_DIR: Setting[Path | None] = Setting(
    "ip_stack_dir", "--ip-stack-dir", "ip_stack_dir", None, None, "none",
    "the IP stack's folder (lwIP: holds src/include/lwip/ and contrib/; FreeRTOS+TCP: source/; "
    "uros.yaml's: relative to the workspace)",
    from_config=_rtos_folder("ip_stack_dir"),
)  # fmt: skip
IP_STACK_CONFIG: Setting[Path | None] = Setting(
    "ip_stack_config", "--ip-stack-config", "ip_stack_config", None, None, "none",
    "the folder holding your lwipopts.h and arch/cc.h, or FreeRTOSIPConfig.h (uros.yaml's: relative to "
    "the workspace)",
    from_config=_rtos_folder("ip_stack_config"),
)  # fmt: skip
CACHE: Setting[str | None] = Setting(
    "cache", "--cache", "cache", None, None, "none",
    "the team cache of outputs: file:///DIR or http(s)://...; none: no cache for this build",
)  # fmt: skip
CACHE_TIMEOUT: Setting[float] = Setting(
    "cache_timeout", None, None, "UROS_CACHE_TIMEOUT", TIMEOUT_SECONDS, f"{TIMEOUT_SECONDS:g} seconds",
    "how long an HTTP team cache may stay silent (seconds; more than 0, less than a day)",
    from_env=_seconds,
)  # fmt: skip
CACHE_UPLOAD: Setting[bool] = Setting(
    "cache_upload", "--cache-upload", None, None, False, "off", "upload this build's output to the team cache"
)
CCACHE: Setting[bool | None] = Setting(
    "ccache", "--ccache/--no-ccache", None, None, None, "when installed", "compile through ccache"
)
FORCE: Setting[bool] = Setting(
    "force", "--force", None, None, False, "off", "write into an --output folder holding other files"
)
REBUILD: Setting[bool] = Setting(
    "rebuild", "--rebuild", None, None, False, "off", "run every step even when no input changed"
)
VERBOSE: Setting[bool] = Setting(
    "verbose", "-v/--verbose", None, None, False, "off",
    "stream the tools' output; print these settings and where each came from",
)  # fmt: skip
HOST_STAGE: Setting[bool] = Setting(
    "host_stage", None, None, "UROS_HOST_STAGE", True, "on",
    "off (or 0, false, no): configure and install every package for each target (no host stage; "
    "docs/cache.md)",
    from_env=_switch,
)  # fmt: skip
COMPILER_SEED: Setting[bool] = Setting(
    "compiler_seed", None, None, "UROS_COMPILER_SEED", True, "on",
    "off (or 0, false, no): every package's configure finds the compilers itself",
    from_env=_switch,
)  # fmt: skip
GEN_CACHE: Setting[bool] = Setting(
    "gen_cache", None, None, "UROS_GEN_CACHE", True, "on",
    "off (or 0, false, no): every generator run and configure call runs as CMake asks (no generation cache)",
    from_env=_switch,
)  # fmt: skip
GEN_CACHE_DIR: Setting[Path] = Setting(
    "gen_cache_dir", None, None, "UROS_GEN_CACHE_DIR", Path("~/.cache/uros/gen"),
    "$XDG_CACHE_HOME/uros/gen (~/.cache/uros/gen)",
    "the user's generation and configure-call cache, shared by every workspace",
    from_env=_path, default_from_env=_user_cache,
)  # fmt: skip
AGENT: Setting[str | None] = Setting(
    "agent", "--agent", None, "UROS_AGENT", None, "none", "the MicroXRCEAgent program `uros probe` runs",
    commands=("probe", "doctor"),
)  # fmt: skip
ROS2_VENV: Setting[Path] = Setting(
    "ros2_venv", None, None, "UROS_ROS2_VENV", Path("~/.cache/uros/ros2"),
    "$XDG_CACHE_HOME/uros/ros2 (~/.cache/uros/ros2)",
    "where `uros probe --peer` keeps its ROS 2 environment (a venv of PyPI's ros-* wheels, one per set "
    "of pinned versions) and the host builds of the workspace's interface packages",
    commands=("probe",), from_env=_path, default_from_env=_ros2_cache,
)  # fmt: skip

FREERTOS: Setting[str | None] = Setting(
    "freertos", "--freertos", None, "UROS_FREERTOS", None, "none",
    "a FreeRTOS-Kernel checkout: `uros probe --freertos DIR` runs the probe firmware on FreeRTOS; "
    "$UROS_FREERTOS names the kernel only when a FreeRTOS library's own is gone",
    commands=("probe",),
)  # fmt: skip
LWIP: Setting[str | None] = Setting(
    "lwip", None, None, "UROS_LWIP", None, "none",
    "an lwIP tree: `uros probe` of a library built with --ip-stack lwip compiles it when the library's "
    "own lwIP folder is gone",
    commands=("probe",),
)  # fmt: skip
FREERTOS_TCP: Setting[str | None] = Setting(
    "freertos_tcp", None, None, "UROS_FREERTOS_TCP", None, "none",
    "a FreeRTOS+TCP tree: `uros probe` of a library built with --ip-stack freertos-tcp compiles it when "
    "the library's own folder is gone",
    commands=("probe",),
)  # fmt: skip

# The table, in the order `uros build -v` prints it and docs/settings.md lists it.
SETTINGS: tuple[Setting[Any], ...] = (
    WORKSPACE, TARGETS, PROFILE, COMPILER_PREFIX, CFLAGS, OUTPUT, DISTRO, TRANSPORT, PRESET, METAS, SETS,
    PACKAGES, FOR_FIRMWARE, PACKAGES_UP_TO, JOBS, IDF_BUILD, RTOS, RTOS_DIR, RTOS_CONFIG, RTOS_PORT,
    IP_STACK, IP_STACK_DIR, IP_STACK_CONFIG, CACHE, CACHE_TIMEOUT, CACHE_UPLOAD,
    CCACHE, FORCE, REBUILD, VERBOSE, HOST_STAGE, COMPILER_SEED, GEN_CACHE, GEN_CACHE_DIR, AGENT,
    ROS2_VENV,
    FREERTOS, LWIP, FREERTOS_TCP,
)  # fmt: skip


# ---------------------------------------------------------------------------------------------
# the table as the docs print it


def markdown_table() -> str:
    """The table as docs/settings.md prints it (a unit test keeps that page equal to this)."""

    def cell(text: str | None) -> str:
        return f"`{text}`" if text else "—"

    lines = [
        "| setting | command line | uros.yaml | environment | default | meaning | read by |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in SETTINGS:
        key = " / ".join(f"`{k}:`" for k in s.key.split(" / ")) if s.key else "—"
        meaning = s.meaning + (" (adds up)" if s.adds and "adds up" not in s.meaning else "")
        lines.append(
            f"| `{s.name}` | {cell(s.flag)} | {key} | {cell(s.env)} | {s.default_text} | {meaning} "
            f"| {', '.join(s.commands)} |"
        )
    return "\n".join(lines).replace("<", "&lt;").replace(">", "&gt;") + "\n"
