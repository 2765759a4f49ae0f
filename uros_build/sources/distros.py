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

from uros_build import loader, resources
from uros_build.errors import ConfigError, did_you_mean
from uros_build.sources import meta

_DISTRO_KEYS = {
    "name",
    "status",
    "preset",
    "colcon_ignore",
    "dev_colcon_ignore",
    "build_time_clones",
    "stand_ins",
}
# built-here: built end to end by uros's authors (the distro.yaml says where it is recorded);
# manifest-only: written from upstream facts, never built (create-firmware warns); buildable-here
# lies between them.
STATUSES = ("built-here", "buildable-here", "manifest-only")
_SHA = re.compile(r"^[0-9a-f]{40}$")


@dataclass(frozen=True)
class Repo:
    path: str  # where it goes in the workspace, e.g. "uros/rclc"
    url: str
    version: str  # branch, tag or commit


@dataclass(frozen=True)
class Distro:
    name: str
    status: str  # one of STATUSES
    preset: str
    dev: tuple[Repo, ...]
    mcu: tuple[Repo, ...]
    colcon_ignore: tuple[str, ...]
    dev_colcon_ignore: tuple[str, ...]
    build_time_clones: tuple[str, ...]
    # what stood in for repositories whose branch a mirror lacked when this distro was built here:
    # applied only on request (`create-firmware --stand-ins`), each printed with its reason
    stand_ins: tuple[Override, ...] = ()


def parse_repos(data: Any, source: str) -> tuple[Repo, ...]:
    """A vcstool ``.repos`` file: ``repositories: {path: {type: git, url: URL, version: V}}``."""
    top = loader.mapping(data, source, {"repositories"}, required=("repositories",))
    entries = loader.mapping(top["repositories"], f"{source}: repositories")
    repos = []
    for path, entry in entries.items():
        if not isinstance(path, str) or not path:
            raise ConfigError(
                f"{source}: repositories: {path!r}: a workspace path must be a non-empty string"
            )
        where = f"{source}: repositories.{path}"
        item = loader.mapping(entry, where, {"type", "url", "version"}, required=("url", "version"))
        loader.one_of(item, "type", where, ("git",), "git")
        if not isinstance(item["version"], str):
            raise ConfigError(
                f"{where}: version: must be a string (branch, tag or commit), got {item['version']!r}",
                "quote versions that YAML would read as a number, e.g. version: '2.0'",
            )
        repos.append(Repo(path, loader.string(item, "url", where), loader.string(item, "version", where)))
    return tuple(sorted(repos, key=lambda r: r.path))


def known_distros() -> list[str]:
    root = resources.meta_dir() / "distros"
    return sorted(p.name for p in root.iterdir() if (p / "distro.yaml").is_file())


def parse_distro(info: Any, source: str, folder: str, dev: tuple[Repo, ...], mcu: tuple[Repo, ...]) -> Distro:
    """A ``distro.yaml`` (already parsed) of the folder ``meta/distros/<folder>``."""
    top = loader.mapping(info, source, _DISTRO_KEYS, required=("name",))
    name = loader.string(top, "name", source)
    if name != folder:
        raise ConfigError(f"{source}: name: {name!r} differs from its folder name {folder!r}")
    preset = loader.string(top, "preset", source, name)
    if preset not in meta.presets():
        raise ConfigError(
            f"{source}: preset: {preset!r} is not a shipped preset (known: {', '.join(meta.presets())})"
        )
    clones = loader.mapping_list(top, "build_time_clones", source, {"url", "by"}, required=("url",))
    stand_ins = parse_overrides(top.get("stand_ins"), f"{source}: stand_ins", require_reason=True)
    check_overrides_match(stand_ins, (*dev, *mcu), f"{source}: stand_ins")
    return Distro(
        name=name,
        status=loader.one_of(top, "status", source, STATUSES, "manifest-only"),
        preset=preset,
        dev=dev,
        mcu=mcu,
        colcon_ignore=loader.string_list(top, "colcon_ignore", source),
        dev_colcon_ignore=loader.string_list(top, "dev_colcon_ignore", source),
        build_time_clones=tuple(
            loader.string(c, "url", f"{source}: build_time_clones[{i}]") for i, c in enumerate(clones)
        ),
        stand_ins=stand_ins,
    )


def load_distro(name: str, flag: str = "--distro") -> Distro:
    if name not in known_distros():
        raise ConfigError(
            f"{flag}: unknown distro {name!r}{did_you_mean(name, known_distros())}",
            f"known distros: {', '.join(known_distros())}",
        )
    root = resources.meta_dir() / "distros" / name
    dev, mcu = root / "dev.repos", root / "mcu.repos"
    return parse_distro(
        loader.load_yaml(root / "distro.yaml"),
        str(root / "distro.yaml"),
        name,
        parse_repos(loader.load_yaml(dev), str(dev)),
        parse_repos(loader.load_yaml(mcu), str(mcu)),
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
    reason: str = ""  # why it stands in (a declared stand-in always says; a bare flag may not)

    @property
    def use(self) -> str:
        """``URL[@VERSION]`` or ``@VERSION``, as written."""
        return (self.url or "") + (f"@{self.version}" if self.version else "")

    def matches(self, repo: Repo, prefix: str = "") -> bool:
        return self.key in (repo.path, f"{prefix}{repo.path}", owner_repo(repo.url))


@dataclass(frozen=True)
class Mirror:
    rules: tuple[MirrorRule, ...] = ()
    overrides: tuple[Override, ...] = ()


MIRROR_PLACEHOLDERS = ("{owner}", "{repo}")
_RULE_HINT = "for example --mirror 'https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo'"


def parse_rule(spec: str, flag: str = "--mirror") -> MirrorRule:
    """``UPSTREAM=LOCAL``; both sides may use ``{owner}`` and ``{repo}`` (LOCAL only those of UPSTREAM)."""
    pattern, eq, target = spec.partition("=")
    if not eq or not pattern or not target:
        raise ConfigError(f"{flag} {spec!r}: expected UPSTREAM=LOCAL", _RULE_HINT)
    known = ", ".join(MIRROR_PLACEHOLDERS)
    for side, text in (("UPSTREAM", pattern), ("LOCAL", target)):
        found = re.findall(r"\{[^{}]*\}", text)
        unknown = [p for p in found if p not in MIRROR_PLACEHOLDERS]
        if unknown:
            raise ConfigError(
                f"{flag} {spec!r}: unknown placeholder {unknown[0]} in {side} (known: {known})", _RULE_HINT
            )
        rest = re.sub(r"\{[^{}]*\}", "", text)
        if "{" in rest or "}" in rest:
            raise ConfigError(f"{flag} {spec!r}: unbalanced {{ or }} in {side} (known: {known})", _RULE_HINT)
    for placeholder in MIRROR_PLACEHOLDERS:
        if pattern.count(placeholder) > 1:
            raise ConfigError(f"{flag} {spec!r}: {placeholder} appears twice in UPSTREAM", _RULE_HINT)
        if placeholder in target and placeholder not in pattern:
            raise ConfigError(
                f"{flag} {spec!r}: LOCAL uses {placeholder}, which UPSTREAM does not match", _RULE_HINT
            )
    return MirrorRule(pattern, target)


def parse_override(spec: str, flag: str = "--mirror-override", reason: str = "") -> Override:
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
    return Override(key, url or None, version or None, reason)


_OVERRIDE_KEYS = {"use", "why"}


def parse_overrides(data: Any, where: str, require_reason: bool = False) -> tuple[Override, ...]:
    """``REPO: URL[@VERSION]`` lines, or ``REPO: {use: URL[@VERSION], why: REASON}`` to say why it
    stands in (``require_reason``: only the second form, as in a distro's declared stand-ins)."""
    entries = loader.mapping(data, where)
    out = []
    for key, value in entries.items():
        item = f"{where}.{key}"
        if isinstance(value, str) and not require_reason:
            out.append(parse_override(f"{key}={value}", where))
            continue
        if isinstance(value, str) or not isinstance(value, Mapping):
            raise ConfigError(
                f"{item}: expected {{use: URL[@VERSION], why: REASON}}"
                + ("" if require_reason else " or URL[@VERSION]")
                + f", got {value!r}",
                "for example  ros2/rcl: {use: '@9.2.0', why: 'the mirror has no jazzy branch'}",
            )
        fields = loader.mapping(value, item, _OVERRIDE_KEYS, required=("use", "why"))
        out.append(
            parse_override(
                f"{key}={loader.string(fields, 'use', item)}", item, loader.string(fields, "why", item)
            )
        )
    return tuple(out)


def check_overrides_match(overrides: Iterable[Override], repos: Iterable[Repo], where: str) -> None:
    """Each override names a repository of the distro: a typo must not leave the real branch in
    place while the user believes a stand-in was used."""
    known = tuple(repos)
    for o in overrides:
        if not any(o.matches(r) for r in known):
            names = sorted({r.path for r in known} | {owner_repo(r.url) or r.path for r in known})
            raise ConfigError(
                f"{where}.{o.key}: names no repository of this distro{did_you_mean(o.key, names)}",
                "use a workspace path (uros/rclc) or owner/repo of an upstream URL in the .repos files",
            )


def owner_repo(url: str) -> str | None:
    match = re.search(r"[:/]([^/:]+)/([^/]+?)(?:\.git)?/?$", url)
    return f"{match.group(1)}/{match.group(2)}" if match else None


def load_mirror_config(data: Any, source: str) -> Mirror:
    """The ``mirror:`` section of a uros.yaml: ``rules: [UP=LOCAL]``, ``overrides: {repo: URL[@V]}``."""
    where = f"{source}: mirror"
    top = loader.mapping(data, where, {"rules", "overrides"})
    rules = loader.string_list(top, "rules", where)
    return Mirror(
        tuple(parse_rule(r, f"{where}.rules") for r in rules),
        parse_overrides(top.get("overrides"), f"{where}: overrides"),
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
        "overrides": {o.key: {"use": o.use, "why": o.reason} if o.reason else o.use for o in m.overrides},
    }


@dataclass(frozen=True)
class Source:
    repo: Repo
    url: str  # what git clones
    version: str
    stand_in: Override | None = None  # the override that replaced the manifest's URL or version

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
    override = next((o for o in mirror.overrides if o.matches(repo, prefix)), None)
    # an override's own URL goes through the mirror rules too, so a declared stand-in can name the
    # upstream fork (https://github.com/fictionlab/...) and still be cloned from the mirror
    url = rewrite_url(override.url if override and override.url else repo.url, mirror)
    version = override.version if override and override.version else repo.version
    if locked is not None:
        version = locked.get(f"{prefix}{repo.path}", version)
    return Source(repo, url, version, override)


def stand_in_label(source: Source) -> str:
    """What stood in, short: the version ("9.2.0"), or the fork and its version when the override
    named another repository ("fictionlab/rosidl_typesupport@jazzy"); "" for the manifest's own."""
    o = source.stand_in
    if o is None:
        return ""
    if o.url:
        return f"{owner_repo(o.url) or o.url}@{source.version}"
    return source.version


def describe_stand_in(path: str, source: Source) -> str:
    """One line saying what stood in for the manifest's repository, and why (never silent)."""
    o = source.stand_in
    if o is None:
        return f"{path}: {source.repo.version} from {source.url}"
    why = o.reason or "no reason given: say why in uros.yaml, mirror.overrides.<repo>.why"
    return f"{path}: {source.version} from {source.url} instead of {source.repo.version} ({why})"


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
