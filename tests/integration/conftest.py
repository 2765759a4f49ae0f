from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from fixture_ws import fixture_build_args, make_fixture_workspace
from uros_helpers import need, run_uros

pytestmark = pytest.mark.integration


@pytest.fixture(scope="session")
def m7_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The fixture workspace built once for cortex-m7 through the real CLI; returns the workspace."""
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path_factory.mktemp("m7"))
    run_uros(*fixture_build_args(ws))
    return ws


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
