from __future__ import annotations

import json
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest


def pytest_configure(config: pytest.Config) -> None:
    """Builds the tests start keep their generation cache (uros's, normally ~/.cache/uros/gen) in
    a folder of this run's own, unless the caller chose one: a test run neither reads nor fills
    the user's. Under pytest-xdist each worker has its own (the workers inherit the controller's
    environment: one this conftest set is replaced, one the caller set is kept)."""
    ours = os.environ.get("UROS_TEST_GEN_CACHE_DIR")
    if not os.environ.get("UROS_GEN_CACHE_DIR") or os.environ["UROS_GEN_CACHE_DIR"] == ours:
        os.environ["UROS_GEN_CACHE_DIR"] = os.environ["UROS_TEST_GEN_CACHE_DIR"] = tempfile.mkdtemp(
            prefix="uros-test-gen-cache-"
        )
    _keep_bytecode()


def _keep_bytecode() -> None:
    """Where bytecode is not written (PYTHONDONTWRITEBYTECODE, set on some CI images and on this
    project's lab machines), every `uros` a test starts compiled all of uros_build from source
    first: 0.25 s more CPU in each start (0.6 -> 0.35 s for `uros --version`, 0.9 -> 0.6 s for an
    up-to-date build of the fixture).
    The run's processes (the workers, and every `uros` they start) keep it in a folder of the test
    runs' own instead (PYTHONPYCACHEPREFIX), never beside the sources; a prefix the caller chose is
    kept. Python checks each compiled module against its source's time and size, as beside it."""
    if not sys.flags.dont_write_bytecode or os.environ.get("PYTHONPYCACHEPREFIX"):
        return
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    os.environ["PYTHONPYCACHEPREFIX"] = os.path.join(
        tempfile.gettempdir(), f"uros-test-pycache-{os.getuid()}"
    )


MODULE_CPU = Path(__file__).with_name("module_cpu.json")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The modules with tests marked serial first (pytest-xdist keeps this order of the modules with
    --no-loadscope-reorder: their serial tests run while the other modules wait), then the others
    the costliest first, by the CPU seconds module_cpu.json measured for them (written by
    `benchmarks/house_metrics.py --costs DIR --write-module-cpu`; a module it lacks, a new one,
    counts as the costliest: early, where a long module does no harm). A worker that takes a module
    late takes a short one, so the workers end together (with --dist loadfile a module runs on one
    worker, start to end)."""
    cpu: dict[str, float] = json.loads(MODULE_CPU.read_text()) if MODULE_CPU.is_file() else {}
    serial = {item.nodeid.split("::")[0] for item in items if item.get_closest_marker("serial")}

    def order(item: pytest.Item) -> tuple[bool, float]:
        path = item.nodeid.split("::")[0]
        return path not in serial, -cpu.get(path, float("inf"))

    items.sort(key=order)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """Under pytest-xdist a test marked serial runs with no other test running (its setup, the
    session fixtures it builds and its teardown too): a lock that every test holds shared and a
    serial test exclusive, with a turnstile that a waiting serial test holds, so that the other
    workers' next tests wait for it (no starving). Without workers, nothing to do."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        yield
        return
    import fcntl

    root = item.config._tmp_path_factory.getbasetemp().parent  # type: ignore[attr-defined]
    serial = item.get_closest_marker("serial") is not None
    with open(root / "serial.turnstile", "a") as turnstile, open(root / "serial.lock", "a") as lock:
        fcntl.flock(turnstile, fcntl.LOCK_EX)
        fcntl.flock(lock, fcntl.LOCK_EX if serial else fcntl.LOCK_SH)
        if not serial:
            fcntl.flock(turnstile, fcntl.LOCK_UN)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
            fcntl.flock(turnstile, fcntl.LOCK_UN)
