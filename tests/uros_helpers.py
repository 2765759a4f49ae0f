"""Helpers shared by the test suites."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from uros_build.sources import distros

REPO = Path(__file__).resolve().parent.parent


def default_sigint() -> None:
    """preexec_fn for a uros that a test interrupts: Ctrl-C at its default. A shell without job
    control starts background commands with SIGINT ignored, and a Python started so keeps ignoring
    it (no KeyboardInterrupt): a CI started in the background would otherwise never interrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_uros(
    *args: str, cwd: Path | None = None, check: bool = True, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """Run the real `uros` CLI as a user would (a separate process)."""
    proc = subprocess.run(
        [sys.executable, "-m", "uros_build", *args],
        cwd=cwd,
        env=env if env is not None else os.environ.copy(),
        capture_output=True,
        text=True,
    )
    if check and proc.returncode != 0:
        raise AssertionError(
            f"uros {' '.join(args)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
        )
    return proc


def build_firmware_project(source: Path, package: Path, build: Path, *cmake_args: str) -> Path:
    """Configure and build a firmware CMake project against a `uros build` output (its firmware
    toolchain file and its CMake package), as a user would; returns the ELF."""
    subprocess.run(
        ["cmake", "-S", str(source), "-B", str(build), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={package / 'toolchain.cmake'}", f"-DCMAKE_PREFIX_PATH={package}",
         "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", *cmake_args],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    done = subprocess.run(["cmake", "--build", str(build)], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"firmware build failed:\n{done.stdout}\n{done.stderr}")
    return build / "firmware.elf"


def env_without(programs: tuple[str, ...], shadow: Path) -> dict[str, str]:
    """The environment with ``programs`` gone from PATH: every PATH folder holding one of them is
    replaced by a folder of links to everything else in it (made under ``shadow``)."""
    env = os.environ.copy()
    folders = []
    for i, entry in enumerate(p for p in env.get("PATH", "").split(os.pathsep) if p):
        folder = Path(entry)
        if not any((folder / p).exists() for p in programs):
            folders.append(entry)
            continue
        copy = shadow / f"path{i}"
        copy.mkdir(parents=True, exist_ok=True)
        for item in folder.iterdir():
            if item.name not in programs and not (copy / item.name).exists():
                (copy / item.name).symlink_to(item)
        folders.append(str(copy))
    env["PATH"] = os.pathsep.join(folders)
    return env


def defined_globals(lib: Path) -> Counter[str]:
    """The global symbols an ARM archive defines, with how many members define each."""
    out = subprocess.run(
        ["arm-none-eabi-nm", "-g", "--defined-only", "--format=posix", str(lib)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "LC_ALL": "C"},
    ).stdout
    return Counter(line.split()[0] for line in out.splitlines() if line and not line.endswith(":"))


def git_out(*args: str, cwd: Path) -> str:
    """git's stdout, with a fixed identity and no user configuration."""
    return subprocess.run(
        ["git", *args],
        cwd=cwd,
        check=True,
        capture_output=True,
        text=True,
        env={
            "GIT_AUTHOR_NAME": "t",
            "GIT_AUTHOR_EMAIL": "t@t",
            "GIT_COMMITTER_NAME": "t",
            "GIT_COMMITTER_EMAIL": "t@t",
            "PATH": "/usr/bin:/bin",
        },
    ).stdout.strip()


def git_commit(repo: Path, message: str) -> str:
    """One more commit on the checked-out branch of ``repo`` (a line in HISTORY); its sha."""
    history = repo / "HISTORY"
    history.write_text((history.read_text() if history.exists() else "") + message + "\n")
    git_out("add", "-A", cwd=repo)
    git_out("commit", "-q", "-m", message, cwd=repo)
    return git_out("rev-parse", "HEAD", cwd=repo)


def fake_upstream(root: Path, distro_names: tuple[str, ...]) -> Path:
    """<root>/<owner>+<repo>: a real git repository per repository of these distros' manifests,
    with the branch each asks for (as west's tests serve repositories from file paths)."""
    root.mkdir(parents=True, exist_ok=True)
    for name in distro_names:
        d = distros.load_distro(name)
        for repo in (*d.dev, *d.mcu):
            key = distros.owner_repo(repo.url)
            assert key
            path = root / key.replace("/", "+")
            if not path.exists():
                path.mkdir()
                git_out("init", "-q", "-b", repo.version, cwd=path)
                (path / "README").write_text(f"fake {key}\n")
                git_commit(path, "initial")
            elif repo.version not in git_out("branch", "--format=%(refname:short)", cwd=path).split():
                git_out("checkout", "-q", "-b", repo.version, cwd=path)
                git_commit(path, f"{repo.version} starts")
    return root


def upstream_mirror(upstream: Path) -> list[str]:
    """create-firmware's mirror flags that point every repository at ``fake_upstream``'s."""
    return [
        "--mirror",
        f"https://github.com/{{owner}}/{{repo}}={upstream}/{{owner}}+{{repo}}",
        "--mirror-override",
        f"uros/tracetools={upstream}/ros_tracing+ros2_tracing",
    ]


def need(*programs: str) -> None:
    missing = [p for p in programs if shutil.which(p) is None]
    if missing:
        message = f"not installed: {', '.join(missing)} (.ci/run installs them)"
        # .ci/run sets this after installing them: there a missing program is a broken CI, not a skip
        if os.environ.get("UROS_TEST_TOOLS_REQUIRED") == "1":
            pytest.fail(message)
        pytest.skip(message)
