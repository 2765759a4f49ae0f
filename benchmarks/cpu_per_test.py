"""A pytest plugin: the CPU seconds each test costs (issue 38), which a loaded machine changes far less
than the wall clock.

    UROS_TEST_COSTS=DIR python -m pytest -q -p cpu_per_test (PYTHONPATH=benchmarks)     # one JSON line per test in DIR
    python benchmarks/house_metrics.py --costs DIR                        # the ranked lists

For every test (setup, call and teardown: a session fixture's build is counted in the first test that
asks for it, on its worker) it records the user + system seconds of the pytest process and of every
process it started and waited for (getrusage RUSAGE_SELF + RUSAGE_CHILDREN: a grandchild is counted
when its parent waited for it, as colcon, CMake and ninja do), the wall seconds, when it ended,
whether it is marked serial, and its worker. Under pytest-xdist each worker writes its own file, so
tests running side by side do not count each other's work.
"""

from __future__ import annotations

import json
import os
import resource
import time
from collections.abc import Iterator
from pathlib import Path

import pytest


def _cpu() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@pytest.hookimpl(hookwrapper=True, trylast=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    folder = os.environ.get("UROS_TEST_COSTS")
    if not folder:
        yield
        return
    cpu, wall = _cpu(), time.monotonic()
    yield
    record = {
        "test": item.nodeid,
        "cpu": round(_cpu() - cpu, 3),
        "wall": round(time.monotonic() - wall, 3),
        "end": round(time.time(), 3),  # when it ended: each worker's last end shows its idle tail
        "serial": item.get_closest_marker("serial") is not None,
        "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"),
    }
    Path(folder).mkdir(parents=True, exist_ok=True)
    out = Path(folder) / f"costs-{record['worker']}-{os.getpid()}.jsonl"
    with out.open("a", encoding="utf-8") as f:
        f.write(json.dumps(record, sort_keys=True) + "\n")
