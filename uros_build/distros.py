"""Distro manifests (``meta/distros/<distro>/``) and mirror rewriting, as typed values.

A distro is two vcstool ``.repos`` files (the host dev workspace and the MCU workspace), the
packages micro_ros_setup COLCON_IGNOREs, the colcon.meta preset, and the URLs that CMake
ExternalProject clones during the build. A mirror rewrites upstream URLs to local clones or an
internal server, like git's ``insteadOf`` but with ``{owner}``/``{repo}`` placeholders, and
per-repository overrides cover forks, renamed repositories and missing branches.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from uros_build import resources
from uros_build.errors import ConfigError

_DISTRO_KEYS = {"name", "status", "preset", "colcon_ignore", "dev_colcon_ignore", "build_time_clones"}
_SHA = re.compile(r"^[0-9a-f]{40}$")


@dataclass(frozen=True)
class Repo:
    path: str  # where it goes in the workspace, e.g. "uros/rclc"
    url: str
    version: str  # branch, tag or commit


@dataclass(frozen=True)
class Distro:
    name: str
    status: str  # built-here | buildable-here | manifest-only
    preset: str
    dev: tuple[Repo, ...]
    mcu: tuple[Repo, ...]
    colcon_ignore: tuple[str, ...]
    dev_colcon_ignore: tuple[str, ...]
    build_time_clones: tuple[str, ...]


def _yaml(path: Path) -> Any:
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{path}{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from exc


def parse_repos(data: Any, source: str) -> tuple[Repo, ...]:
    if not isinstance(data, dict) or not isinstance(data.get("repositories"), dict):
        raise ConfigError(f"{source}: expected a vcstool file with a 'repositories:' mapping")
    repos = []
    for path, entry in data["repositories"].items():
        if not isinstance(entry, dict) or entry.get("type", "git") != "git":
            raise ConfigError(f"{source}: repositories.{path}: expected type: git with url and version")
        url, version = entry.get("url"), entry.get("version")
        if not isinstance(url, str) or not isinstance(version, (str, int, float)):
            raise ConfigError(f"{source}: repositories.{path}: url and version are required")
        repos.append(Repo(str(path), url, str(version)))
    return tuple(sorted(repos, key=lambda r: r.path))


def known_distros() -> list[str]:
    root = resources.meta_dir() / "distros"
    return sorted(p.name for p in root.iterdir() if (p / "distro.yaml").is_file())


def load_distro(name: str) -> Distro:
    if name not in known_distros():
        raise ConfigError(
            f"--distro: unknown distro {name!r}", f"known distros: {', '.join(known_distros())}"
        )
    root = resources.meta_dir() / "distros" / name
    info = _yaml(root / "distro.yaml")
    source = str(root / "distro.yaml")
    if not isinstance(info, dict):
        raise ConfigError(f"{source}: expected a mapping")
    unknown = sorted(set(info) - _DISTRO_KEYS)
    if unknown:
        raise ConfigError(f"{source}: {unknown[0]}: unknown key (known: {', '.join(sorted(_DISTRO_KEYS))})")
    clones = info.get("build_time_clones") or []
    return Distro(
        name=str(info["name"]),
        status=str(info.get("status", "manifest-only")),
        preset=str(info.get("preset", name)),
        dev=parse_repos(_yaml(root / "dev.repos"), str(root / "dev.repos")),
        mcu=parse_repos(_yaml(root / "mcu.repos"), str(root / "mcu.repos")),
        colcon_ignore=tuple(info.get("colcon_ignore") or ()),
        dev_colcon_ignore=tuple(info.get("dev_colcon_ignore") or ()),
        build_time_clones=tuple(str(c["url"]) for c in clones),
    )


# ---------------------------------------------------------------------------------------------
# mirrors


@dataclass(frozen=True)
class MirrorRule:
    pattern: str  # e.g. https://github.com/{owner}/{repo}
    target: str  # e.g. /srv/mirror/{owner}+{repo}/repo

    def apply(self, url: str) -> str | None:
        regex = re.escape(self.pattern.rstrip("/"))
        regex = regex.replace(r"\{owner\}", r"(?P<owner>[^/]+)").replace(r"\{repo\}", r"(?P<repo>[^/]+?)")
        match = re.fullmatch(regex + r"(?:\.git)?/?", url)
        if match is None:
            return None
        return self.target.format(**match.groupdict())


@dataclass(frozen=True)
class Override:
    key: str  # a workspace path (uros/tracetools) or owner/repo of the upstream URL
    url: str | None
    version: str | None


@dataclass(frozen=True)
class Mirror:
    rules: tuple[MirrorRule, ...] = ()
    overrides: tuple[Override, ...] = ()

    def is_empty(self) -> bool:
        return not self.rules and not self.overrides


def parse_rule(spec: str, flag: str = "--mirror") -> MirrorRule:
    pattern, eq, target = spec.partition("=")
    if not eq or not pattern or not target:
        raise ConfigError(
            f"{flag} {spec!r}: expected UPSTREAM=LOCAL",
            "for example --mirror 'https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo'",
        )
    return MirrorRule(pattern, target)


def parse_override(spec: str, flag: str = "--mirror-override") -> Override:
    key, eq, value = spec.partition("=")
    if not eq or not key or not value:
        raise ConfigError(
            f"{flag} {spec!r}: expected REPO=URL[@VERSION] or REPO=@VERSION",
            "REPO is a workspace path (uros/rclc) or owner/repo, e.g. "
            "--mirror-override ament/googletest=@ros2",
        )
    url, version = value, None
    at = value.rfind("@")
    if at >= 0 and "/" not in value[at + 1 :] and ":" not in value[at + 1 :]:
        url, version = value[:at], value[at + 1 :]
    return Override(key, url or None, version or None)


def owner_repo(url: str) -> str | None:
    match = re.search(r"[:/]([^/:]+)/([^/]+?)(?:\.git)?/?$", url)
    return f"{match.group(1)}/{match.group(2)}" if match else None


def load_mirror_config(data: Mapping[str, Any], source: str) -> Mirror:
    """The ``mirror:`` section of a uros.yaml: ``rules: [UP=LOCAL]``, ``overrides: {repo: URL[@V]}``."""
    rules = data.get("rules") or []
    overrides = data.get("overrides") or {}
    if not isinstance(rules, list) or not isinstance(overrides, dict):
        raise ConfigError(f"{source}: mirror: expected rules: [..] and overrides: {{repo: url}}")
    return Mirror(
        tuple(parse_rule(str(r), f"{source}: mirror.rules") for r in rules),
        tuple(parse_override(f"{k}={v}", f"{source}: mirror.overrides") for k, v in overrides.items()),
    )


def combine(*mirrors: Mirror) -> Mirror:
    """Later mirrors win: flags over the config file."""
    rules: list[MirrorRule] = []
    overrides: list[Override] = []
    for m in reversed(mirrors):
        rules += m.rules
        overrides += m.overrides
    return Mirror(tuple(rules), tuple(overrides))


def mirror_to_config(m: Mirror) -> dict[str, Any]:
    return {
        "rules": [f"{r.pattern}={r.target}" for r in m.rules],
        "overrides": {o.key: (o.url or "") + (f"@{o.version}" if o.version else "") for o in m.overrides},
    }


@dataclass(frozen=True)
class Source:
    repo: Repo
    url: str  # what git clones
    version: str

    @property
    def is_commit(self) -> bool:
        return bool(_SHA.match(self.version))


def rewrite_url(url: str, mirror: Mirror) -> str:
    for rule in mirror.rules:
        rewritten = rule.apply(url)
        if rewritten is not None:
            return rewritten
    return url


def resolve(repo: Repo, mirror: Mirror, locked: Mapping[str, str] | None = None, prefix: str = "") -> Source:
    override = next(
        (o for o in mirror.overrides if o.key in (repo.path, f"{prefix}{repo.path}", owner_repo(repo.url))),
        None,
    )
    url = override.url if override and override.url else rewrite_url(repo.url, mirror)
    version = override.version if override and override.version else repo.version
    if locked is not None:
        version = locked.get(f"{prefix}{repo.path}", version)
    return Source(repo, url, version)


def is_local(url: str) -> bool:
    return url.startswith(("/", "file://", "./", "../"))


def local_path(url: str) -> Path:
    return Path(url.removeprefix("file://"))


def insteadof(urls: Iterable[str], mirror: Mirror) -> dict[str, str]:
    """git config for clones made during the build (CMake ExternalProject): url.<local>.insteadOf."""
    config = {}
    for url in urls:
        rewritten = rewrite_url(url, mirror)
        if rewritten != url:
            config[f"url.{rewritten}.insteadOf"] = url
    return config
