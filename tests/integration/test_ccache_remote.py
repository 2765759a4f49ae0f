"""Issue 33, item 6: a build farm on existing engines. ccache's own remote storage, against a real
Redis (Debian's redis-server, started here on 127.0.0.1 and a free port, stopped here): a second
workspace at another path with an empty local ccache takes every compile from the remote store, the
build says so, and its libmicroros.a is byte for byte the first's."""

from __future__ import annotations

import hashlib
import json
import os
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fixture_ws import fixture_build_args, make_fixture_workspace
from uros_helpers import need, run_uros

pytestmark = [pytest.mark.integration, pytest.mark.colcon]

LOOPBACK = "127.0.0.1"  # the only address the server listens on, and the only one the test talks to


def _free_port() -> int:
    with socket.socket() as s:
        s.bind((LOOPBACK, 0))
        port: int = s.getsockname()[1]
        return port


@pytest.fixture
def redis(tmp_path: Path) -> Iterator[str]:
    """A real redis-server on a free loopback port, nothing saved to disk; yields ccache's URL."""
    need("redis-server", "ccache")
    features = subprocess.run(["ccache", "--version"], capture_output=True, text=True).stdout
    if "redis-storage" not in features:
        pytest.skip(f"this ccache has no Redis storage backend: {features.splitlines()[:2]}")
    folder = tmp_path / "redis"
    folder.mkdir()
    port = _free_port()
    argv = ["redis-server", "--bind", LOOPBACK, "--port", str(port), "--protected-mode", "yes"]
    argv += ["--save", "", "--appendonly", "no", "--dir", str(folder), "--logfile", str(folder / "log")]
    server = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(100):
            try:
                with socket.create_connection((LOOPBACK, port), timeout=0.2) as s:
                    s.sendall(b"PING\r\n")
                    if s.recv(16).startswith(b"+PONG"):
                        break
            except OSError:
                pass
            if server.poll() is not None:
                pytest.fail(f"redis-server did not start: {(folder / 'log').read_text(errors='replace')}")
            time.sleep(0.1)
        yield f"redis://{LOOPBACK}:{port}"
    finally:
        server.terminate()
        server.wait(timeout=10)


def _stats(ws: Path) -> list[str]:
    return (ws / ".uros" / "targets" / "cortex-m7" / "ccache-stats.log").read_text().splitlines()


def _sha256(ws: Path) -> str:
    return hashlib.sha256((ws / "build" / "cortex-m7" / "libmicroros.a").read_bytes()).hexdigest()


def test_a_second_workspace_takes_its_compiles_from_ccache_remote_storage_on_redis(
    tmp_path: Path, redis: str
) -> None:
    need("arm-none-eabi-gcc", "cmake")
    seconds = {}
    said = {}
    for name in ("first", "second machine"):
        ws = make_fixture_workspace(tmp_path / name)
        # each its own empty local cache, as on another machine; the remote store is shared
        env = {**os.environ, "CCACHE_DIR": str(tmp_path / f"ccache {name}"), "CCACHE_REMOTE_STORAGE": redis}
        began = time.monotonic()
        said[name] = run_uros(*fixture_build_args(ws, "--ccache"), env=env).stderr
        seconds[name] = time.monotonic() - began
    first, second = tmp_path / "first", tmp_path / "second machine"

    compiles = _stats(first).count("cache_miss")
    assert compiles >= 8 and _stats(first).count("remote_storage_write") >= compiles, _stats(first)
    assert f"ccache: 0 of {compiles} compiles taken from the cache" in said["first"], said["first"]
    # the second: every compile missed the empty local cache and hit the remote one
    assert _stats(second).count("local_storage_miss") == compiles
    assert _stats(second).count("remote_storage_hit") == compiles
    assert "cache_miss" not in _stats(second)
    line = f"ccache: {compiles} of {compiles} compiles taken from the cache (100%), {compiles} of them from its remote storage"
    assert line in said["second machine"], said["second machine"]
    info = json.loads((second / "build" / "cortex-m7" / "build-info.json").read_text())
    assert info["ccache"] == {"hits": compiles, "misses": 0, "remote_hits": compiles}
    shown = run_uros("info", str(second / "build" / "cortex-m7")).stdout
    assert (
        f"{compiles} of {compiles} compiles of this build taken from the cache ({compiles} from its remote storage)"
        in shown
    )
    assert _sha256(first) == _sha256(second)  # the bytes, not the message
    # where the entries are kept is no input of the build: the remote storage turned off, another
    # local cache, and the workspace is up to date (colcon ran again for each before)
    env = {k: v for k, v in os.environ.items() if k != "CCACHE_REMOTE_STORAGE"}
    again = run_uros(*fixture_build_args(second), env={**env, "CCACHE_DIR": str(tmp_path / "other")}).stderr
    assert "up to date" in again and "changed since the last build" not in again, again
    # figures for docs/cache.md (pytest -s shows them)
    print(f"\nremote ccache: first {seconds['first']:.1f} s, second {seconds['second machine']:.1f} s, "
          f"{compiles} of {compiles} compiles from Redis")  # fmt: skip
