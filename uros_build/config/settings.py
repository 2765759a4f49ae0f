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
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from uros_build import defaults

if TYPE_CHECKING:  # only the table's types: the workspace's files and what they import are not
    # needed to make the table, which every `uros` start makes (start-up cost)
    from uros_build.sources.wsfiles import WorkspaceConfig

T = TypeVar("T")

# ---------------------------------------------------------------------------------------------
# the table

DEFAULT = "default"  # the source of a value no one gave


ENV = "UROS_<NAME>"  # a row's environment variable: UROS_ and the row's name in capitals


@dataclass(frozen=True)
class CommandLine:
    """How `uros build` offers a row on its command line: what click needs besides the row's
    ``flag`` (its spelling), ``name`` (the option's and BuildArgs' field) and ``meaning`` (the help).
    cli/build.py makes the options from these, in the table's order; config/buildargs.py refuses, at
    import, a BuildArgs field without such a row or such a row without a field."""

    kind: str = "value"  # "value"; "flag": on when given; "switch": --x/--no-x (None when neither)
    type: str = "text"  # "text", "path" or "int"
    choices: tuple[str, ...] = ()  # the only values it takes (its metavar: them, with |)
    multiple: bool = False  # repeatable: a tuple of every value given
    metavar: str | None = None  # the value's name in --help (None: click's, from the type)
    complete: str | None = None  # what the shell completes: "targets", "packages" or "sets"
    help: str | None = None  # the --help text (None: the meaning as a sentence)
    aliases: tuple[str, ...] = ()  # old spellings that still work, out of --help
    show_default: bool = False  # --help says the default (its default_text)

    def __post_init__(self) -> None:
        if self.kind not in ("value", "flag", "switch") or self.type not in ("text", "path", "int"):
            raise TypeError(f"CommandLine: kind {self.kind!r} or type {self.type!r} is none uros knows")


@dataclass(frozen=True)
class Setting(Generic[T]):
    """One row of the table: where a setting can be given, its default and what it means."""

    name: str  # the field of BuildArgs it comes from on the command line (and its name in `-v`)
    flag: str | None  # the command line's spelling (None: no flag)
    key: str | None  # the uros.yaml key (None: none)
    env: str | None  # the environment variable: ENV (UROS_<NAME>) or None
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
    # how `uros build` offers it (None: no option of uros build; its flag, if any, is another command's)
    option: CommandLine | None = None

    def __post_init__(self) -> None:
        # the environment's name is the row's: one spelling, and none that drifts from the name
        derived = f"UROS_{self.name.upper()}"
        if self.env == ENV:
            object.__setattr__(self, "env", derived)
        elif self.env is not None and self.env != derived:
            raise TypeError(
                f"setting {self.name}: its environment variable is ENV ({derived}), not {self.env}"
            )
        if self.option is not None and (self.flag is None or "build" not in self.commands):
            raise TypeError(
                f"setting {self.name}: an option of uros build needs a flag and 'build' in commands"
            )

    @property
    def help(self) -> str:
        """The option's --help text: its own, else the meaning as a sentence."""
        if self.option is not None and self.option.help is not None:
            return self.option.help
        return self.meaning[:1].upper() + self.meaning[1:] + "."


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

TARGETS: Setting[tuple[str, ...]] = Setting(
    "toolchains", "--toolchain", "target / targets", None, (), "none: an error",
    "the target(s): a shipped target name, a profile file (.yaml, as --profile) or your own CMake "
    "toolchain file; several build one after the other, each into build/<target>",
    commands=_TARGETED, unless=("profile", "compiler_prefix", "cflags"), from_config=_targets_of,
    option=CommandLine(
        multiple=True, complete="targets", aliases=("--target",),
        help="A target name (see `uros targets`) or your own CMake toolchain file; repeat it to build "
        "several targets in one run (default: uros.yaml's target or targets).",
    ),
)  # fmt: skip
PROFILE: Setting[Path | None] = Setting(
    "profile", "--profile", None, None, None, "none",
    "your own target profile (.yaml; `uros targets show NAME` prints one to start from)",
    option=CommandLine(type="path"),
)  # fmt: skip
WORKSPACE: Setting[Path | None] = Setting(
    "workspace", "-w/--workspace", None, None, None, defaults.WORKSPACE_HELP,
    "the firmware workspace (a folder with mcu_ws/, or a colcon workspace)",
    commands=("build", "clean", "doctor", "info", "size", "probe", "create-firmware", "update",
              "add-package"),
    option=CommandLine(type="path", aliases=("--dir",), show_default=True, help="The firmware workspace."),
)  # fmt: skip
METAS: Setting[tuple[Path, ...]] = Setting(
    "metas", "--meta", None, None, (), "the workspace's colcon.meta",
    "colcon.meta files merged on top: the workspace's colcon.meta first, then each --meta",
    commands=("build", "meta write"),
    option=CommandLine(type="path", multiple=True, help="A colcon.meta merged on top (repeatable)."),
)  # fmt: skip
SETS: Setting[tuple[str, ...]] = Setting(
    "sets", "--set", "set", None, (), "none",
    "PKG.OPTION=VALUE, CMake options of packages: uros.yaml's first, then --set's (adds up)",
    commands=("build", "meta write"), adds=True,
    option=CommandLine(
        multiple=True, metavar="PKG.OPTION=VALUE", complete="sets", help="Set a CMake option of a package."
    ),
)  # fmt: skip
PRESET: Setting[str] = Setting(
    "preset", "--preset", None, None, defaults.PRESET, defaults.PRESET,
    "the colcon.meta starting point (meta/presets/; the distro's own when it has one)",
    commands=("build", "meta write"),
    option=CommandLine(show_default=True, help="colcon.meta starting point (meta/presets/)."),
)  # fmt: skip
TRANSPORT: Setting[str | None] = Setting(
    "transport", "--transport", "transport", None, None, "the target's",
    "the XRCE-DDS transport: custom, udp or serial",
    option=CommandLine(help="XRCE-DDS transport: custom, udp or serial (default: the target's)."),
)  # fmt: skip
OUTPUT: Setting[Path | None] = Setting(
    "output", "-o/--output", None, None, None, "<workspace>/build/<target>", "the output folder",
    option=CommandLine(type="path", help="Output folder (default: <workspace>/build/<target>)."),
)  # fmt: skip
DISTRO: Setting[str | None] = Setting(
    "distro", "--distro", "distro", None, None,
    f"none: uros's own preset (create-firmware: {defaults.DISTRO})",
    "the micro-ROS distro: which clones create-firmware makes and update moves to (update needs one); "
    "a build takes its colcon.meta preset",
    commands=("build", "update"), from_config=_distro_of,
)  # fmt: skip
PACKAGES: Setting[tuple[str, ...]] = Setting(
    "packages", "--packages", "packages", None, (), "every package",
    "what the firmware wants (the core and the extra packages are added); not read from uros.yaml "
    "with --for-firmware",
    unless=("for_firmware",),
    option=CommandLine(
        multiple=True, metavar="PKG", complete="packages",
        help="The packages the firmware wants (repeatable); the core and the extra packages are added, "
        "and only their closure is built (default: uros.yaml's packages:, else every package).",
    ),
)  # fmt: skip
FOR_FIRMWARE: Setting[Path | None] = Setting(
    "for_firmware", "--for-firmware", None, None, None, "none",
    "build what the firmware's C/C++ sources in this folder use",
    option=CommandLine(
        type="path", metavar="DIR",
        help="Build what the firmware in DIR uses: the interface packages its C/C++ sources include "
        "(<pkg/msg/...>) or take type support of, plus the core and the extra packages.",
    ),
)  # fmt: skip
PACKAGES_UP_TO: Setting[tuple[str, ...]] = Setting(
    "packages_up_to", "--packages-up-to", None, None, (), "none",
    "build exactly these packages and their dependencies (colcon's)",
    option=CommandLine(multiple=True, complete="packages"),
)  # fmt: skip
JOBS: Setting[int | None] = Setting(
    "jobs", "-j/--jobs", None, None, None, "colcon's",
    "packages built in parallel (colcon --parallel-workers)",
    option=CommandLine(type="int"),
)  # fmt: skip
COMPILER_PREFIX: Setting[str | None] = Setting(
    "compiler_prefix", "--compiler-prefix", None, None, None, "the profile's",
    "derive a target: this compiler prefix (e.g. arm-none-eabi-) instead of the profile's",
    option=CommandLine(),
)  # fmt: skip
CFLAGS: Setting[tuple[str, ...]] = Setting(
    "cflags", "--cflags", None, None, (), "none",
    "derive a target: one more compiler flag (repeatable; one flag each, never split)",
    option=CommandLine(multiple=True, metavar="FLAG"),
)  # fmt: skip
IDF_BUILD: Setting[Path | None] = Setting(
    "idf_build", "--idf-build", "idf_build", None, None, "none",
    "an ESP-IDF project's build folder to compile against (uros.yaml's: for an ESP-IDF target only, "
    "relative to the workspace)",
    from_config=_idf_build_of,
    option=CommandLine(
        type="path", metavar="DIR",
        help="An ESP-IDF project's build folder (after idf.py reconfigure): compile micro-ROS against "
        "its components, sdkconfig.h and C flags (default: uros.yaml's idf_build).",
    ),
)  # fmt: skip
RTOS: Setting[str | None] = Setting(
    "rtos", "--rtos", "rtos", None, None, "none (bare metal)",
    "the RTOS micro-ROS is compiled against: freertos (needs rtos_dir and rtos_config; docs/rtos.md)",
    option=CommandLine(
        choices=("freertos",),
        help="Compile micro-ROS against an RTOS: freertos, with --rtos-dir and --rtos-config "
        "(default: uros.yaml's rtos:; docs/rtos.md).",
    ),
)  # fmt: skip
RTOS_DIR: Setting[Path | None] = Setting(
    "rtos_dir", "--rtos-dir", "rtos_dir", None, None, "none",
    "the RTOS kernel's folder (FreeRTOS-Kernel: holds include/FreeRTOS.h and portable/; uros.yaml's: "
    "relative to the workspace)",
    from_config=_rtos_folder("rtos_dir"),
    option=CommandLine(
        type="path", metavar="KERNEL",
        help="The FreeRTOS-Kernel folder (holds include/FreeRTOS.h and portable/).",
    ),
)  # fmt: skip
RTOS_CONFIG: Setting[Path | None] = Setting(
    "rtos_config", "--rtos-config", "rtos_config", None, None, "none",
    "the folder holding your FreeRTOSConfig.h (uros.yaml's: relative to the workspace)",
    from_config=_rtos_folder("rtos_config"),
    option=CommandLine(type="path", metavar="DIR", help="The folder holding your FreeRTOSConfig.h."),
)  # fmt: skip
RTOS_PORT: Setting[str | None] = Setting(
    "rtos_port", "--rtos-port", "rtos_port", None, None, "the core's (meta/rtos/freertos.yaml)",
    "the kernel's port folder under portable/ (e.g. GCC/ARM_CM4F), or an absolute folder "
    "(default: the core's, meta/rtos/freertos.yaml)",
    option=CommandLine(metavar="PORT"),
)  # fmt: skip
IP_STACK: Setting[str | None] = Setting(
    "ip_stack", "--ip-stack", "ip_stack", None, None, "none",
    "the IP stack the udp transport is compiled against: lwip or freertos-tcp (needs an RTOS, "
    "ip_stack_dir and ip_stack_config; docs/network.md)",
    option=CommandLine(
        choices=("lwip", "freertos-tcp"),
        help="Compile the udp transport against an IP stack: lwip or freertos-tcp, with --ip-stack-dir and "
        "--ip-stack-config (needs --rtos; default: uros.yaml's ip_stack:; docs/network.md).",
    ),
)  # fmt: skip
IP_STACK_DIR: Setting[Path | None] = Setting(
    "ip_stack_dir", "--ip-stack-dir", "ip_stack_dir", None, None, "none",
    "the IP stack's folder (lwIP: holds src/include/lwip/ and contrib/; FreeRTOS+TCP: source/; "
    "uros.yaml's: relative to the workspace)",
    from_config=_rtos_folder("ip_stack_dir"),
    option=CommandLine(
        type="path", metavar="DIR",
        help="The stack's folder (lwIP: src/include/lwip/, contrib/; FreeRTOS+TCP: source/).",
    ),
)  # fmt: skip
IP_STACK_CONFIG: Setting[Path | None] = Setting(
    "ip_stack_config", "--ip-stack-config", "ip_stack_config", None, None, "none",
    "the folder holding your lwipopts.h and arch/cc.h, or FreeRTOSIPConfig.h (uros.yaml's: relative to "
    "the workspace)",
    from_config=_rtos_folder("ip_stack_config"),
    option=CommandLine(
        type="path", metavar="DIR", help="The folder of your lwipopts.h and arch/cc.h, or FreeRTOSIPConfig.h."
    ),
)  # fmt: skip
CACHE: Setting[str | None] = Setting(
    "cache", "--cache", "cache", None, None, "none",
    "the team cache of outputs: file:///DIR or http(s)://...; none: no cache for this build",
    option=CommandLine(
        metavar="URL",
        help="A team cache of outputs: file:///DIR or http(s)://HOST/PATH (GET/PUT: nginx WebDAV, "
        "bazel-remote, Artifactory...). An output built elsewhere with the same build key is taken "
        "from it, checked, instead of building (default: uros.yaml's cache:; none: no cache).",
    ),
)  # fmt: skip
CACHE_TIMEOUT: Setting[float] = Setting(
    "cache_timeout", None, None, ENV, defaults.CACHE_TIMEOUT_SECONDS,
    f"{defaults.CACHE_TIMEOUT_SECONDS:g} seconds",
    "how long an HTTP team cache may stay silent (seconds; more than 0, less than a day)",
    from_env=_seconds,
)  # fmt: skip
CACHE_UPLOAD: Setting[bool] = Setting(
    "cache_upload", "--cache-upload", None, None, False, "off",
    "upload this build's output to the team cache",
    option=CommandLine(
        kind="flag",
        help="Upload this build's output to the cache (CI); without it the cache is only read. "
        "Credentials: $UROS_CACHE_TOKEN or ~/.netrc, never in the URL.",
    ),
)  # fmt: skip
CCACHE: Setting[bool | None] = Setting(
    "ccache", "--ccache/--no-ccache", None, None, None, "when installed",
    "compile through ccache (default: when it is installed); the library is the same either way",
    option=CommandLine(kind="switch"),
)  # fmt: skip
FORCE: Setting[bool] = Setting(
    "force", "--force", None, None, False, "off", "write into an --output folder holding other files (kept)",
    option=CommandLine(kind="flag"),
)  # fmt: skip
REBUILD: Setting[bool] = Setting(
    "rebuild", "--rebuild", None, None, False, "off",
    "run every step even when no input changed (the cache is not read)",
    option=CommandLine(kind="flag"),
)  # fmt: skip
VERBOSE: Setting[bool] = Setting(
    "verbose", "-v/--verbose", None, None, False, "off",
    "print every setting in force and who chose it (docs/settings.md), and stream the tools' output",
    option=CommandLine(kind="flag"),
)  # fmt: skip
HOST_STAGE: Setting[bool] = Setting(
    "host_stage", None, None, ENV, True, "on",
    "off (or 0, false, no): configure and install every package for each target (no host stage; "
    "docs/cache.md)",
    from_env=_switch,
)  # fmt: skip
COMPILER_SEED: Setting[bool] = Setting(
    "compiler_seed", None, None, ENV, True, "on",
    "off (or 0, false, no): every package's configure finds the compilers itself",
    from_env=_switch,
)  # fmt: skip
GEN_CACHE: Setting[bool] = Setting(
    "gen_cache", None, None, ENV, True, "on",
    "off (or 0, false, no): every generator run and configure call runs as CMake asks (no generation cache)",
    from_env=_switch,
)  # fmt: skip
GEN_CACHE_DIR: Setting[Path] = Setting(
    "gen_cache_dir", None, None, ENV, Path("~/.cache/uros/gen"),
    "$XDG_CACHE_HOME/uros/gen (~/.cache/uros/gen)",
    "the user's generation and configure-call cache, shared by every workspace",
    from_env=_path, default_from_env=_user_cache,
)  # fmt: skip
AGENT: Setting[str | None] = Setting(
    "agent", "--agent", None, ENV, None, "none", "the MicroXRCEAgent program `uros probe` runs",
    commands=("probe", "doctor"),
)  # fmt: skip
ROS2_VENV: Setting[Path] = Setting(
    "ros2_venv", None, None, ENV, Path("~/.cache/uros/ros2"),
    "$XDG_CACHE_HOME/uros/ros2 (~/.cache/uros/ros2)",
    "where `uros probe --peer` keeps its ROS 2 environment (a venv of PyPI's ros-* wheels, one per set "
    "of pinned versions) and the host builds of the workspace's interface packages",
    commands=("probe",), from_env=_path, default_from_env=_ros2_cache,
)  # fmt: skip

FREERTOS: Setting[str | None] = Setting(
    "freertos", "--freertos", None, ENV, None, "none",
    "a FreeRTOS-Kernel checkout: `uros probe --freertos DIR` runs the probe firmware on FreeRTOS; "
    "$UROS_FREERTOS names the kernel only when a FreeRTOS library's own is gone",
    commands=("probe",),
)  # fmt: skip
LWIP: Setting[str | None] = Setting(
    "lwip", None, None, ENV, None, "none",
    "an lwIP tree: `uros probe` of a library built with --ip-stack lwip compiles it when the library's "
    "own lwIP folder is gone",
    commands=("probe",),
)  # fmt: skip
FREERTOS_TCP: Setting[str | None] = Setting(
    "freertos_tcp", None, None, ENV, None, "none",
    "a FreeRTOS+TCP tree: `uros probe` of a library built with --ip-stack freertos-tcp compiles it when "
    "the library's own folder is gone",
    commands=("probe",),
)  # fmt: skip

# The table: every row above, in the order they are written, which is the order `uros build --help`
# lists its options, `uros build -v` prints the settings and docs/settings.md lists them. A row
# written here is in it: there is no second list to forget it in.
SETTINGS: tuple[Setting[Any], ...] = tuple(v for v in dict(globals()).values() if isinstance(v, Setting))
if len({s.name for s in SETTINGS}) != len(SETTINGS):
    raise TypeError(f"two settings of one name: {sorted(s.name for s in SETTINGS)}")


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
