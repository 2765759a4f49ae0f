"""The workspace's own files, as data: uros.yaml (what create-firmware made and the user edits:
distro, mirror rules, extra packages, what `uros build` is told without flags) and uros.lock (the
commit of every cloned repository). Parsing is strict and every error names the file and the key;
edits are line edits that keep the user's comments. Reads and writes files; starts no process.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from uros_build import __version__, defaults, loader
from uros_build.errors import ConfigError, did_you_mean
from uros_build.files import write_if_changed
from uros_build.sources import distros as distros_mod
from uros_build.sources.distros import Mirror, Source
from uros_build.sources.meta import split_set
from uros_build.target.ipstack import NAMES as IP_STACK_NAMES
from uros_build.target.profiles import TRANSPORTS
from uros_build.target.rtos import NAMES as RTOS_NAMES

CONFIG = defaults.WORKSPACE_MARKER  # "uros.yaml"
LOCK = "uros.lock"
EXTRA = "extra_packages"  # mcu_ws/extra_packages: the user's packages, synced at every build
# The workspace's folders (sources/workspace.py draws them; Workspace gives their paths)
MCU_WS = "mcu_ws"  # the sources colcon builds for the MCU
DEV_WS = "dev_ws"  # the host tools' workspace
STATE = ".uros"  # uros's own: colcon's trees per target, logs, caches


# ---------------------------------------------------------------------------------------------
# uros.yaml


@dataclass(frozen=True)
class WorkspaceConfig:
    # "": none. Only create-firmware and update need a distro (to choose and move clones); a build
    # needs none (a plain colcon workspace with a uros.yaml of `target: cortex-m7` builds).
    distro: str = ""
    platform: str = "generate_lib"
    mirror: Mirror = field(default_factory=Mirror)
    extra_packages: tuple[str, ...] = ()  # source folders synced into mcu_ws/extra_packages
    # What `uros build` would otherwise be told on every command line (the command line wins):
    target: str | None = None  # the target `uros build` builds without --toolchain
    targets: tuple[str, ...] = ()  # or several: `uros build` builds each
    transport: str | None = None  # XRCE-DDS transport (default: the target's)
    set: tuple[str, ...] = ()  # PKG.OPTION=VALUE, before --set's
    packages: tuple[str, ...] = ()  # the packages a build is for (see `uros build --help`)
    # An ESP-IDF project's build folder (after `idf.py reconfigure`), relative to the workspace
    # or absolute: micro-ROS is compiled against its components, sdkconfig.h and C flags.
    idf_build: str | None = None
    # The RTOS micro-ROS is compiled against (docs/rtos.md): `freertos`, its kernel's folder and
    # the folder of FreeRTOSConfig.h (relative to the workspace or absolute), the port when not
    # the core's.
    rtos: str | None = None
    rtos_dir: str | None = None
    rtos_config: str | None = None
    rtos_port: str | None = None
    # The IP stack the udp transport is compiled against (docs/network.md): `lwip`, its folder and
    # the folder of lwipopts.h and arch/cc.h (relative to the workspace or absolute).
    ip_stack: str | None = None
    ip_stack_dir: str | None = None
    ip_stack_config: str | None = None
    # A team cache of outputs (file:///DIR or http(s)://...): `uros build` takes a matching output
    # from it instead of building; only `uros build --cache-upload` writes to it.
    cache: str | None = None


_CONFIG_KEYS = {f.name for f in fields(WorkspaceConfig)}


def parse_config(data: Any, source: str) -> WorkspaceConfig:
    """uros.yaml, or a --config file read for its mirror section; every key is optional (`uros update`
    asks for the distro: :func:`require_distro`)."""
    top = loader.mapping(data, source, _CONFIG_KEYS)
    target = loader.string(top, "target", source) if top.get("target") is not None else None
    targets = loader.string_list(top, "targets", source)
    if target is not None and targets:
        raise ConfigError(f"{source}: target and targets: give one of them", "targets: [a, b] builds several")
    transport = loader.string(top, "transport", source) if top.get("transport") is not None else None
    if transport is not None and transport not in TRANSPORTS:
        raise ConfigError(
            f"{source}: transport: unknown transport {transport!r}{did_you_mean(transport, TRANSPORTS)}",
            f"known: {', '.join(TRANSPORTS)}",
        )
    sets = loader.string_list(top, "set", source)
    for item in sets:
        split_set(item, f"{source}: set:")
    return WorkspaceConfig(
        distro=loader.string(top, "distro", source) if "distro" in top else "",
        platform=loader.one_of(top, "platform", source, (defaults.PLATFORM,), defaults.PLATFORM),
        mirror=distros_mod.load_mirror_config(
            loader.mapping(top.get("mirror"), f"{source}: mirror"), f"{source}"
        ),
        extra_packages=loader.string_list(top, "extra_packages", source),
        target=target,
        targets=targets,
        transport=transport,
        set=sets,
        packages=_package_names(loader.string_list(top, "packages", source), f"{source}: packages"),
        idf_build=loader.string(top, "idf_build", source) if top.get("idf_build") is not None else None,
        rtos=loader.one_of(top, "rtos", source, RTOS_NAMES) if top.get("rtos") is not None else None,
        **{k: _optional_string(top, k, source) for k in ("rtos_dir", "rtos_config", "rtos_port")},
        ip_stack=loader.one_of(top, "ip_stack", source, IP_STACK_NAMES)
        if top.get("ip_stack") is not None
        else None,
        **{k: _optional_string(top, k, source) for k in ("ip_stack_dir", "ip_stack_config")},
        cache=loader.string(top, "cache", source) if top.get("cache") is not None else None,
    )


def _optional_string(top: Mapping[str, Any], key: str, source: str) -> str | None:
    return loader.string(top, key, source) if top.get(key) is not None else None


_PACKAGE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def _package_names(names: tuple[str, ...], where: str) -> tuple[str, ...]:
    for name in names:
        if not _PACKAGE_NAME.fullmatch(name):
            raise ConfigError(
                f"{where}: {name!r} is not a package name", "e.g. packages: [std_msgs, my_msgs]"
            )
    return names


def load_config(root: Path) -> WorkspaceConfig | None:
    path = root / CONFIG
    if not path.is_file():
        return None
    hint = "fix the file or re-create the workspace with `uros create-firmware --force`"
    return parse_config(loader.load_yaml(path, hint=hint), str(path))


def config_text(cfg: WorkspaceConfig) -> str:
    data: dict[str, Any] = {
        "platform": cfg.platform,
        "mirror": distros_mod.mirror_to_config(cfg.mirror),
        "extra_packages": list(cfg.extra_packages),
    }
    # the keys users add themselves, written back only when set (add-package rewrites the file)
    optional = {
        "distro": cfg.distro or None,
        "target": cfg.target,
        "transport": cfg.transport,
        "idf_build": cfg.idf_build,
        "rtos": cfg.rtos,
        "rtos_dir": cfg.rtos_dir,
        "rtos_config": cfg.rtos_config,
        "rtos_port": cfg.rtos_port,
        "ip_stack": cfg.ip_stack,
        "ip_stack_dir": cfg.ip_stack_dir,
        "ip_stack_config": cfg.ip_stack_config,
        "cache": cfg.cache,
    }
    data.update({k: v for k, v in optional.items() if v is not None})
    lists = {"targets": cfg.targets, "set": cfg.set, "packages": cfg.packages}
    data.update({k: list(v) for k, v in lists.items() if v})
    header = f"# Written by uros {__version__} create-firmware; edit freely (uros build reads it).\n"
    import yaml  # here and in the edits below: most starts write no uros.yaml (start-up cost)

    return header + yaml.safe_dump(data, sort_keys=True)


def save_config(root: Path, cfg: WorkspaceConfig) -> None:
    write_if_changed(root / CONFIG, config_text(cfg))


def with_distro(text: str, distro: str, source: str) -> str:
    """uros.yaml's text with its top-level ``distro:`` line set to ``distro``, everything else (the
    user's comments, order, other keys) as it was (pure). A file whose distro is not on one plain
    line is refused rather than rewritten; a file without one (a build needs none) gets one at its end."""
    import yaml

    pattern = re.compile(r"^distro:[ \t]*([^#\n]*?)[ \t]*(#.*)?$", re.MULTILINE)
    found = list(pattern.finditer(text))
    if not found and not parse_config(yaml.safe_load(text) or {}, source).distro:
        sep = "" if not text or text.endswith("\n") else "\n"
        return _checked_distro(f"{text}{sep}distro: {distro}\n", distro, source)
    if len(found) != 1:
        raise ConfigError(
            f"{source}: no single top-level 'distro:' line to change",
            f"set 'distro: {distro}' in the file yourself, then run `uros update` again",
        )
    match = found[0]
    comment = f"  {match.group(2)}" if match.group(2) else ""
    edited = text[: match.start()] + f"distro: {distro}{comment}" + text[match.end() :]
    return _checked_distro(edited, distro, source)


def _checked_distro(edited: str, distro: str, source: str) -> str:
    import yaml

    if parse_config(yaml.safe_load(edited), source).distro != distro:
        raise ConfigError(f"{source}: could not set 'distro: {distro}'", "set it in the file yourself")
    return edited


def with_extra_package(text: str, entry: str, source: str) -> str:
    """uros.yaml's text with ``entry`` appended to its top-level ``extra_packages:`` list, every
    other line (the user's comments, order, keys) as it was (pure). The value is written as a JSON
    string, which YAML reads as the same string whatever it holds. A list uros cannot extend by a
    line edit is refused rather than the file rewritten."""
    import yaml

    value = json.dumps(entry)
    before = parse_config(yaml.safe_load(text) or {}, source).extra_packages
    lines = text.splitlines(keepends=True)
    key = next((i for i, line in enumerate(lines) if line.startswith("extra_packages:")), None)
    if key is None:
        sep = "" if not text or text.endswith("\n") else "\n"
        edited = f"{text}{sep}extra_packages:\n- {value}\n"
    else:
        rest = lines[key][len("extra_packages:") :].rstrip("\n")
        flow = re.fullmatch(r"\s*\[(.*)\]\s*(#.*)?", rest)
        if flow is not None:
            inner = flow.group(1).strip()
            comment = f"  {flow.group(2)}" if flow.group(2) else ""
            lines[key] = f"extra_packages: [{inner + ', ' if inner else ''}{value}]{comment}\n"
        elif re.fullmatch(r"\s*(#.*)?", rest):
            at, item = key + 1, "- "
            while at < len(lines) and (found := re.match(r"\s*- ", lines[at])) is not None:
                item, at = found.group(0), at + 1
            lines.insert(at, f"{item}{value}\n")
        else:
            lines = []
        edited = "".join(lines)
    try:
        after = parse_config(yaml.safe_load(edited), source).extra_packages
    except (ConfigError, yaml.YAMLError):
        after = ()
    if after != (*before, entry):
        raise ConfigError(
            f"{source}: extra_packages: uros cannot add {entry} to this list without rewriting the file",
            f"add it yourself (a line '- {value}' under extra_packages:)",
        )
    return edited


def find_workspace(start: Path) -> Path | None:
    """The nearest folder from ``start`` upward that holds a uros.yaml (west's topdir search)."""
    start = start.resolve()
    for folder in (start, *start.parents):
        if (folder / CONFIG).is_file():
            return folder
    return None


# ---------------------------------------------------------------------------------------------
# uros.lock


@dataclass(frozen=True)
class LockedRepo:
    url: str  # upstream
    version: str  # the manifest's branch/tag
    source: str  # what was cloned (after mirror rules)
    commit: str
    # what stood in (an override replaced the manifest's repository or version: distros.stand_in_label)
    # and why: the lock says plainly which clones are not the manifest's own
    stand_in: str = ""
    why: str = ""

    @classmethod
    def of(cls, source: Source, commit: str) -> LockedRepo:
        o = source.stand_in
        return cls(
            source.repo.url,
            source.repo.version,
            source.url,
            commit,
            stand_in=distros_mod.stand_in_label(source),
            why=o.reason if o is not None else "",
        )

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "url": self.url,
            "version": self.version,
            "source": self.source,
            "commit": self.commit,
        }
        if self.stand_in:
            data["stand_in"] = {"use": self.stand_in, "why": self.why}
        return data


@dataclass(frozen=True)
class Lock:
    distro: str
    repositories: Mapping[str, LockedRepo]

    @classmethod
    def from_clones(cls, distro: str, sources: Mapping[str, Source], commits: Mapping[str, str]) -> Lock:
        return cls(
            distro,
            {p: LockedRepo.of(s, commits[p]) for p, s in sources.items()},
        )

    def commits(self) -> dict[str, str]:
        return {path: r.commit for path, r in self.repositories.items()}

    def to_json(self, command: str = "create-firmware") -> str:
        data = {
            "generated_by": f"uros {__version__} {command}",
            "distro": self.distro,
            "repositories": {path: r.to_dict() for path, r in sorted(self.repositories.items())},
        }
        return json.dumps(data, indent=2, sort_keys=True) + "\n"


def check_clone_path(path: str, where: str) -> str:
    """A repository's place in the workspace: inside dev_ws/ or mcu_ws/, never elsewhere. A lock
    names what `create-firmware --force` deletes, so a path like '../..' or 'mcu_ws' must not
    pass."""
    parts = path.split("/")
    if (
        len(parts) < 2
        or parts[0] not in (DEV_WS, MCU_WS)
        or any(p in ("", ".", "..") for p in parts)
        or parts[:2] == [MCU_WS, EXTRA]
        or "\\" in path
    ):
        raise ConfigError(
            f"{where}: {path!r} is not a repository folder inside dev_ws/ or mcu_ws/",
            "uros.lock is written by `uros create-firmware`: restore it, or re-create the workspace",
        )
    return path


def parse_lock(data: Any, source: str) -> Lock:
    top = loader.mapping(data, source, required=("repositories",))
    repos = loader.mapping(top["repositories"], f"{source}: repositories")
    out = {}
    for path, entry in repos.items():
        where = f"{source}: repositories.{path}"
        check_clone_path(str(path), f"{source}: repositories")
        item = loader.mapping(entry, where, required=("commit",))
        stand_in = loader.mapping(item.get("stand_in"), f"{where}.stand_in", {"use", "why"})
        out[str(path)] = LockedRepo(
            url=str(item.get("url", "")),
            version=str(item.get("version", "")),
            source=str(item.get("source", "")),
            commit=loader.string(item, "commit", where),
            stand_in=str(stand_in.get("use", "")),
            why=str(stand_in.get("why", "")),
        )
    return Lock(str(top.get("distro", "")), out)


def read_lock(path: Path, flag: str) -> Lock:
    # The fix depends on what pointed here: "create the workspace once without --locked" was the
    # hint of every command, also of `uros update`, `doctor` and `--lock-file`, where it could not work.
    if not path.is_file():
        missing = {
            "--locked": f"the first `uros create-firmware` (without --locked) writes {path.name}; "
            "to re-create another workspace's commits, pass --lock-file PATH",
            "--lock-file": "pass the uros.lock of a workspace (`uros create-firmware` writes one there)",
        }
        raise ConfigError(f"{flag} {path}: no such lock file", missing.get(flag))
    hint = (
        f"restore {path.name} (from version control or a copy): uros needs it to know which clones it "
        "made, and writes it only when it clones"
    )
    return parse_lock(loader.load_json(path, flag, hint), f"{flag} {path}")


def clone_state(status: str) -> tuple[str, int]:
    """(HEAD commit, number of changed tracked files) from ``git status --porcelain=v2 --branch
    --untracked-files=no`` (https://git-scm.com/docs/git-status#_porcelain_format_version_2)."""
    head = ""
    changed = 0
    for line in status.splitlines():
        if line.startswith("# branch.oid "):
            head = line.split()[2]
        elif line and not line.startswith("#"):
            changed += 1
    return head, changed
