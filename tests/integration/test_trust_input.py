"""Round 5's settings and input checks (issue 43, "Also"), through the real CLI: each was accepted
without a word (a build that silently differed from what was asked) or answered with a hint that
did not hold. Each is now one line naming the flag, file or variable and the fix, a fixed exit code,
and nothing created or lost. In-process (`run_uros_here`) where the answer comes before any process
starts; a real `uros` process where git or a build runs first."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from fixture_ws import fixture_build_args, make_fixture_workspace
from uros_helpers import (
    default_sigint,
    env_without,
    fake_upstream,
    git_out,
    run_uros,
    run_uros_here,
    upstream_mirror,
)

from uros_build.config.sourceplan import plan_sources
from uros_build.sources import distros
from uros_build.sources.wsfiles import Lock

pytestmark = pytest.mark.integration


def _one_error(proc: subprocess.CompletedProcess[str]) -> tuple[str, str]:
    """(the one error line, the hint line or "")."""
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr, proc.stderr
    hints = [line for line in proc.stderr.splitlines() if line.startswith("hint:")]
    return errors[0], hints[0] if hints else ""


def _files(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if ".uros" not in p.parts)


def _ws(tmp: Path, uros_yaml: str | None = None) -> Path:
    ws = make_fixture_workspace(tmp / "ws")
    if uros_yaml is not None:
        (ws / "uros.yaml").write_text(uros_yaml)
    return ws


@pytest.mark.parametrize(
    ("key", "main", "example"),
    [("rtos_dir", "rtos", "freertos"), ("rtos_config", "rtos", "freertos"), ("rtos_port", "rtos", "freertos"),
     ("ip_stack_dir", "ip_stack", "lwip")],
)  # fmt: skip
def test_an_rtos_folder_in_uros_yaml_without_rtos_is_refused_not_built_bare_metal(
    tmp_path: Path, key: str, main: str, example: str
) -> None:
    """`rtos_dir:` without `rtos:` in uros.yaml built bare metal without a word (and an IP stack's
    folder without `ip_stack:` built without it)."""
    (tmp_path / "kernel").mkdir()
    ws = _ws(tmp_path, f"target: cortex-m7\n{key}: ../kernel\n")
    before = _files(tmp_path)
    proc = run_uros_here(*fixture_build_args(ws), check=False)
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert f"uros.yaml: {key} without {main}: (the build would ignore it)" in error
    assert f"add `{main}: {example}` to uros.yaml" in hint and f"remove {key}:" in hint
    assert _files(tmp_path) == before


@pytest.mark.parametrize("char", ['"', ";", "\\"])
def test_an_output_folder_cmake_cannot_use_is_refused_before_the_build(tmp_path: Path, char: str) -> None:
    """`uros build --output` took folders with '"' or ';' whose CMake package no project can use
    (CMake splits at ';'; its Makefiles generator writes '"' unescaped): `uros export` refused them."""
    ws = _ws(tmp_path)
    out = tmp_path / f"o{char}ut"
    before = _files(tmp_path)
    proc = run_uros_here(*fixture_build_args(ws, "--output", str(out)), check=False)
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert f"--output {out}: holds {char!r}, which CMake cannot use in the folder of a package" in error
    assert hint.startswith("hint: build into a folder without it")
    assert _files(tmp_path) == before
    # the same words as `uros export cmake`, whose check this is
    export = run_uros_here("export", "cmake", "--output", str(out), check=False)
    assert export.returncode == 2 and f"holds {char!r}, which CMake cannot use" in _one_error(export)[0]


def test_an_extra_package_that_is_no_folder_is_refused_not_left_out(tmp_path: Path) -> None:
    """`extra_packages: [/nonexistent]` built without the package after "keeping the copy" (there
    was none)."""
    ws = _ws(tmp_path, "target: cortex-m7\nextra_packages: [/nonexistent/my_msgs]\n")
    before = _files(tmp_path)
    proc = run_uros_here(*fixture_build_args(ws), check=False)
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert "uros.yaml: extra_packages: /nonexistent/my_msgs is no folder, and mcu_ws/extra_packages" in error
    assert "remove it from extra_packages:" in hint
    assert _files(tmp_path) == before


@pytest.mark.parametrize(
    ("variable", "value", "setting"),
    [
        ("UROS_CACHE_TIMEOUT", "abc", "cache_timeout"),
        ("UROS_CACHE_TIMEOUT", "-1", "cache_timeout"),
        ("UROS_CACHE_TIMEOUT", "0", "cache_timeout"),
        ("UROS_HOST_STAGE", "maybe", "host_stage"),
        ("UROS_GEN_CACHE", "disable", "gen_cache"),
        ("UROS_COMPILER_SEED", "2", "compiler_seed"),
    ],
)
def test_an_environment_setting_that_is_no_value_is_refused(
    tmp_path: Path, variable: str, value: str, setting: str
) -> None:
    """UROS_CACHE_TIMEOUT=abc|-1|0 silently became 60 s; a switch took any word but `off` as on."""
    ws = _ws(tmp_path)
    before = _files(tmp_path)
    proc = run_uros_here(*fixture_build_args(ws), env={variable: value}, check=False)
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert f"${variable}={value!r} is no {setting} value" in error
    assert (
        "more than 0 and less than 86400" if setting == "cache_timeout" else "off (or 0, false, no)"
    ) in hint
    assert _files(tmp_path) == before


@pytest.mark.parametrize(
    ("variable", "value", "setting"),
    [("UROS_HOST_STAGE", "0", "host_stage"), ("UROS_GEN_CACHE", "no", "gen_cache"),
     ("UROS_COMPILER_SEED", "false", "compiler_seed")],
)  # fmt: skip
def test_the_usual_words_for_off_turn_a_switch_off(
    tmp_path: Path, variable: str, value: str, setting: str
) -> None:
    """UROS_HOST_STAGE=0 and UROS_GEN_CACHE=no were on: only the exact word `off` was off. `uros
    build -v` says what each setting is before anything runs; here the build then stops at once
    (no readelf on PATH: exit 3), so nothing is built."""
    ws = _ws(tmp_path)
    env = {**env_without(("readelf",), tmp_path / "no-readelf"), variable: value}
    proc = run_uros(*fixture_build_args(ws, "-v"), env=env, check=False)
    assert proc.returncode == 3 and "'readelf' was not found on PATH" in proc.stderr, proc.stderr
    assert f"{setting} = off  (${variable})" in proc.stderr


@pytest.fixture(scope="module")
def upstream(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return fake_upstream(tmp_path_factory.mktemp("upstream"), ("humble",))


def test_a_lock_naming_a_repository_the_distro_lacks_is_refused(tmp_path: Path) -> None:
    """A lock with a repository humble does not have: that entry was skipped without a word."""
    humble = distros.load_distro("humble")
    sources = plan_sources(humble, distros.Mirror(), None)
    commits = dict.fromkeys(sources, "1" * 40)
    lock = json.loads(Lock.from_clones("humble", sources, commits).to_json())
    lock["repositories"]["mcu_ws/uros/my_fork"] = {**lock["repositories"]["mcu_ws/uros/rclc"]}
    crafted = tmp_path / "team.lock"
    crafted.write_text(json.dumps(lock))
    proc = run_uros_here(
        "create-firmware",
        "-w",
        str(tmp_path / "fw"),
        "--no-dev-build",
        "--lock-file",
        str(crafted),
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert (
        f"--lock-file {crafted}: locks 1 repository that humble does not have (mcu_ws/uros/my_fork)" in error
    )
    assert "remove that entry from it" in hint
    assert not (tmp_path / "fw").exists()


def test_locked_force_on_a_changed_clone_hints_a_fix_that_works(upstream: Path, tmp_path: Path) -> None:
    """`--locked --force` on a workspace whose clone has the user's edit hinted "--force re-clones
    it", to a command that had --force."""
    fw = tmp_path / "fw"
    base = ["create-firmware", "--workspace", str(fw), "--no-dev-build", *upstream_mirror(upstream)]
    run_uros(*base)
    (fw / "mcu_ws/uros/rclc/README").write_text("my edit\n")
    proc = run_uros(*base, "--locked", "--force", check=False)
    assert proc.returncode == 2, proc.stderr
    error, hint = _one_error(proc)
    assert "mcu_ws/uros/rclc has 1 changed file(s)" in error
    assert "--force" not in hint and "then run this command again: it re-clones the folder" in hint
    assert (fw / "mcu_ws/uros/rclc/README").read_text() == "my edit\n"
    git_out("checkout", "--", "README", cwd=fw / "mcu_ws/uros/rclc")
    run_uros(*base, "--locked", "--force")  # the hint's fix works


@pytest.fixture
def silent_cache() -> Iterator[tuple[str, threading.Event]]:
    """An HTTP "cache" that takes connections and never answers; the event is set at the first."""
    server = socket.create_server(("127.0.0.1", 0))
    asked = threading.Event()
    held: list[socket.socket] = []

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            held.append(conn)
            asked.set()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.getsockname()[1]}/cache/", asked
    server.close()
    for conn in held:
        conn.close()


def test_ctrl_c_during_the_upload_says_the_new_output_is_in_place(
    m7_build: Path, tmp_path: Path, silent_cache: tuple[str, threading.Event]
) -> None:
    """Ctrl-C during `--cache-upload` said "the previous output was left untouched" while the new
    output was in place (the upload runs after the swap)."""
    url, asked = silent_cache
    # up to date: the first request to the cache is the upload's
    args = [*fixture_build_args(m7_build), "--cache", url, "--cache-upload"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "uros_build", *args],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "UROS_CACHE_TIMEOUT": "300"},
        preexec_fn=default_sigint,
    )
    try:
        assert asked.wait(300), "uros never asked the cache"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    error, hint = _one_error(subprocess.CompletedProcess(args, 130, "", err))
    assert "the upload of entry" in error and "was interrupted (Ctrl-C)" in error
    out = m7_build / "build" / "cortex-m7"
    assert f"this build's output is in place in {out}" in hint and "left untouched" not in err
    assert (out / "libmicroros.a").is_file()
