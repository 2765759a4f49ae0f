from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import run_uros

pytestmark = pytest.mark.integration


def need(*programs: str) -> None:
    missing = [p for p in programs if shutil.which(p) is None]
    if missing:
        pytest.skip(f"not installed: {', '.join(missing)} (.ci/run installs them)")


@pytest.fixture(scope="session")
def m7_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The fixture workspace built once for cortex-m7 through the real CLI; returns the workspace."""
    need("arm-none-eabi-gcc", "cmake")
    ws = make_fixture_workspace(tmp_path_factory.mktemp("m7"))
    run_uros("build", "--toolchain", "cortex-m7", "--workspace", str(ws), "--meta", str(ws / "fixture.meta"))
    return ws
