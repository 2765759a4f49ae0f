"""The smaller commands: listings, rendering, exports, checks, packages and interfaces.

Each is one function the CLI calls; `uros build` and `uros create-firmware`, the long pipelines, live
in pipeline.py, whose helpers (target resolution, the bare-metal output checks) some of these reuse.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from uros_build import abi, console, export, firmware, interfaces
from uros_build import distros as distros_mod
from uros_build.errors import ConfigError, StepFailed
from uros_build.pipeline import check_output_dir
from uros_build.proc import Runner
from uros_build.profiles import find_profile, load_profile_file, shipped_profiles
from uros_build.toolchain import CLOCK_HEADER_NAME, CLOCK_HEADER_TEXT, ToolchainRequest, render_toolchain
from uros_build.workspace import write_if_changed

# ---------------------------------------------------------------------------------------------
# uros targets / toolchain render / meta write


def targets_table() -> list[dict[str, Any]]:
    return [
        {
            "name": p.name,
            "description": p.description,
            "compiler": p.tool("gcc"),
            "cpu_flags": list(p.cpu_flags),
            "transport": p.transport,
            "file": Path(p.source).name,
        }
        for p in shipped_profiles().values()
    ]


def render_toolchain_file(target: str, output: Path | None, micro_ros: bool, gcc_major: int | None) -> None:
    """`uros toolchain render`: a target name or a profile .yaml -> toolchain text.

    For micro-ROS with an output file, the clock_gettime declaration header the profile may need
    is written beside it and referenced by absolute path, so the file works on its own.
    """
    profile = load_profile_file(Path(target)) if target.endswith((".yaml", ".yml")) else find_profile(target)
    header: Path | None = None
    if micro_ros and output is not None and profile.micro_ros.declare_clock_gettime:
        header = output.resolve().with_name(CLOCK_HEADER_NAME)
        write_if_changed(header, CLOCK_HEADER_TEXT)
    command = f"uros toolchain render {target}" + (" --for micro-ros" if micro_ros else "")
    req = ToolchainRequest(
        profile,
        micro_ros=micro_ros,
        gcc_major=gcc_major,
        clock_header=str(header) if header else None,
        command=command,
    )
    write_output_file(output, render_toolchain(req))


def write_output_file(path: Path | None, text: str) -> None:
    if path is None:
        sys.stdout.write(text)
        return
    write_if_changed(path, text)
    console.info(f"wrote {path}")


# ---------------------------------------------------------------------------------------------
# uros export cmake


def export_cmake(source: Path | None, output: Path) -> Path:
    info, out = _prepare_export(source, output)
    written = export.write_cmake_package(out, info)
    console.step(f"wrote {', '.join(p.name for p in written)} in {out}")
    return out


def _prepare_export(source: Path | None, output: Path) -> tuple[dict[str, Any], Path]:
    """Read the build-info of the output to export and copy that output to ``output``."""
    src = (source or output).resolve()
    info = export.read_build_info(src, "--from" if source else "--output")
    out = output.resolve()
    if src != out:
        check_output_dir(out, force=False)
        export.copy_build_output(src, out)
    return info, out


# ---------------------------------------------------------------------------------------------
# uros export esp-idf


def export_esp_idf(source: Path | None, output: Path) -> Path:
    src = (source or output).resolve()
    info = export.read_build_info(src, "--from" if source else "--output")
    if not info.get("idf_target"):
        raise ConfigError(
            f"{src}: built for {info.get('target')}, which is not an ESP-IDF target",
            "build for esp32, esp32s2, esp32s3 or esp32c3 first: uros build --toolchain esp32s3",
        )
    info, out = _prepare_export(source, output)
    written = export.write_esp_idf_component(out, info)
    console.step(
        f"wrote the ESP-IDF component {out} ({', '.join(p.name for p in written)}): copy it into your "
        f"project's components/ and add its folder name to PRIV_REQUIRES"
    )
    return out


# ---------------------------------------------------------------------------------------------
# uros check


def check_library(library: Path, target: str | None, profile_path: Path | None, verbose: bool) -> None:
    """`uros check`: the build's ABI check on any library."""
    if (target is None) == (profile_path is None):
        raise ConfigError("uros check needs one target", "pass --target NAME or --profile FILE")
    if not library.is_file():
        raise ConfigError(f"{library}: no such file", "pass the path of a static library (.a) or an object")
    profile = load_profile_file(profile_path) if profile_path is not None else find_profile(str(target))
    stamp = time.strftime("%Y%m%d-%H%M%S")
    log = Path(tempfile.gettempdir()) / f"uros-{os.getuid()}" / "log" / f"{stamp}-check-{os.getpid()}.log"
    runner = Runner(log, verbose=verbose)
    summary = abi.check_library(runner, library.resolve(), profile)
    console.step(f"{library}: {abi.describe(summary)}")


# ---------------------------------------------------------------------------------------------
# uros distros / add-package / interface new


def distros_table() -> list[dict[str, Any]]:
    rows = []
    for name in distros_mod.known_distros():
        d = distros_mod.load_distro(name)
        rows.append(
            {
                "name": d.name,
                "status": d.status,
                "dev_repositories": len(d.dev),
                "mcu_repositories": len(d.mcu),
            }
        )
    return rows


def add_package(source: str, workspace: Path, version: str | None, verbose: bool) -> Path:
    root = workspace.resolve()
    cfg = firmware.load_config(root)
    if cfg is None:
        raise ConfigError(
            f"--workspace {workspace}: not a firmware workspace (no {firmware.CONFIG})",
            "create one with `uros create-firmware generate_lib`, or copy the package into your workspace",
        )
    extra = root / "mcu_ws" / firmware.EXTRA
    if "://" in source or source.startswith("git@"):
        name = source.rstrip("/").rsplit("/", 1)[-1].removesuffix(".git")
        dest = extra / name
        if dest.exists():
            raise ConfigError(f"add-package: {dest} already exists", "remove it first to clone it again")
        runner = Runner(root / ".uros" / "log" / f"add-package-{os.getpid()}.log", verbose=verbose)
        argv = [runner.which("git"), "clone", "--quiet", *(["--branch", version] if version else []), source]
        try:
            runner.run([*argv, str(dest)], step=f"clone {source}")
        except StepFailed:
            shutil.rmtree(dest, ignore_errors=True)
            raise
        if not list(dest.rglob("package.xml")):
            shutil.rmtree(dest)
            raise ConfigError(
                f"add-package {source}: the repository holds no package.xml", "pass a ROS 2 package"
            )
        console.step(f"cloned {source} into {dest}")
        return dest
    path = Path(source).resolve()
    name = firmware.check_extra_package(path, "add-package")
    entries = list(cfg.extra_packages)
    if str(path) not in entries:
        entries.append(str(path))
    firmware.save_config(root, firmware.FirmwareConfig(cfg.distro, cfg.platform, cfg.mirror, tuple(entries)))
    dest = extra / name
    firmware.sync_tree(path, dest)
    console.step(f"added {name}: {path} is synced into {dest} at every `uros build`")
    return dest


def interface_new(name: str, msgs: list[Path], srvs: list[Path], output: Path | None, force: bool) -> Path:
    files = [interfaces.read_interface(p, "msg") for p in msgs] + [
        interfaces.read_interface(p, "srv") for p in srvs
    ]
    texts = interfaces.package_files(name, files)
    dest = (output or Path(name)).resolve()
    if dest.exists() and any(dest.iterdir()) and not force:
        raise ConfigError(f"interface new: {dest} already exists", "choose another --output, or pass --force")
    for rel, text in texts.items():
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        (dest / rel).write_text(text, encoding="utf-8")
    console.step(f"wrote interface package {name} in {dest}; add it with `uros add-package {dest}`")
    return dest
