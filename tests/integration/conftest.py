from __future__ import annotations

import json
import os
import shutil
import stat
from collections.abc import Callable
from pathlib import Path

import pytest
from fixture_ws import VARIANTS, make_fixture_workspace
from uros_helpers import build_fixture, fake_upstream, git_out, need, run_uros, upstream_mirror

pytestmark = pytest.mark.integration


def _remove(path: Path) -> None:
    """rmtree that also removes what a test left read-only."""

    def again(func: Callable[[str], object], name: str, _exc: object) -> None:
        os.chmod(os.path.dirname(name), stat.S_IRWXU)
        if os.path.isdir(name) and not os.path.islink(name):
            os.chmod(name, stat.S_IRWXU)
        func(name)

    if path.exists() or path.is_symlink():
        shutil.rmtree(path, onerror=again)


class Built:
    """The fixture variants built once per worker, in ``root``/<variant>/ws, kept as a snapshot
    beside it; :meth:`restore` puts a fresh copy back in that same folder (copytree keeps every
    mtime, so the next build of the variant's command is up to date)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.failed: dict[str, str] = {}

    def restore(self, variant: str = "m7") -> Path:
        ws, snapshot = self.root / variant / "ws", self.snapshot(variant)
        _remove(ws)
        shutil.copytree(snapshot, ws, symlinks=True)
        return ws

    def snapshot(self, variant: str = "m7") -> Path:
        """The snapshot of the built ``variant`` (built first if need be), to copy from, never to
        change: a copy elsewhere is a built workspace moved (its outputs are to read, not rebuild)."""
        need("arm-none-eabi-gcc", "cmake")
        ws, snapshot = self.root / variant / "ws", self.root / variant / "snapshot"
        if variant in self.failed:
            pytest.fail(f"the {variant} fixture build failed in an earlier test:\n{self.failed[variant]}")
        if snapshot.is_dir():
            return snapshot
        _remove(ws)
        make_fixture_workspace(ws)
        try:
            build_fixture(ws, *VARIANTS[variant])
        except AssertionError as exc:
            self.failed[variant] = str(exc)
            raise
        shutil.copytree(ws, snapshot.with_name("snapshot.part"), symlinks=True)
        snapshot.with_name("snapshot.part").rename(snapshot)
        return snapshot


@pytest.fixture(scope="session")
def fixture_builds(tmp_path_factory: pytest.TempPathFactory) -> Built:
    """The built fixture variants of this worker (see :func:`built`)."""
    return Built(tmp_path_factory.getbasetemp() / "built")


@pytest.fixture
def built(fixture_builds: Built) -> Callable[[str], Path]:
    """``built(variant)``: a fixture workspace of VARIANTS built, fresh for this test, at a fixed
    path of this worker (one test at a time there): the workspace."""
    return fixture_builds.restore


@pytest.fixture
def m7_build(fixture_builds: Built) -> Path:
    """The fixture workspace built for cortex-m7 through the real CLI (variant m7), fresh for this
    test: the workspace."""
    return fixture_builds.restore("m7")


@pytest.fixture(scope="session")
def m7_snapshot(fixture_builds: Built) -> Path:
    """The snapshot of the m7 variant itself, not a copy (no restore): for a test or a module that
    only reads it or copies from it, never one that changes it or builds in it."""
    return fixture_builds.snapshot("m7")


@pytest.fixture(scope="session")
def _upstream_snapshot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return fake_upstream(tmp_path_factory.mktemp("upstream-snapshot"), ("humble", "iron"))


@pytest.fixture
def upstream(_upstream_snapshot: Path, tmp_path: Path) -> Path:
    """A fake upstream (uros_helpers.fake_upstream) of every repository humble and iron clone,
    humble's branches checked out: made once per worker, a fresh copy for each test (which may
    commit to it)."""
    return Path(shutil.copytree(_upstream_snapshot, tmp_path / "upstream", symlinks=True))


@pytest.fixture
def upstream_to_read(_upstream_snapshot: Path) -> Path:
    """The fake upstream of :func:`upstream` itself, not a copy: for a test that only clones and
    fetches from it (a commit or a branch changed there would reach this worker's later tests)."""
    return _upstream_snapshot


@pytest.fixture(scope="session")
def _created_snapshot(_upstream_snapshot: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    fw = tmp_path_factory.mktemp("created") / "firmware"
    run_uros(
        "create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(_upstream_snapshot)
    )
    return fw


def _copy_created(snapshot: Path, fw: Path) -> Path:
    """A copy of the created workspace ``snapshot`` at ``fw``, each clone's index refreshed as git
    would at its first look (a copy's files have new inodes and ctimes, which git's stat cache
    records): the clones are then byte for byte as create-firmware left them."""
    shutil.copytree(snapshot, fw, symlinks=True)
    for clone in json.loads((fw / "uros.lock").read_text())["repositories"]:
        git_out("update-index", "-q", "--refresh", cwd=fw / clone)
    return fw


@pytest.fixture
def created(_created_snapshot: Path, tmp_path: Path) -> Path:
    """``uros create-firmware --workspace W --no-dev-build`` (humble) from :func:`upstream_to_read`,
    made once per worker: a copy of this test's own at tmp_path/firmware (a created workspace names
    its own folder nowhere; its clones fetch from that upstream, which the test must not change)."""
    return _copy_created(_created_snapshot, tmp_path / "firmware")


@pytest.fixture(scope="session")
def spanish_env(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The environment of a Spanish-speaking user (es_ES.UTF-8): the installed locale, or one
    compiled with localedef into a temporary LOCPATH; skipped where neither is possible. Checked
    to be in effect: readelf prints "Máquina:" there."""
    import subprocess

    need("readelf")
    env = {**os.environ, "LANG": "es_ES.UTF-8", "LC_ALL": "es_ES.UTF-8", "LANGUAGE": "es"}
    installed = subprocess.run(["locale", "-a"], capture_output=True, text=True).stdout.split()
    if not {"es_ES.utf8", "es_ES.UTF-8"} & set(installed):
        if shutil.which("localedef") is None:
            pytest.skip("no es_ES locale and no localedef to compile one")
        folder = tmp_path_factory.mktemp("locale")
        made = subprocess.run(
            ["localedef", "-i", "es_ES", "-f", "UTF-8", str(folder / "es_ES.UTF-8")], capture_output=True
        )
        if made.returncode != 0:
            pytest.skip(f"localedef could not compile es_ES.UTF-8: {made.stderr.decode()[:200]}")
        env["LOCPATH"] = str(folder)
    header = subprocess.run(["readelf", "-h", "/bin/sh"], capture_output=True, text=True, env=env).stdout
    if "Máquina:" not in header:
        pytest.skip("readelf has no Spanish messages here (binutils' translations are not installed)")
    return env


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A test that asks for a built fixture runs a real colcon build (its worker's first), and so does
    one of real sources: marked colcon (the others that build say so themselves)."""
    for item in items:
        built = {"built", "m7_build", "fixture_builds"} & set(getattr(item, "fixturenames", ()))
        if built or item.get_closest_marker("realsources"):
            item.add_marker(pytest.mark.colcon)
