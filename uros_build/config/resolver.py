"""The one resolver every command reads its settings through (config/settings.py holds the table):
each row through the precedence, the command line over the environment over uros.yaml over the
default, each value with who chose it (:class:`Chosen`), which error messages name and
`uros build -v` prints; and the workspace every command works in (one default for all). Nothing
here starts a process."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar, cast

from uros_build import defaults
from uros_build.config.settings import DEFAULT, SETTINGS, WORKSPACE, Setting
from uros_build.errors import ConfigError
from uros_build.sources.workspace import Workspace
from uros_build.sources.wsfiles import CONFIG, WorkspaceConfig, find_workspace

T = TypeVar("T")

# ---------------------------------------------------------------------------------------------
# the resolver


@dataclass(frozen=True)
class Chosen(Generic[T]):
    """A setting's value and who chose it: a flag (``--transport``), a uros.yaml line
    (``/ws/uros.yaml: transport``), an environment variable (``$UROS_HOST_STAGE``) or ``default``."""

    value: T
    source: str


def _given(value: object) -> bool:
    """A value the command line (or uros.yaml) gave: None and an empty list are "not given"; an
    empty string is given (``--cache ""``)."""
    return value is not None and value != ()


def resolve_one(
    setting: Setting[T],
    flags: Mapping[str, object],
    cfg: WorkspaceConfig | None,
    root: Path,
    env: Mapping[str, str],
) -> Chosen[T]:
    """One row through the precedence (the module's docstring): the command line, the environment,
    uros.yaml, the default."""
    given = flags.get(setting.name)
    blocked = any(_given(flags.get(name)) for name in setting.unless)
    configured: tuple[T, str] | None = None
    if cfg is not None and setting.key is not None and not blocked:
        if setting.from_config is not None:
            configured = setting.from_config(cfg, root)
        else:
            value = getattr(cfg, setting.key)
            configured = (value, setting.key) if _given(value) else None
    where = f"{root / CONFIG}: {configured[1]}" if configured else ""
    if setting.adds:
        # uros.yaml's first, then the command line's: a later value wins where they meet
        parts: list[tuple[object, str]] = [(configured[0], where)] if configured else []
        parts += [(given, str(setting.flag))] if _given(given) else []
        if not parts:
            return Chosen(setting.default, DEFAULT)
        total = tuple(item for value, _ in parts for item in cast(tuple[Any, ...], value))
        return Chosen(cast(T, total), ", then ".join(source for _, source in parts))
    if _given(given):
        return Chosen(cast(T, given), str(setting.flag))
    text = env.get(setting.env) if setting.env and not blocked else None
    if text:  # an empty variable is an unset one
        return Chosen(_from_env(setting, text), f"${setting.env}")
    if configured is not None:
        return Chosen(configured[0], where)
    if setting.default_from_env is not None:
        return Chosen(setting.default_from_env(env), DEFAULT)
    return Chosen(setting.default, DEFAULT)


def _from_env(setting: Setting[T], text: str) -> T:
    """The environment's text as the row's value; one it cannot be is one line naming the variable."""
    if setting.from_env is None:
        return cast(T, text)
    try:
        return setting.from_env(text)
    except ValueError as bad:
        raise ConfigError(
            f"${setting.env}={text.strip()!r} is no {setting.name} value",
            f"{bad} (or unset it: {setting.default_text})",
        ) from None


@dataclass(frozen=True)
class Resolved:
    """Every setting a command reads, each with who chose it."""

    chosen: Mapping[str, Chosen[Any]]

    def __getitem__(self, setting: Setting[T]) -> Chosen[T]:
        return cast(Chosen[T], self.chosen[setting.name])

    def value(self, setting: Setting[T]) -> T:
        return self[setting].value

    def lines(self) -> list[str]:
        """One line a setting, in the table's order: its value and where it came from (`uros build -v`)."""
        out = []
        for setting in SETTINGS:
            if setting.name in self.chosen:
                chosen = self.chosen[setting.name]
                out.append(f"{setting.name} = {shown(setting, chosen.value)}  ({chosen.source})")
        return out


def shown(setting: Setting[Any], value: object) -> str:
    """A value as `uros build -v` prints it."""
    if value is None:
        return setting.default_text
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, tuple):
        return ", ".join(str(v) for v in value) if value else setting.default_text
    return str(value)


def resolve(
    flags: Mapping[str, object],
    cfg: WorkspaceConfig | None,
    root: Path,
    env: Mapping[str, str],
    rows: tuple[Setting[Any], ...] = SETTINGS,
) -> Resolved:
    """The settings ``rows`` (all by default) for a command: ``flags`` (the command line's values
    by row name; None or () for not given), ``cfg`` (the uros.yaml of the workspace at ``root``;
    None: there is none) and ``env`` (the environment). Pure."""
    chosen: dict[str, Chosen[Any]] = {}
    for setting in rows:
        if setting is WORKSPACE:
            given = flags.get(setting.name) is not None
            chosen[setting.name] = Chosen(root, str(setting.flag) if given else _found_where(root))
        else:
            chosen[setting.name] = resolve_one(setting, flags, cfg, root, env)
    return Resolved(chosen)


def resolve_outside(
    setting: Setting[T], given: T | None = None, env: Mapping[str, str] | None = None
) -> Chosen[T]:
    """A setting read outside a workspace (the agent of `uros probe` and `uros doctor`): the command
    line's value, else the environment's, else the default."""
    return resolve_one(setting, {setting.name: given}, None, Path(), os.environ if env is None else env)


def _found_where(root: Path) -> str:
    return f"{root / CONFIG}: found upward" if (root / CONFIG).is_file() else DEFAULT


# ---------------------------------------------------------------------------------------------
# the workspace: one default for every command


def resolve_workspace(given: Path | None, cwd: Path | None = None) -> Path:
    """-w/--workspace as given, else the nearest folder upward with a uros.yaml, else ./firmware."""
    if given is not None:
        return given
    here = cwd if cwd is not None else Path.cwd()
    found = find_workspace(here)
    return found if found is not None else here / defaults.FIRMWARE_DIR


def open_workspace(given: Path | None, cwd: Path | None = None) -> Workspace:
    """The workspace a build runs in. Without -w, a folder that is no uros workspace is refused
    before anything is written: run in the wrong folder, a build would crawl every project below
    it for packages and leave .uros/ and build/ behind."""
    path = resolve_workspace(given, cwd)
    if given is None and not path.exists():
        here = cwd if cwd is not None else Path.cwd()
        raise ConfigError(
            f"no uros workspace here: no {CONFIG} in {here} or above it, and no ./{defaults.FIRMWARE_DIR}",
            "cd into a firmware workspace, create one with `uros create-firmware generate_lib` "
            "(makes ./firmware), or pass -w DIR (a colcon workspace with packages works too)",
        )
    return Workspace.open(path)
