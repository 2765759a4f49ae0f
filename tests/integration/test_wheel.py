"""The built wheel carries toolchains/, meta/ and templates/ and works from any directory.

The wheel goes into a fresh venv *without* system site packages (inside a venv, those would be the
base interpreter's, not the venv's). Its dependencies come from the environment running the tests,
whether a venv or not, through a .pth file naming that environment's site-packages: no network, no
package index, no `pip download`.
"""

from __future__ import annotations

import json
import os
import re
import site
import subprocess
import sys
import sysconfig
import venv
import zipfile
from importlib import metadata
from pathlib import Path

import pytest
from uros_helpers import REPO

pytestmark = pytest.mark.integration

# pyproject's force-include: <repo>/<name> -> uros_build/_data/<name> in the wheel (meta/ with
# whatever it holds: distros, presets, transports, fragments, schemas, ...).
DATA_DIRS = ("toolchains", "meta", "templates")


def _run(argv: list[str], cwd: Path | None = None, env: dict[str, str] | None = None) -> str:
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise AssertionError(f"{' '.join(argv)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return proc.stdout


def _outer_site_dirs() -> list[str]:
    """The folders holding this interpreter's installed packages: the outer venv's site-packages when
    the tests run in one, the interpreter's own (and the user site) otherwise."""
    paths = sysconfig.get_paths()
    candidates = [paths["purelib"], paths["platlib"], *site.getsitepackages()]
    if site.ENABLE_USER_SITE:
        candidates.append(site.getusersitepackages())
    # e.g. the base interpreter's, seen by an outer venv made with --system-site-packages
    candidates += [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages")]
    dirs: list[str] = []
    for c in candidates:
        if c and Path(c).is_dir() and c not in dirs and Path(c).resolve() != REPO:
            dirs.append(c)
    return dirs


def _files(root: Path) -> set[str]:
    return {
        p.relative_to(root).as_posix()
        for p in root.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }


def _pip_supports_python_option() -> bool:
    try:
        major, minor = (int(x) for x in metadata.version("pip").split(".")[:2])
    except (metadata.PackageNotFoundError, ValueError):
        return False
    return (major, minor) >= (22, 3)


def test_wheel_installs_and_runs_elsewhere(tmp_path: Path) -> None:
    shipped = {name: _files(REPO / name) for name in DATA_DIRS}
    dist = tmp_path / "dist"
    _run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(dist), str(REPO)])
    wheel = next(dist.glob("uros_build-*.whl"))
    version = wheel.name.split("-")[1]

    # Every file of the data folders is in the wheel, under uros_build/_data/.
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
    in_wheel: dict[str, set[str]] = {}
    for name in DATA_DIRS:
        prefix = f"uros_build/_data/{name}/"
        in_wheel[name] = {n[len(prefix) :] for n in names if n.startswith(prefix) and not n.endswith("/")}
        assert shipped[name], f"{name}/ is empty in the checkout"
        missing = sorted(shipped[name] - in_wheel[name])
        assert not missing, f"{name}/ files missing from the wheel: {missing}"
    assert not [n for n in names if n.startswith(DATA_DIRS)], "data folders outside uros_build/_data"

    # A fresh venv that sees nothing of this environment; the package only from the wheel.
    env_dir = (tmp_path / "venv").resolve()
    pip_here = _pip_supports_python_option()
    venv.create(env_dir, with_pip=not pip_here, system_site_packages=False)
    py = env_dir / "bin" / "python"
    # --isolated: no pip.conf or PIP_* settings (a local index, constraints), --no-index: no network.
    pip = [sys.executable, "-m", "pip", "--python", str(py)] if pip_here else [str(py), "-m", "pip"]
    _run([*pip, "--isolated", "install", "--no-deps", "--no-index", "--no-compile", str(wheel)])
    # Then the dependencies (click, jinja2, colcon, ...): this environment's, appended after the
    # venv's own site-packages, so the wheel's uros_build comes first even where a checkout or
    # another copy of uros is installed here (.pth files in these folders are not processed, so
    # an editable install's path to the checkout is not added either).
    purelib = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
    venv_site = Path(_run([str(py), "-c", purelib]).strip())
    (venv_site / "zz_uros_test_outer_site.pth").write_text("".join(f"{d}\n" for d in _outer_site_dirs()))

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    # A PYTHONPATH pointing at a checkout (as when testing a worktree) would shadow the wheel.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")}
    env["PATH"] = f"{env_dir / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env.pop("VIRTUAL_ENV", None)

    where = json.loads(
        _run(
            [
                str(py),
                "-c",
                "import json, importlib.metadata as m, re, uros_build, uros_build.resources as r\n"
                "missing = []\n"
                "for req in m.requires('uros-build') or []:\n"
                "    if 'extra ==' in req: continue\n"
                "    name = re.match(r'[A-Za-z0-9._-]+', req).group(0)\n"
                "    try: m.distribution(name)\n"
                "    except m.PackageNotFoundError: missing.append(req)\n"
                "print(json.dumps({'package': uros_build.__file__, 'missing': missing,\n"
                "    'toolchains': str(r.toolchains_dir()), 'meta': str(r.meta_dir()),\n"
                "    'templates': str(r.templates_dir())}))",
            ],
            cwd=elsewhere,
            env=env,
        )
    )
    assert where["missing"] == [], "dependencies not installed in the environment running the tests"
    package = Path(where["package"]).parent
    assert package == venv_site / "uros_build", f"uros_build imported from {package}, not from the wheel"
    for name in DATA_DIRS:
        installed = Path(where[name])
        assert installed == package / "_data" / name, f"{name} read from {installed}"
        assert _files(installed) == in_wheel[name]

    # Probes added to the installed copy only: the CLI must show them, so it reads the wheel's files.
    data = package / "_data"
    m7 = (data / "toolchains" / "cortex-m7.yaml").read_text()
    (data / "toolchains" / "wheel-probe.yaml").write_text(re.sub(r"(?m)^name: .*$", "name: wheel-probe", m7))
    with (data / "templates" / "toolchain.cmake.j2").open("a") as f:
        f.write("\n# uros wheel probe\n")
    (data / "meta" / "transports" / "wheel-probe.json").write_text(
        json.dumps({"names": {"rmw_microxrcedds": {"cmake-args": ["-DRMW_UXRCE_TRANSPORT=wheel-probe"]}}})
    )

    uros = str(env_dir / "bin" / "uros")

    def cli(*args: str) -> str:
        return _run([uros, *args], cwd=elsewhere, env=env)

    assert version in cli("--version")
    targets = [t["name"] for t in json.loads(cli("targets", "--json"))]
    assert "cortex-m7" in targets and "wheel-probe" in targets
    tc = cli("toolchain", "render", "cortex-m7")
    assert "set(CMAKE_SYSTEM_NAME Generic)" in tc and "# uros wheel probe" in tc
    assert "-DRMW_UXRCE_TRANSPORT=custom" in cli("meta", "write", "--toolchain", "cortex-m7")
    assert "-DRMW_UXRCE_TRANSPORT=wheel-probe" in cli("meta", "write", "--transport", "wheel-probe")
    for name in ("microrosConfig.cmake.j2", "toolchain.cmake.j2", "esp-idf-component.cmake.j2"):
        assert name in in_wheel["templates"]
