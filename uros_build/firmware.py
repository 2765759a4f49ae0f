"""`uros create-firmware`: a real micro-ROS firmware workspace from a distro manifest.

<dir>/uros.yaml        what was created: distro, mirror rules, extra packages (edit freely)
<dir>/uros.lock        the commit of every repository (`--locked` re-creates exactly these)
<dir>/colcon.meta      the distro's generate_lib meta, layered into every `uros build` (edit freely)
<dir>/dev_ws/          host tools (ament, ...), built once and shared by every target
<dir>/mcu_ws/          micro-ROS sources; mcu_ws/extra_packages/ holds your interface packages
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from uros_build import __version__, console
from uros_build import colcon as colcon_mod
from uros_build import distros as distros_mod
from uros_build import meta as meta_mod
from uros_build.distros import Distro, Mirror, Source
from uros_build.errors import ConfigError, StepFailed, UrosError
from uros_build.proc import Runner

CONFIG = "uros.yaml"
LOCK = "uros.lock"
USER_META = "colcon.meta"
EXTRA = "extra_packages"
DEV_MARKER = ".uros-dev-built"  # in dev_ws/install: the lock the dev workspace was built from
_CONFIG_KEYS = {"distro", "platform", "mirror", "extra_packages"}


@dataclass(frozen=True)
class FirmwareConfig:
    distro: str
    platform: str = "generate_lib"
    mirror: Mirror = field(default_factory=Mirror)
    extra_packages: tuple[str, ...] = ()  # source folders synced into mcu_ws/extra_packages


def load_config(root: Path) -> FirmwareConfig | None:
    path = root / CONFIG
    if not path.is_file():
        return None
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except yaml.YAMLError as exc:
        raise ConfigError(
            f"{path}: not valid YAML: {exc}", "fix the file or re-create it with --force"
        ) from exc
    if not isinstance(data, dict) or "distro" not in data:
        raise ConfigError(f"{path}: expected a mapping with at least 'distro:'")
    unknown = sorted(set(data) - _CONFIG_KEYS)
    if unknown:
        raise ConfigError(f"{path}: {unknown[0]}: unknown key (known: {', '.join(sorted(_CONFIG_KEYS))})")
    return FirmwareConfig(
        distro=str(data["distro"]),
        platform=str(data.get("platform", "generate_lib")),
        mirror=distros_mod.load_mirror_config(data.get("mirror") or {}, str(path)),
        extra_packages=tuple(str(p) for p in data.get("extra_packages") or ()),
    )


def config_text(cfg: FirmwareConfig) -> str:
    data: dict[str, Any] = {
        "distro": cfg.distro,
        "platform": cfg.platform,
        "mirror": distros_mod.mirror_to_config(cfg.mirror),
        "extra_packages": list(cfg.extra_packages),
    }
    header = f"# Written by uros {__version__} create-firmware; edit freely (uros build reads it).\n"
    return header + yaml.safe_dump(data, sort_keys=True)


def save_config(root: Path, cfg: FirmwareConfig) -> None:
    (root / CONFIG).write_text(config_text(cfg), encoding="utf-8")


def read_lock(path: Path, flag: str) -> dict[str, str]:
    if not path.is_file():
        raise ConfigError(f"{flag} {path}: no such lock file", "create the workspace once without --locked")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return {k: str(v["commit"]) for k, v in data["repositories"].items()}
    except (ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"{flag} {path}: not a uros lock file ({exc})") from exc


def lock_text(distro: str, sources: Mapping[str, Source], commits: Mapping[str, str]) -> str:
    data = {
        "generated_by": f"uros {__version__} create-firmware",
        "distro": distro,
        "repositories": {
            path: {"url": s.repo.url, "version": s.repo.version, "source": s.url, "commit": commits[path]}
            for path, s in sorted(sources.items())
        },
    }
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def find_package_xml(folder: Path) -> Path | None:
    direct = folder / "package.xml"
    return direct if direct.is_file() else None


def package_name(package_xml: Path) -> str:
    import xml.etree.ElementTree as ET

    try:
        name = ET.parse(package_xml).getroot().findtext("name")
    except ET.ParseError as exc:
        raise ConfigError(f"{package_xml}: not valid XML: {exc}") from exc
    if not name:
        raise ConfigError(f"{package_xml}: has no <name>")
    return name.strip()


def check_extra_package(path: Path, flag: str) -> str:
    if not path.is_dir():
        raise ConfigError(f"{flag} {path}: no such folder", "pass the folder of a ROS 2 package")
    xml = find_package_xml(path)
    if xml is None:
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


def sync_extra_packages(root: Path, cfg: FirmwareConfig) -> None:
    for entry in cfg.extra_packages:
        src = Path(entry)
        if not src.is_dir():
            console.warn(f"{root / CONFIG}: extra package {src} is gone; keeping the copy in mcu_ws/{EXTRA}")
            continue
        name = check_extra_package(src, f"{root / CONFIG}: extra_packages")
        changed = sync_tree(src, root / "mcu_ws" / EXTRA / name)
        if changed:
            console.info(f"extra package {name}: {changed} file(s) updated from {src}")


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CreateOptions:
    directory: Path
    distro: str = "humble"
    platform: str = "generate_lib"
    mirrors: tuple[str, ...] = ()
    overrides: tuple[str, ...] = ()
    config: Path | None = None
    locked: bool = False
    lock_file: Path | None = None
    extra_packages: tuple[Path, ...] = ()
    force: bool = False
    keep_partial: bool = False
    build_dev: bool = True
    toolchain: str | None = None  # a target whose prerequisites are checked first
    jobs: int = 4
    verbose: bool = False


@dataclass
class _Created:
    """What this run made, so a failure can take exactly that away."""

    paths: list[Path] = field(default_factory=list)


def _mirror_from(opts: CreateOptions, existing: FirmwareConfig | None) -> Mirror:
    parts: list[Mirror] = []
    if existing is not None:
        parts.append(existing.mirror)
    if opts.config is not None:
        if not opts.config.is_file():
            raise ConfigError(f"--config {opts.config}: no such file")
        data = yaml.safe_load(opts.config.read_text(encoding="utf-8")) or {}
        parts.append(distros_mod.load_mirror_config(data.get("mirror") or {}, str(opts.config)))
    parts.append(
        Mirror(
            tuple(distros_mod.parse_rule(s) for s in opts.mirrors),
            tuple(distros_mod.parse_override(s) for s in opts.overrides),
        )
    )
    return distros_mod.combine(*parts)


def plan_sources(distro: Distro, mirror: Mirror, locked: Mapping[str, str] | None) -> dict[str, Source]:
    """Workspace path (dev_ws/..., mcu_ws/...) -> what to clone (pure)."""
    sources = {}
    for ws, repos in (("dev_ws", distro.dev), ("mcu_ws", distro.mcu)):
        for repo in repos:
            sources[f"{ws}/{repo.path}"] = distros_mod.resolve(repo, mirror, locked, prefix=f"{ws}/")
    return sources


def clone_argv(git: str, source: Source, dest: Path) -> list[list[str]]:
    """git commands that put ``source`` at ``dest`` (pure)."""
    quiet = [git, "-c", "advice.detachedHead=false"]
    if source.is_commit:
        return [
            [*quiet, "clone", "--quiet", "--no-checkout", source.url, str(dest)],
            [*quiet, "-C", str(dest), "checkout", "--quiet", "--detach", source.version],
        ]
    return [[*quiet, "clone", "--quiet", "--branch", source.version, source.url, str(dest)]]


def _check_sources(sources: Mapping[str, Source]) -> None:
    for path, source in sources.items():
        if distros_mod.is_local(source.url) and not distros_mod.local_path(source.url).exists():
            raise ConfigError(
                f"--mirror: {source.url} (for {path}, upstream {source.repo.url}) does not exist",
                "fix the mirror rule, or point this repository elsewhere: "
                f"--mirror-override {source.repo.path}=URL",
            )


def _clone_all(
    runner: Runner, git: str, root: Path, sources: Mapping[str, Source], jobs: int
) -> dict[str, str]:
    def one(item: tuple[str, Source]) -> tuple[str, str]:
        path, source = item
        dest = root / path
        try:
            for argv in clone_argv(git, source, dest):
                runner.run(argv, step=f"clone {path}", quiet=True)
        except StepFailed as exc:
            git_error = exc.message.split(": ", 1)[-1]
            raise StepFailed(
                f"cloning {path} from {source.url} at {source.version!r} failed: {git_error}",
                f"check that the source has {source.version!r}, or override it: "
                f"--mirror-override {source.repo.path}=URL@VERSION (log: {runner.log_path})",
                log=runner.log_path,
            ) from exc
        head = runner.run([git, "-C", str(dest), "rev-parse", "HEAD"], step=f"read {path}", quiet=True)
        return path, head[-1].strip()

    console.step(f"cloning {len(sources)} repositories ({jobs} at a time)")
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(one, sorted(sources.items())))
    return dict(results)


def _ignore(root: Path, ws: str, paths: tuple[str, ...]) -> None:
    for rel in paths:
        folder = root / ws / rel
        if folder.is_dir():
            (folder / "COLCON_IGNORE").write_text("uros: ignored as micro_ros_setup does for this distro\n")
        else:
            console.warn(f"{ws}/{rel} is not in the workspace; nothing to ignore there")


def _existing(root: Path, force: bool) -> tuple[bool, FirmwareConfig | None]:
    """Returns (existed, its config); an existing workspace needs --force. Changes nothing."""
    if not root.exists():
        return False, None
    if not any(root.iterdir()):
        return True, None
    if not force:
        raise ConfigError(
            f"--dir {root}: already exists",
            "use another --dir, or pass --force to re-create its sources "
            f"(your {USER_META}, {CONFIG} and mcu_ws/{EXTRA}/ are kept)",
        )
    return True, load_config(root)


def _clear_sources(root: Path) -> None:
    """--force: remove the cloned sources, keep what the user made (uros.yaml, colcon.meta, extras)."""
    shutil.rmtree(root / "dev_ws", ignore_errors=True)
    mcu = root / "mcu_ws"
    if mcu.is_dir():
        for child in mcu.iterdir():
            if child.name != EXTRA:
                shutil.rmtree(child) if child.is_dir() else child.unlink()


def create_firmware(
    opts: CreateOptions,
    build_dev: Callable[[Path, Runner, bool], None],
    precheck: Callable[[Runner], None] | None = None,
) -> Path:
    """``precheck`` checks a target's compiler, C library and C++ headers before anything is
    cloned, so a missing package costs seconds, not a clone and a dev_ws build."""
    if opts.platform != "generate_lib":
        raise ConfigError(
            f"create-firmware: unknown platform {opts.platform!r}", "uros supports `generate_lib` (any MCU)"
        )
    distro = distros_mod.load_distro(opts.distro)
    root = opts.directory.resolve()
    extra_names = [check_extra_package(p, "--extra-package") for p in opts.extra_packages]
    locked: dict[str, str] | None = None
    if opts.locked or opts.lock_file:
        lock_path = opts.lock_file or root / LOCK
        locked = read_lock(lock_path, "--lock-file" if opts.lock_file else "--locked")
    existed, existing = _existing(root, opts.force)
    mirror = _mirror_from(opts, existing)
    sources = plan_sources(distro, mirror, locked)
    _check_sources(sources)

    root.mkdir(parents=True, exist_ok=True)
    runner = Runner(root / ".uros" / "log" / f"create-firmware-{os.getpid()}.log", verbose=opts.verbose)
    console.step(f"uros create-firmware {opts.platform}: micro-ROS {distro.name} in {root}")
    console.info(f"log: {runner.log_path}")
    try:
        git = runner.which("git")
        runner.which("cmake")
        if precheck is not None:
            precheck(runner)
    except UrosError:
        if not existed:
            shutil.rmtree(root, ignore_errors=True)
        raise
    if existing is not None or existed:
        _clear_sources(root)
    if distro.status == "manifest-only":
        console.warn(
            f"the {distro.name} manifest was written from upstream facts and not built by uros's authors"
        )
    try:
        commits = _clone_all(runner, git, root, sources, opts.jobs)
        (root / LOCK).write_text(lock_text(distro.name, sources, commits), encoding="utf-8")
        _ignore(root, "mcu_ws", distro.colcon_ignore)
        _ignore(root, "dev_ws", distro.dev_colcon_ignore)
        extras = list(existing.extra_packages) if existing else []
        for path, name in zip(opts.extra_packages, extra_names, strict=True):
            if str(path.resolve()) not in extras:
                extras.append(str(path.resolve()))
            sync_tree(path, root / "mcu_ws" / EXTRA / name)
        cfg = FirmwareConfig(distro.name, opts.platform, mirror, tuple(extras))
        save_config(root, cfg)
        if not (root / USER_META).exists():
            preset = meta_mod.load_preset(distro.preset)
            (root / USER_META).write_text(
                meta_mod.dump_meta(preset, f"{distro.name} generate_lib defaults; edit freely"),
                encoding="utf-8",
            )
        (root / "COLCON_IGNORE").write_text("uros: the firmware folder is not a package\n")
        if opts.build_dev:
            build_dev(root, runner, opts.verbose)
    except (UrosError, KeyboardInterrupt):
        if not opts.keep_partial:
            _remove_partial(root, existed)
        raise
    console.step(f"created {root} ({len(commits)} repositories, locked in {LOCK})")
    return root


def _remove_partial(root: Path, existed: bool) -> None:
    if not existed:
        shutil.rmtree(root, ignore_errors=True)
        console.info(f"removed the partial workspace {root} (keep it with --keep-partial)")
        return
    shutil.rmtree(root / "dev_ws", ignore_errors=True)
    for child in (root / "mcu_ws").iterdir() if (root / "mcu_ws").is_dir() else ():
        if child.name != EXTRA:
            shutil.rmtree(child, ignore_errors=True)
    console.info(f"removed the partial sources in {root} (keep them with --keep-partial)")


# ---------------------------------------------------------------------------------------------
# the host dev workspace


def dev_install(root: Path) -> Path:
    return root / "dev_ws" / "install"


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


def dev_build_plan(root: Path, verbose: bool, jobs: int | None = None) -> colcon_mod.ColconPlan:
    ws = root / "dev_ws"
    return colcon_mod.ColconPlan(
        base_paths=(ws,),
        build_base=ws / "build",
        install_base=ws / "install",
        log_base=ws / "log",
        metas=(),
        toolchain_file=None,
        python=colcon_mod.host_python(),
        generator="Ninja" if shutil.which("ninja") else None,
        verbose=verbose,
        parallel_workers=jobs,
        ignore_regex=None,
    )
