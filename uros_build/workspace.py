"""The firmware workspace: its layout on disk, its data files, and where uros keeps things in it.

    <workspace>/
      uros.yaml          what create-firmware made: distro, mirror rules, extra packages (edit freely)
      uros.lock          the commit of every cloned repository (`--locked` re-creates exactly these)
      colcon.meta        the distro's generate_lib meta, layered into every `uros build` (edit freely)
      mcu_ws/            sources colcon builds for the MCU (or the packages sit in <workspace> itself)
      mcu_ws/extra_packages/   the user's packages, synced from their folders at every build
      dev_ws/            host tools workspace (ament, ...), built once, shared by every target
      build/<target>/    outputs: libmicroros.a, include/, CMake package, build-info.json
      .uros/targets/<target>/{build,install,log}   colcon's trees, kept between runs per target
      .uros/log/         one log per uros run, latest.log the newest

Keeping colcon's trees per target is what makes a second build incremental (micro_ros_setup's
build.sh wipes build/install/log every time) and what lets two targets share one workspace.
This module only reads and writes files; it starts no processes.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import filelock
import yaml

from uros_build import __version__, console, defaults, loader, proc
from uros_build import distros as distros_mod
from uros_build.distros import Mirror, Source
from uros_build.errors import ConfigError, did_you_mean
from uros_build.meta import split_set
from uros_build.profiles import TRANSPORTS

CONFIG = defaults.WORKSPACE_MARKER  # "uros.yaml"
LOCK = "uros.lock"
USER_META = "colcon.meta"
EXTRA = "extra_packages"
# written by create-firmware before it clones (a lock without commits), removed when it is done: a
# folder a killed create-firmware left is recognised, and --force finishes it
PENDING = ".uros/create-firmware.pending"
DEV_MARKER = ".uros-dev-built"  # in dev_ws/install: the lock the dev workspace was built from
_IGNORE_NOTE = "uros: colcon must not look for packages here\n"


# ---------------------------------------------------------------------------------------------
# uros.yaml


@dataclass(frozen=True)
class WorkspaceConfig:
    distro: str
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
    # A team cache of outputs (file:///DIR or http(s)://...): `uros build` takes a matching output
    # from it instead of building; only `uros build --cache-upload` writes to it.
    cache: str | None = None


_CONFIG_KEYS = {f.name for f in fields(WorkspaceConfig)}


def parse_config(data: Any, source: str, partial: bool = False) -> WorkspaceConfig:
    """``partial``: a --config file, read for its mirror section, may leave the distro out (its
    other keys are checked all the same)."""
    top = loader.mapping(data, source, _CONFIG_KEYS, required=() if partial else ("distro",))
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
        distro=loader.string(top, "distro", source) if "distro" in top or not partial else "",
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
        cache=loader.string(top, "cache", source) if top.get("cache") is not None else None,
    )


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
        "distro": cfg.distro,
        "platform": cfg.platform,
        "mirror": distros_mod.mirror_to_config(cfg.mirror),
        "extra_packages": list(cfg.extra_packages),
    }
    # the keys users add themselves, written back only when set (add-package rewrites the file)
    optional = {
        "target": cfg.target,
        "transport": cfg.transport,
        "idf_build": cfg.idf_build,
        "cache": cfg.cache,
    }
    data.update({k: v for k, v in optional.items() if v is not None})
    lists = {"targets": cfg.targets, "set": cfg.set, "packages": cfg.packages}
    data.update({k: list(v) for k, v in lists.items() if v})
    header = f"# Written by uros {__version__} create-firmware; edit freely (uros build reads it).\n"
    return header + yaml.safe_dump(data, sort_keys=True)


def save_config(root: Path, cfg: WorkspaceConfig) -> None:
    write_if_changed(root / CONFIG, config_text(cfg))


def with_distro(text: str, distro: str, source: str) -> str:
    """uros.yaml's text with its top-level ``distro:`` line set to ``distro``, everything else (the
    user's comments, order, other keys) as it was (pure). A file whose distro is not on one plain
    line is refused rather than rewritten."""
    pattern = re.compile(r"^distro:[ \t]*([^#\n]*?)[ \t]*(#.*)?$", re.MULTILINE)
    found = list(pattern.finditer(text))
    if len(found) != 1:
        raise ConfigError(
            f"{source}: no single top-level 'distro:' line to change",
            f"set 'distro: {distro}' in the file yourself, then run `uros update` again",
        )
    match = found[0]
    comment = f"  {match.group(2)}" if match.group(2) else ""
    edited = text[: match.start()] + f"distro: {distro}{comment}" + text[match.end() :]
    if parse_config(yaml.safe_load(edited), source).distro != distro:
        raise ConfigError(f"{source}: could not set 'distro: {distro}'", "set it in the file yourself")
    return edited


def with_extra_package(text: str, entry: str, source: str) -> str:
    """uros.yaml's text with ``entry`` appended to its top-level ``extra_packages:`` list, every
    other line (the user's comments, order, keys) as it was (pure). The value is written as a JSON
    string, which YAML reads as the same string whatever it holds. A list uros cannot extend by a
    line edit is refused rather than the file rewritten."""
    value = json.dumps(entry)
    before = parse_config(yaml.safe_load(text) or {}, source, partial=True).extra_packages
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
        after = parse_config(yaml.safe_load(edited), source, partial=True).extra_packages
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


@dataclass(frozen=True)
class Lock:
    distro: str
    repositories: Mapping[str, LockedRepo]

    @classmethod
    def from_clones(cls, distro: str, sources: Mapping[str, Source], commits: Mapping[str, str]) -> Lock:
        return cls(
            distro,
            {p: LockedRepo(s.repo.url, s.repo.version, s.url, commits[p]) for p, s in sources.items()},
        )

    def commits(self) -> dict[str, str]:
        return {path: r.commit for path, r in self.repositories.items()}

    def to_json(self, command: str = "create-firmware") -> str:
        data = {
            "generated_by": f"uros {__version__} {command}",
            "distro": self.distro,
            "repositories": {
                path: {"url": r.url, "version": r.version, "source": r.source, "commit": r.commit}
                for path, r in sorted(self.repositories.items())
            },
        }
        return json.dumps(data, indent=2, sort_keys=True) + "\n"


def check_clone_path(path: str, where: str) -> str:
    """A repository's place in the workspace: inside dev_ws/ or mcu_ws/, never elsewhere. A lock
    names what `create-firmware --force` deletes, so a path like '../..' or 'mcu_ws' must not
    pass."""
    parts = path.split("/")
    if (
        len(parts) < 2
        or parts[0] not in ("dev_ws", "mcu_ws")
        or any(p in ("", ".", "..") for p in parts)
        or parts[:2] == ["mcu_ws", EXTRA]
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
        out[str(path)] = LockedRepo(
            url=str(item.get("url", "")),
            version=str(item.get("version", "")),
            source=str(item.get("source", "")),
            commit=loader.string(item, "commit", where),
        )
    return Lock(str(top.get("distro", "")), out)


def read_lock(path: Path, flag: str) -> Lock:
    hint = "create the workspace once without --locked"
    if not path.is_file():
        raise ConfigError(f"{flag} {path}: no such lock file", hint)
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


# ---------------------------------------------------------------------------------------------
# extra packages


def package_name(package_xml: Path) -> str:
    try:
        name = ET.parse(package_xml).getroot().findtext("name")
    except ET.ParseError as exc:
        raise ConfigError(f"{package_xml}: not valid XML: {exc}") from exc
    if not name:
        raise ConfigError(f"{package_xml}: has no <name>")
    return name.strip()


def check_extra_package(path: Path, flag: str) -> str:
    """The package name of the folder ``path``, or a ConfigError naming ``flag``."""
    if not path.is_dir():
        raise ConfigError(f"{flag} {path}: no such folder", "pass the folder of a ROS 2 package")
    xml = path / "package.xml"
    if not xml.is_file():
        raise ConfigError(
            f"{flag} {path}: no package.xml in it",
            "an extra package is a ROS 2 package folder (package.xml, CMakeLists.txt); "
            "`uros interface new` scaffolds one",
        )
    return package_name(xml)


def sync_tree(src: Path, dst: Path) -> int:
    """Make ``dst`` a copy of ``src``, touching only files whose content changed (so the build
    sees exactly what changed); returns how many files were written or removed."""
    changed = 0
    dst.mkdir(parents=True, exist_ok=True)
    wanted = set()
    for path in sorted(src.rglob("*")):
        rel = path.relative_to(src)
        if any(part.startswith(".git") for part in rel.parts):
            continue
        wanted.add(rel)
        target = dst / rel
        if path.is_dir():
            target.mkdir(parents=True, exist_ok=True)
        elif not target.is_file() or target.read_bytes() != path.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
            changed += 1
    for path in sorted(dst.rglob("*"), reverse=True):
        if path.relative_to(dst) not in wanted:
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink()
            changed += 1
    return changed


# ---------------------------------------------------------------------------------------------
# the host dev workspace


def dev_env(env: Mapping[str, str], install: Path) -> dict[str, str]:
    """What sourcing dev_ws/install/setup.bash provides, without a shell (pure)."""
    out = dict(env)
    prefix = str(install)
    out["AMENT_PREFIX_PATH"] = prefix
    out["CMAKE_PREFIX_PATH"] = prefix
    out["PATH"] = os.pathsep.join(p for p in (str(install / "bin"), env.get("PATH", "")) if p)
    sites = sorted(str(p) for p in install.glob("lib/python3*/site-packages"))
    out["PYTHONPATH"] = os.pathsep.join(
        [*sites, *(p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p)]
    )
    return out


# ---------------------------------------------------------------------------------------------
# the workspace


@dataclass(frozen=True)
class Workspace:
    root: Path

    @classmethod
    def open(cls, path: Path, flag: str = "--workspace") -> Workspace:
        """A folder holding packages (a firmware workspace or any colcon workspace)."""
        root = path.resolve()
        if not root.is_dir():
            raise ConfigError(
                f"{flag} {path}: no such folder",
                "pass a colcon workspace, or create one with `uros create-firmware generate_lib`",
            )
        check_build_folder(root, flag)
        ws = cls(root)
        if not ws.has_packages():
            raise ConfigError(
                f"{flag} {path}: not a uros workspace (no {CONFIG}) and no package.xml under {ws.source_dir}",
                "create one with `uros create-firmware generate_lib -w DIR`; a colcon workspace holds "
                "packages (folders with package.xml) in mcu_ws/ or in the folder itself",
            )
        return ws

    @classmethod
    def open_firmware(cls, path: Path, flag: str = "--workspace") -> tuple[Workspace, WorkspaceConfig]:
        """A workspace made by `uros create-firmware` (it has a uros.yaml)."""
        root = path.resolve()
        cfg = load_config(root)
        if cfg is None:
            raise ConfigError(
                f"{flag} {path}: not a firmware workspace (no {CONFIG})",
                "create one with `uros create-firmware generate_lib`, "
                "or copy the package into your workspace",
            )
        return cls(root), cfg

    # -- layout --------------------------------------------------------------------------------

    @property
    def source_dir(self) -> Path:
        mcu = self.root / "mcu_ws"
        return mcu if mcu.is_dir() else self.root

    @property
    def extra_dir(self) -> Path:
        return self.root / "mcu_ws" / EXTRA

    @property
    def state_dir(self) -> Path:
        return self.root / ".uros"

    @property
    def log_dir(self) -> Path:
        return self.state_dir / "log"

    @property
    def user_meta(self) -> Path:
        return self.root / USER_META

    @property
    def lock_path(self) -> Path:
        return self.root / LOCK

    @property
    def dev_dir(self) -> Path:
        return self.root / "dev_ws"

    @property
    def dev_install(self) -> Path:
        return self.dev_dir / "install"

    def dev_built(self) -> bool:
        return (self.dev_install / DEV_MARKER).is_file()

    def mark_dev_built(self) -> None:
        lock = self.lock_path.read_text(encoding="utf-8") if self.lock_path.is_file() else ""
        (self.dev_install / DEV_MARKER).write_text(lock, encoding="utf-8")

    def target_dir(self, key: str) -> Path:
        return _target_folder(self.state_dir / "targets", key)

    def default_output(self, key: str) -> Path:
        return _target_folder(self.root / "build", key)

    def tree_keys(self) -> list[str]:
        """The targets uros has trees of here (.uros/targets/<key>); outputs.target_keys adds
        those with only an output."""
        trees = self.state_dir / "targets"
        return sorted(p.name for p in trees.iterdir() if p.is_dir()) if trees.is_dir() else []

    def new_log(self, command: str, key: str = "") -> Path:
        return proc.new_run_log(self.log_dir, command, key)

    def has_packages(self) -> bool:
        for _dirpath, dirnames, filenames in os.walk(self.source_dir):
            if "COLCON_IGNORE" in filenames:
                dirnames[:] = []
                continue
            if "package.xml" in filenames:
                return True
            dirnames[:] = [
                d for d in dirnames if not d.startswith(".") and d not in ("build", "install", "log")
            ]
        return False

    def mark_ignored(self) -> None:
        """Keep colcon from finding installed package.xml files in uros's own folders."""
        for folder in (self.state_dir, self.root / "build"):
            folder.mkdir(parents=True, exist_ok=True)
            marker = folder / "COLCON_IGNORE"
            if not marker.exists():
                marker.write_text(_IGNORE_NOTE, encoding="utf-8")

    # -- extra packages ------------------------------------------------------------------------

    def sync_extra_packages(self, cfg: WorkspaceConfig) -> None:
        """Copy each extra package's folder into mcu_ws/extra_packages, changed files only."""
        for entry in cfg.extra_packages:
            src = Path(entry)
            if not src.is_dir():
                console.warn(
                    f"{self.root / CONFIG}: extra package {src} is gone; keeping the copy in mcu_ws/{EXTRA}"
                )
                continue
            name = check_extra_package(src, f"{self.root / CONFIG}: extra_packages")
            changed = sync_tree(src, self.extra_dir / name)
            if changed:
                console.info(f"extra package {name}: {changed} file(s) updated from {src}")


# What colcon and CMake cannot build in. colcon's generated environment scripts source paths in
# double quotes (colcon_core/shell/template/command_prefix.sh.em: . "<prefix>/share/<pkg>/package.sh"),
# where the shell expands '$' and '`' and ends at '"'; CMake writes folder paths unescaped into
# files it reads back (CMakeFiles/<version>/CMakeSystem.cmake), where '\' and ';' break them.
# Spaces, "'", '#', parentheses and '=' were built through: tests/integration/test_escaping_build.py.
_FOLDER_UNUSABLE = re.compile(r'[$`"\\;\x00-\x1f\x7f]')


def check_build_folder(root: Path, flag: str) -> None:
    """A workspace's folder is where colcon and CMake build: refuse a path they cannot use."""
    bad = _FOLDER_UNUSABLE.search(str(root))
    if bad is not None:
        raise ConfigError(
            f"{flag} {root}: colcon and CMake cannot build in a folder whose path holds {bad.group(0)!r}",
            "rename or move the folder (spaces and ' are fine)",
        )


# ---------------------------------------------------------------------------------------------
# target keys, locks, generated files, outputs


# One folder name: .uros/targets/<key> and build/<key>. Never '.', '..' or hidden, never a path.
_KEY = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


def target_key(name: str, where: str = "--toolchain") -> str:
    """The folder name of a target: its profile's name (an identifier already), or the stem of the
    user's toolchain file with anything but letters, digits, '.', '_' and '-' made '_'."""
    key = re.sub(r"[^A-Za-z0-9_.-]", "_", name)
    if not _KEY.fullmatch(key):
        raise ConfigError(
            f"{where}: {name!r} cannot name a target folder (it must start with a letter or digit)",
            "rename the file, e.g. my-board.cmake",
        )
    return key


def _target_folder(base: Path, key: str) -> Path:
    """``base/key``, checked to be one folder directly inside ``base``: whatever made ``key``, the
    trees and outputs of a target never land on the workspace or outside it."""
    path = base / key
    if not _KEY.fullmatch(key) or path.parent != base:
        raise ConfigError(f"{key!r} cannot name a target folder", "name targets with letters, digits, '.-_'")
    return path


def lock_holder(text: str) -> int | None:
    """The process id a target's lock file names (pure)."""
    first = text.split("\n", 1)[0].strip()
    return int(first) if first.isdigit() else None


@contextmanager
def locked(folder: Path, target: str) -> Iterator[None]:
    """One build per target tree at a time: a second `uros build` waits, then reuses the trees.
    filelock takes an OS lock on <folder>/.lock (flock on POSIX, msvcrt on Windows), which the
    OS releases when the process ends, however it ends. The holder writes its process id beside
    it (filelock truncates the lock file itself), so that a waiting build can say whom it waits for."""
    folder.mkdir(parents=True, exist_ok=True)
    if (folder / ".lock").is_dir() and not (folder / ".lock").is_symlink():
        raise ConfigError(
            f"{folder / '.lock'}: is a folder, where uros keeps the lock file of {target}",
            "move it away (uros does not remove what it did not write), then run the command again",
        )
    lock = filelock.FileLock(str(folder / ".lock"))
    owner = folder / ".lock.owner"
    try:
        lock.acquire(timeout=0)
    except filelock.Timeout:
        try:
            holder = lock_holder(owner.read_text(encoding="utf-8"))
        except OSError:
            holder = None
        who = f" (pid {holder})" if holder else ""
        console.info(f"waiting for another uros build of {target}{who} to finish (lock: {folder / '.lock'})")
        lock.acquire()
    try:
        owner.write_text(f"{os.getpid()}\n", encoding="utf-8")
        yield
    finally:
        lock.release()


def workspace_of_output(out: Path, key: str) -> Workspace | None:
    """The workspace an output was built in: <ws>/build/<key> beside <ws>/.uros/targets/<key>."""
    if out.parent.name != "build":
        return None
    ws = Workspace(out.parent.parent)
    return ws if ws.target_dir(key).is_dir() else None


def tree_bytes(path: Path) -> int:
    """Bytes of the files under ``path`` (links counted as links, not followed)."""
    if path.is_symlink() or path.is_file():
        return path.lstat().st_size
    total = 0
    for dirpath, _dirnames, filenames in os.walk(path):
        total += sum(os.lstat(os.path.join(dirpath, name)).st_size for name in filenames)
    return total


# What CMake's configure writes into a package's build folder and reads back at every build. A
# write that fails on a full disk leaves it empty or cut short, and every later build fails
# (ninja: "unknown build rule", CMake: "Parse error in cache file") until the folder is dropped.
CONFIGURE_FILES = (
    "CMakeCache.txt",
    "build.ninja",
    "CMakeFiles/rules.ninja",
    "Makefile",
    "CMakeFiles/Makefile2",
)
_TAIL = 4096


def configure_damage(name: str, size: int, tail: bytes) -> str | None:
    """Why a configure file is damaged, from its size and its last bytes, or None (pure). Each is
    a text file CMake writes whole, ending in a line break; the cache ends with its INTERNAL
    entries."""
    if size == 0:
        return f"{name} is empty"
    if b"\0" in tail:
        return f"{name} holds NUL bytes"
    if not tail.endswith(b"\n"):
        return f"{name} is cut short"
    if name == "CMakeCache.txt" and b":INTERNAL=" not in tail:
        return f"{name} is cut short (no INTERNAL entries at its end)"
    return None


_AR_MAGIC = b"!<arch>\n"
_AR_HEADER = 60  # https://en.wikipedia.org/wiki/Ar_(Unix)#File_header: size at 48..58, "`\n" at 58


def archive_damage(size: int, read_at: Callable[[int, int], bytes]) -> str | None:
    """Why an ar archive of ``size`` bytes is cut short or broken, or None: its member headers,
    read with ``read_at(offset, length)``, must chain exactly to its end (pure over the reader)."""
    if read_at(0, len(_AR_MAGIC)) != _AR_MAGIC:
        return "is not an ar archive (a write cut short?)"
    offset = len(_AR_MAGIC)
    while offset < size:
        header = read_at(offset, _AR_HEADER)
        if len(header) < _AR_HEADER or header[58:60] != b"`\n" or not header[48:58].strip().isdigit():
            return f"is cut short or broken at byte {offset}"
        offset += _AR_HEADER + int(header[48:58]) + int(header[48:58]) % 2
    return None if offset in (size, size + 1) else f"is cut short (a member ends at byte {offset} of {size})"


def damaged_archives(folders: list[Path]) -> list[tuple[Path, str]]:
    """The static libraries (``*.a``) in ``folders`` that are cut short or broken, with why."""
    found = []
    for folder in folders:
        for path in sorted(folder.glob("*.a")) if folder.is_dir() else []:
            try:
                with path.open("rb") as handle:

                    def read_at(offset: int, length: int, handle: Any = handle) -> bytes:
                        handle.seek(offset)
                        return bytes(handle.read(length))

                    why = archive_damage(os.fstat(handle.fileno()).st_size, read_at)
            except OSError as exc:
                why = f"cannot be read ({exc.strerror})"
            if why is not None:
                found.append((path, why))
    return found


def damaged_configures(build_base: Path) -> list[tuple[Path, str]]:
    """The package build folders under ``build_base`` whose configure files are damaged, with why."""
    found = []
    for folder in sorted(p for p in build_base.iterdir() if p.is_dir()) if build_base.is_dir() else []:
        for name in CONFIGURE_FILES:
            path = folder / name
            try:
                with path.open("rb") as handle:
                    size = os.fstat(handle.fileno()).st_size
                    handle.seek(max(0, size - _TAIL))
                    why = configure_damage(name, size, handle.read())
            except FileNotFoundError:
                continue
            except OSError as exc:
                why = f"{name} cannot be read ({exc.strerror})"
            if why is not None:
                found.append((folder, why))
                break
    return found


def write_if_changed(path: Path, text: str) -> bool:
    """Write only when the content differs, so CMake sees no change and rebuilds nothing."""
    if path.is_file() and path.read_text(encoding="utf-8") == text:
        return False
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return True


def nearest_existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_folder_target(path: Path, flag: str) -> None:
    """A folder uros will create or fill: it, or the nearest of its parents that exists, must
    be a folder, not a file (else a traceback from mkdir after the work is done)."""
    found = nearest_existing(path)
    if found.exists() and not found.is_dir():
        what = "is a file" if found == path else f"is inside {found}, which is a file"
        raise ConfigError(f"{flag} {path}: {what}", "pass a folder (it is created if missing)")


def check_file_target(path: Path, flag: str) -> None:
    """A file uros will write: not a folder, and the nearest existing parent is a folder."""
    if path.is_dir():
        raise ConfigError(f"{flag} {path}: is a folder", f"pass a file name, e.g. {path / 'out.txt'}")
    found = nearest_existing(path.parent)
    if found.exists() and not found.is_dir():
        raise ConfigError(f"{flag} {path}: {found} is a file, not a folder", "pass a path in a folder")
