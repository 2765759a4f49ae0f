"""Packages built once per workspace for the host (issue 19): the host stage.

A micro-ROS workspace holds packages that compile nothing for the target (rosidl's Python and CMake
modules, a header, test data: ``meta/host-stage.yaml``), which colcon would configure and install
again for every target, ~1 s of job time each. uros builds them once, for the host, in
``.uros/shared/<key>/``, and copies the files each one installed into a target's install tree,
with the list of those files as the package's install manifest, so that the target's trees look
as if colcon had installed it there (installtree.py reads them so). The target's colcon then skips
them (``--packages-skip``: still in its graph, so the order of its dependents is what it was).

Which packages: those listed whose own configure needs (depend, build_depend, buildtool_depend,
group_depend) only other shared packages or what is outside the target's colcon build (dev_ws);
and of those, the ones whose stage build compiled nothing (a listed package that compiled code, an
archive or a shared library is built per target: its objects would be the host's).

Reads and writes files; starts no process (steps/host_stage.py runs colcon).
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from uros_build import loader, resources
from uros_build.colcon import fingerprint as fp
from uros_build.colcon import installtree
from uros_build.errors import ConfigError
from uros_build.files import write_atomic
from uros_build.sources.packages import PackageInfo

FORMAT = "1"
MARKER = "uros-stage.json"  # in the stage folder: the key it was built for and what it found
TAKEN = "uros-shared.json"  # in a target's build/<package>: the stage key its copy came from
_LIST = "host-stage.yaml"


@dataclass(frozen=True)
class StageList:
    """``meta/host-stage.yaml``: package -> why it compiles nothing for the target."""

    packages: Mapping[str, str]


def load_list(path: Path | None = None) -> StageList:
    path = path or resources.meta_dir() / _LIST
    source = str(path)
    data = loader.mapping(
        loader.load_yaml(path), source, known={"format", "packages"}, required=("packages",)
    )
    if loader.integer(data, "format", source) != 1:
        raise ConfigError(f"{source}: format: expected 1", "use the file shipped with this uros")
    return StageList(loader.string_map(data, "packages", source))


def choose(
    packages: Sequence[PackageInfo], building: Iterable[str], listed: Iterable[str]
) -> tuple[str, ...]:
    """The listed packages the target's build has whose own configure needs nothing the target
    builds (only other chosen packages, or what is outside the build: dev_ws) (pure)."""
    building = set(building)
    by_name = {p.name: p for p in packages if p.name in building}
    members: dict[str, set[str]] = {}
    for p in by_name.values():
        for group in p.groups:
            members.setdefault(group, set()).add(p.name)
    chosen = set(listed) & set(by_name)
    while True:
        out = {
            name
            for name in chosen
            if not ((by_name[name].configure_deps & building) | _members(by_name[name], members)) <= chosen
        }
        if not out:
            return tuple(sorted(chosen))
        chosen -= out


def _members(package: PackageInfo, members: Mapping[str, set[str]]) -> set[str]:
    return {m for group in package.group_deps for m in members.get(group, ())}


def package_sources(records: Mapping[str, fp.FileRecord], source_dir: Path, package: PackageInfo) -> str:
    """The content of one package's folder, from the workspace's scan (pure)."""
    try:
        prefix = package.path.relative_to(source_dir).as_posix()
    except ValueError:
        return fp.digest("outside", str(package.path))
    if prefix in ("", "."):
        return fp.tree_digest(records)
    inside = {rel: rec for rel, rec in records.items() if rel.startswith(prefix + "/")}
    return fp.tree_digest(inside)


@dataclass(frozen=True)
class Stage:
    """One host stage: its folder (named by what it is built with) and the key of its inputs."""

    folder: Path
    packages: tuple[str, ...]  # the candidates (chosen)
    meta: Mapping[str, Mapping[str, object]]  # their colcon.meta entries
    key: str  # the folder's inputs + the packages' sources + dev_ws + where the folder is

    @property
    def build_base(self) -> Path:
        return self.folder / "build"

    @property
    def install_base(self) -> Path:
        return self.folder / "install"

    @property
    def log_base(self) -> Path:
        return self.folder / "log"

    @property
    def meta_path(self) -> Path:
        return self.folder / "colcon.meta"


def plan_stage(
    stages_dir: Path,
    packages: tuple[str, ...],
    meta: Mapping[str, Mapping[str, object]],
    tools: Sequence[str],
    sources: Mapping[str, str],
    dev: str,
) -> Stage:
    """Where the stage of ``packages`` lives and its key (pure). The folder is named by what the
    packages are built with (their names, colcon.meta entries and the tools), so that targets
    whose colcon.meta differ for them get stages of their own; the key adds their sources and
    the folder's absolute path: what the stage installed names it (install manifests, ament's
    package.sh), so a stage moved or copied with its workspace is built again where it is now."""
    entries = {p: meta.get(p, {}) for p in packages}
    folder_key = fp.digest_json(
        {"format": FORMAT, "packages": packages, "meta": entries, "tools": list(tools)}
    )
    folder = stages_dir / folder_key[:16]
    key = fp.digest_json({"folder": folder_key, "sources": dict(sources), "dev_ws": dev, "at": str(folder)})
    return Stage(folder, packages, entries, key)


def meta_text(stage: Stage, generated_by: str) -> str:
    return json.dumps({"_generated_by": generated_by, "names": stage.meta}, indent=2, sort_keys=True) + "\n"


@dataclass(frozen=True)
class Marker:
    """What the stage's last good build was for and what it found."""

    key: str
    shared: tuple[str, ...]  # built here and compiled nothing: the targets take them
    compiled: tuple[str, ...]  # listed, but compiled code: built per target
    failed: bool = False  # the stage's colcon failed: every package is built per target


def read_marker(stage: Stage) -> Marker | None:
    try:
        data = json.loads((stage.folder / MARKER).read_text(encoding="utf-8"))
        return Marker(str(data["key"]), tuple(data["shared"]), tuple(data["compiled"]), bool(data["failed"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def write_marker(stage: Stage, marker: Marker, generated_by: str) -> None:
    text = json.dumps(
        {
            "_generated_by": generated_by,
            "key": marker.key,
            "shared": list(marker.shared),
            "compiled": list(marker.compiled),
            "failed": marker.failed,
        },
        indent=1,
        sort_keys=True,
    )
    write_atomic(stage.folder / MARKER, text + "\n")


_OBJECTS = (".o", ".obj")
_LIBRARIES = (".a", ".so", ".dylib", ".dll", ".lib")


def compiled_code(build_base: Path, install_base: Path, package: str) -> bool:
    """The package compiled something: an object file in its build folder, or a library among
    the files it installed."""
    for _dirpath, _dirnames, filenames in os.walk(build_base / package):
        if any(name.endswith(_OBJECTS) for name in filenames):
            return True
    return any(
        p.suffix in _LIBRARIES or ".so." in p.name for p in installtree.installed_files(build_base, package)
    )


def files_of(stage: Stage, package: str) -> tuple[Path, ...]:
    """What ``package`` put into the stage's install tree, relative to it: the files its install
    step listed and colcon's per-package files (share/<package>/, its colcon-core marker)."""
    install = stage.install_base
    found: set[Path] = set()
    for path in installtree.installed_files(stage.build_base, package):
        if str(path).startswith(str(install) + os.sep) and (path.is_file() or path.is_symlink()):
            found.add(path.relative_to(install))
    share = install / "share" / package
    for dirpath, _dirnames, filenames in os.walk(share):
        found.update((Path(dirpath) / name).relative_to(install) for name in filenames)
    marker = install / "share" / "colcon-core" / "packages" / package
    if marker.is_file():
        found.add(marker.relative_to(install))
    return tuple(sorted(found))


def taken(target_build: Path, package: str, key: str) -> bool:
    """The target's trees hold ``package`` as the stage of ``key`` installed it."""
    try:
        data = json.loads((target_build / package / TAKEN).read_text(encoding="utf-8"))
        manifest = (target_build / package / "install_manifest.txt").read_bytes()
    except (OSError, ValueError):
        return False
    # the manifest uros wrote, not one a build of the package for the target wrote since
    if not isinstance(data, dict) or data.get("key") != key or data.get("manifest") != fp.digest(manifest):
        return False
    return all(p.is_file() or p.is_symlink() for p in installtree.installed_files(target_build, package))


def take(stage: Stage, package: str, target_build: Path, target_install: Path, workspace: Path) -> int:
    """Put ``package`` into a target's trees as the stage installed it: what the target had of it
    dropped first (its files, by its own manifest, and its build folder), then the stage's files
    copied and listed as its install manifest. Returns how many files were copied.

    Files that name the stage's folder get the target's instead: ament's package.sh and
    local_setup.sh hold their install prefix (colcon sources them for every dependent, and the
    dependents' ament index records that prefix), setuptools' SOURCES.txt its build folder,
    relative to the workspace. Both folders sit at the same depth under it (.uros/shared/<key>,
    .uros/targets/<key>), so one replacement serves absolute and relative spellings."""
    installtree.drop_package(target_build, target_install, package)
    folder = target_build / package
    folder.mkdir(parents=True)
    stage_part = os.fsencode(stage.folder.relative_to(workspace))
    target_part = os.fsencode(target_build.parent.relative_to(workspace))
    copied = []
    for rel in files_of(stage, package):
        src, dest = stage.install_base / rel, target_install / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        if dest.is_symlink() or dest.exists():
            dest.unlink()
        if src.is_symlink():
            shutil.copy2(src, dest, follow_symlinks=False)
        else:
            data = src.read_bytes()
            dest.write_bytes(data.replace(stage_part, target_part) if stage_part in data else data)
            shutil.copystat(src, dest)
        copied.append(str(dest))
    manifest = ("\n".join(copied) + "\n").encode()
    (folder / "install_manifest.txt").write_bytes(manifest)
    record = json.dumps({"key": stage.key, "manifest": fp.digest(manifest), "stage": str(stage.folder)})
    (folder / TAKEN).write_text(record + "\n", encoding="utf-8")
    return len(copied)
