"""The team cache (issue 19, items 3 and 5), through the real CLI, real builds and a real nginx
(WebDAV PUT) on loopback: a fresh workspace elsewhere takes the library from the cache instead of
building, byte for byte the one uploaded; another meta misses; an entry that is cut, corrupt, built
against other headers or for other ELF facts is never used; credentials never reach a log."""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import threading
import time
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest
from fixture_ws import fixture_build_args
from uros_helpers import build_fixture, need, run_uros, run_uros_here

from uros_build.output import team_cache as cache

pytestmark = pytest.mark.integration


def _fresh_copy(seed: Path, where: Path) -> Path:
    """The fixture's sources and meta in a new workspace (no .uros, no output): another checkout."""
    shutil.copytree(seed / "mcu_ws", where / "mcu_ws")
    shutil.copy(seed / "fixture.meta", where / "fixture.meta")
    return where


def _key(ws: Path) -> str:
    key: str = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())["build_key"]
    return key


def _library(ws: Path) -> bytes:
    return (ws / "build" / "cortex-m7" / "libmicroros.a").read_bytes()


@pytest.fixture
def seed(m7_build: Path) -> Path:
    """A built workspace, this test's own (restored: integration/conftest.py)."""
    return m7_build


def _upload_from(seed: Path, url: str, env: dict[str, str] | None = None) -> str:
    """The seed workspace, already built and up to date, uploaded to ``url``."""
    done = build_fixture(seed, "--cache", url, "--cache-upload", env=env)
    assert "up to date" in done.stderr, done.stderr
    return done.stderr


@pytest.fixture(scope="module")
def _uploaded_once(fixture_builds: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A file cache holding the entry uros uploads from the built m7 fixture, uploaded once for
    this module: every seed is that build restored at the same path (the same key, the same bytes)."""
    store = tmp_path_factory.mktemp("uploaded") / "store"
    _upload_from(fixture_builds.restore("m7"), store.as_uri())
    return store


@pytest.fixture
def uploaded(_uploaded_once: Path, tmp_path: Path) -> Path:
    """This test's own copy of :func:`_uploaded_once`'s cache (a folder; its URL is as_uri()): for a
    test whose subject is not the upload, which only needs the seed's entry in a cache."""
    return Path(shutil.copytree(_uploaded_once, tmp_path / "store"))


def test_a_fresh_workspace_takes_the_library_from_a_file_cache(seed: Path, tmp_path: Path) -> None:
    store = tmp_path / "team cache"
    said = _upload_from(seed, store.as_uri())
    key = _key(seed)
    assert f"uploaded entry {key[:16]}" in said
    assert sorted(p.name for p in store.iterdir()) == [f"{key}.json", f"{key}.tar.gz"]
    again = _upload_from(seed, store.as_uri())
    assert f"already has entry {key[:16]}" in again

    ws = _fresh_copy(seed, tmp_path / "another checkout")
    took = build_fixture(ws, "--cache", store.as_uri())
    assert f"from the cache {store.as_uri()} (entry {key[:16]})" in took.stderr, took.stderr
    assert not (ws / ".uros" / "targets" / "cortex-m7" / "build").exists()  # colcon never ran
    assert _library(ws) == _library(seed)  # the bytes, not the message
    info = json.loads((ws / "build" / "cortex-m7" / "build-info.json").read_text())
    assert info["build_key"] == key and info["from_cache"]["key"] == key
    assert (
        f"from the cache  {store.as_uri()} (not built here)"
        in run_uros("info", str(ws / "build" / "cortex-m7")).stdout
    )
    # up to date, and, taken from the cache, not built here: never uploaded back from this workspace
    again = build_fixture(ws, "--cache", store.as_uri(), "--cache-upload").stderr
    assert "up to date" in again
    assert "uploaded" not in again

    # another meta: another key, a miss, a real build (and its own entry once uploaded)
    other = build_fixture(
        ws, "--cache", store.as_uri(), "--cache-upload", "--set", "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=2"
    )
    assert "no entry" in other.stderr and "uploaded entry" in other.stderr
    assert (ws / ".uros" / "targets" / "cortex-m7" / "build").is_dir()
    assert _key(ws) != key and len(list(store.glob("*.json"))) == 2


def _entry_from(
    out: Path, key: str, work: Path, change: dict[str, bytes] | None = None
) -> tuple[bytes, bytes]:
    """(tarball, manifest) of an entry holding ``out`` with ``change``'s files replaced (their
    sha256 updated in build-info.json as an attacker or a broken uploader would)."""
    folder = work / "entry"
    shutil.copytree(out, folder)
    (folder / ".uros-output").unlink()
    info = json.loads((folder / "build-info.json").read_text())
    for name, data in (change or {}).items():
        (folder / name).write_bytes(data)
        if name == "libmicroros.a":
            info["library"]["sha256"] = hashlib.sha256(data).hexdigest()
    (folder / "build-info.json").write_text(json.dumps(info))
    data, files = cache.pack_entry(folder, sorted(p.name for p in folder.iterdir()))
    shutil.rmtree(folder)
    manifest = cache.Manifest(
        key, hashlib.sha256(data).hexdigest(), len(data), "cortex-m7", info["generated_by"], files=files
    )
    return data, manifest.to_json().encode()


def test_an_unusable_entry_is_never_used(seed: Path, tmp_path: Path) -> None:
    need("arm-none-eabi-gcc", "arm-none-eabi-ar")
    key = _key(seed)
    out = seed / "build" / "cortex-m7"
    store = tmp_path / "c"
    store.mkdir()
    library = _library(seed)
    good, manifest = _entry_from(out, key, tmp_path)
    # a library of Cortex-M0 objects in an entry that says cortex-m7, every checksum consistent
    (tmp_path / "m0.c").write_text("int m0(int x) { return x + 1; }\n")
    subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m0", "-mthumb", "-c", str(tmp_path / "m0.c"),
                    "-o", str(tmp_path / "m0.o")], check=True)  # fmt: skip
    subprocess.run(["arm-none-eabi-ar", "rcs", str(tmp_path / "m0.a"), str(tmp_path / "m0.o")], check=True)
    wrong = _entry_from(out, key, tmp_path, {"libmicroros.a": (tmp_path / "m0.a").read_bytes()})
    # the seed itself with no output asks the cache each time, and builds here from its own trees
    # when refused (a fresh checkout's cold build would add nothing to what is checked)
    ws = seed

    def attempt(tarball: bytes, manifest: bytes) -> str:
        (store / f"{key}.tar.gz").write_bytes(tarball)
        (store / f"{key}.json").write_bytes(manifest)
        shutil.rmtree(ws / "build", ignore_errors=True)  # no output: the build asks the cache again
        return build_fixture(ws, "--cache", store.as_uri()).stderr

    said = attempt(good[: len(good) // 2], manifest)  # cut short in transit
    assert "cut short or replaced" in said and "building instead" in said
    assert _library(ws) == library  # built here, and right

    flipped = bytearray(good)
    flipped[len(flipped) // 2] ^= 0xFF
    assert "(corrupt)" in attempt(bytes(flipped), manifest)

    headers = json.loads(manifest)
    headers["outside_headers"] = {"/usr/lib/arm-none-eabi/include/stdio.h": "0" * 64}
    assert "other headers outside the workspace (/usr/lib/arm-none-eabi/include/stdio.h)" in attempt(
        good, json.dumps(headers).encode()
    )

    assert "fails the ABI check" in attempt(*wrong)
    assert _library(ws) == library

    assert "from the cache" in attempt(good, manifest)  # and the good entry is taken
    assert _library(ws) == library


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


@pytest.fixture
def nginx(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """A real nginx on a free loopback port serving /uros/ with WebDAV PUT behind basic auth
    (user ci, password s3cret-pass); yields the cache URL and its document root."""
    need("nginx")
    top = tmp_path / "nginx"
    root = top / "root"
    (root / "uros").mkdir(parents=True)
    (top / "htpasswd").write_text("ci:{PLAIN}s3cret-pass\n")
    port = _free_port()
    user = "user root;" if os.geteuid() == 0 else ""  # as root, workers must still write the root
    (top / "nginx.conf").write_text(f"""
{user}
daemon off;
worker_processes 1;
pid {top}/nginx.pid;
events {{}}
http {{
  access_log {top}/access.log;
  client_body_temp_path {top}/body;
  proxy_temp_path {top}/proxy;
  fastcgi_temp_path {top}/fastcgi;
  uwsgi_temp_path {top}/uwsgi;
  scgi_temp_path {top}/scgi;
  client_max_body_size 0;
  server {{
    listen 127.0.0.1:{port};
    location /uros/ {{
      root {root};
      auth_basic "uros cache";
      auth_basic_user_file {top}/htpasswd;
      dav_methods PUT;
      create_full_put_path on;
    }}
  }}
}}
""")
    server = subprocess.Popen(
        ["nginx", "-p", str(top), "-c", str(top / "nginx.conf"), "-e", str(top / "error.log")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                if server.poll() is not None:
                    pytest.fail(f"nginx did not start: {(top / 'error.log').read_text(errors='replace')}")
                time.sleep(0.1)
        yield f"http://127.0.0.1:{port}/uros/", root / "uros"
    finally:
        server.terminate()
        server.wait(timeout=10)


def test_a_team_cache_on_nginx_webdav(seed: Path, tmp_path: Path, nginx: tuple[str, Path]) -> None:
    url, served = nginx
    netrc = tmp_path / "netrc"
    netrc.write_text("machine 127.0.0.1 login ci password s3cret-pass\n")
    netrc.chmod(0o600)
    with_netrc = {**os.environ, "NETRC": str(netrc)}
    key = _key(seed)

    refused = _upload_from(seed, url)  # no credentials: the server says no, the build stands
    assert "not uploaded" in refused and "HTTP 401" in refused

    said = _upload_from(seed, url, env=with_netrc)
    assert f"uploaded entry {key[:16]}" in said
    assert (served / f"{key}.tar.gz").is_file() and (served / f"{key}.json").is_file()

    ws = _fresh_copy(seed, tmp_path / "teammate")
    took = build_fixture(ws, "--cache", url, env=with_netrc)
    assert f"from the cache {url} (entry {key[:16]})" in took.stderr, took.stderr
    assert _library(ws) == _library(seed)
    # the password is in no output and no log, the token neither
    token_env = {**os.environ, "UROS_CACHE_TOKEN": "tok-123-secret"}
    build_fixture(ws, "--cache", url, "--cache-upload", env=token_env)
    logs = "".join(
        p.read_text(errors="replace")
        for top in (ws, seed)
        for p in (top / ".uros").rglob("*.log")
        if p.is_file() and not p.is_symlink()
    )
    for secret in ("s3cret-pass", "tok-123-secret", "czNjcmV0"):
        assert secret not in logs + said + took.stderr


def test_the_workspace_names_its_cache_and_the_command_line_wins(seed: Path, uploaded: Path) -> None:
    """uros.yaml's cache: is read without --cache; --cache none builds without it; --cache-upload
    without any cache is a one-line error naming the flag and the fix, and nothing is written."""
    store = uploaded
    library = _library(seed)
    # the seed itself with no output: a build asks the cache, and with --cache none builds here
    # from its own trees (no fresh checkout's cold build)
    ws = seed
    shutil.rmtree(ws / "build")
    (ws / "uros.yaml").write_text("distro: humble\ntarget: cortex-m7\n")
    refused = run_uros_here(  # refused before any process starts
        "build", "-w", str(ws), "--meta", str(ws / "fixture.meta"), "--cache-upload", check=False
    )
    assert refused.returncode == 2 and not (ws / "build").exists()
    assert "error: --cache-upload without a cache" in refused.stderr and "cache: line" in refused.stderr
    (ws / "uros.yaml").write_text(f"distro: humble\ntarget: cortex-m7\ncache: {store.as_uri()}\n")
    took = run_uros("build", "-w", str(ws), "--meta", str(ws / "fixture.meta")).stderr
    assert f"from the cache {store.as_uri()}" in took
    shutil.rmtree(ws / "build")
    plain = run_uros("build", "-w", str(ws), "--meta", str(ws / "fixture.meta"), "--cache", "none").stderr
    assert store.as_uri() not in plain and "\ncache: " not in f"\n{plain}" and "==> built " in plain
    assert _library(ws) == library


# ---------------------------------------------------------------------------------------------
# issue 34, item 7: only uros's files; credentials; never the reason a build fails


def _manifest_json(
    key: str, data: bytes, files: dict[str, bytes], headers: dict[str, str] | None = None
) -> bytes:
    """A manifest, as uros's own format says, for a tarball crafted by a test (``files``: what it
    lists, name -> content)."""
    listed = {n: {"bytes": len(d), "sha256": hashlib.sha256(d).hexdigest()} for n, d in files.items()}
    top = {
        "format": cache.FORMAT, "key": key, "archive_sha256": hashlib.sha256(data).hexdigest(),
        "archive_bytes": len(data), "target": "cortex-m7", "generated_by": "uros test",
        "outside_headers": headers or {}, "files": listed,
    }  # fmt: skip
    return json.dumps(top).encode()


def _crafted(out: Path, extra: dict[str, bytes | None]) -> tuple[bytes, dict[str, bytes]]:
    """A tarball of the output ``out`` (every uros file) with ``extra`` members added (None: a
    folder), and every file it holds by name: an entry whose checksums are all consistent."""
    files: dict[str, bytes] = {}
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for path in sorted(out.rglob("*")):
            name = path.relative_to(out).as_posix()
            if name == ".uros-output" or name in extra:  # replaced by ``extra``'s
                continue
            info = tarfile.TarInfo(name)
            if path.is_dir():
                info.type = tarfile.DIRTYPE
                tar.addfile(info)
                continue
            data = path.read_bytes()
            files[name] = data
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
        for name, content in extra.items():
            info = tarfile.TarInfo(name)
            if content is None:
                info.type = tarfile.DIRTYPE
                tar.addfile(info)
                continue
            files[name] = content
            info.size = len(content)
            tar.addfile(info, io.BytesIO(content))
    return buffer.getvalue(), files


def test_an_upload_packs_only_what_uros_wrote_and_a_take_keeps_the_users_files(
    seed: Path, tmp_path: Path
) -> None:
    """The user's notes.txt and private/cred.txt beside an up-to-date output were packed into the
    entry (and a teammate's take then overwrote their own notes.txt); a crafted entry with extra
    top-level names did the same. Now an upload packs what the output's marker names, and a take
    refuses any name an entry may not hold."""
    out = seed / "build" / "cortex-m7"
    (out / "private").mkdir()
    (out / "notes.txt").write_text("the uploader's notes\n")
    (out / "private" / "cred.txt").write_text("password=uploader\n")
    store = tmp_path / "store"
    said = _upload_from(seed, store.as_uri())  # up to date: the user's files are not part of it
    key = _key(seed)
    assert f"uploaded entry {key[:16]}" in said, said
    with tarfile.open(store / f"{key}.tar.gz") as tar:
        names = {m.name.split("/")[0] for m in tar}
    assert names == {"build-info.json", "include", "libmicroros.a", "microros.cmake", "microrosConfig.cmake",
                     "microrosConfigVersion.cmake", "toolchain.cmake"}  # fmt: skip

    # a teammate's output with their own notes.txt beside it, not up to date (its library edited)
    ws = _fresh_copy(seed, tmp_path / "teammate")
    assert "from the cache" in build_fixture(ws, "--cache", store.as_uri()).stderr
    mine = ws / "build" / "cortex-m7"
    (mine / "notes.txt").write_text("the teammate's notes\n")
    with (mine / "libmicroros.a").open("ab") as f:
        f.write(b"\n")
    # the entry now crafted with the uploader's notes.txt and another top-level folder
    data, files = _crafted(out, {"notes.txt": b"the uploader's notes\n", "private": None,
                                 "private/cred.txt": b"password=uploader\n"})  # fmt: skip
    (store / f"{key}.tar.gz").write_bytes(data)
    (store / f"{key}.json").write_bytes(_manifest_json(key, data, files))
    took = build_fixture(ws, "--cache", store.as_uri())
    assert "building instead" in took.stderr and "==> built " in took.stderr, took.stderr
    assert (mine / "notes.txt").read_text() == "the teammate's notes\n"
    assert not (mine / "private").exists()
    assert _library(ws) == _library(seed)


class _Server:
    """An HTTP server on a free loopback port, in a thread: ``routes`` maps a path's start to a
    function(handler) that answers; every request's path and Authorization header is recorded."""

    def __init__(self, routes: dict[str, Callable[[BaseHTTPRequestHandler], None]]) -> None:
        self.seen: list[tuple[str, str, str | None]] = []
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args: object) -> None:
                pass

            def _any(self) -> None:
                server.seen.append((self.command, self.path, self.headers.get("Authorization")))
                length = int(self.headers.get("Content-Length") or 0)
                self.body = self.rfile.read(length) if length else b""
                for start, answer in routes.items():
                    if self.path.startswith(start):
                        answer(self)
                        return
                self.send_response(404)
                self.send_header("Content-Length", "0")
                self.end_headers()

            do_GET = do_PUT = do_HEAD = _any

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.port = self.httpd.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def servers() -> Iterator[Callable[[dict[str, Callable[[BaseHTTPRequestHandler], None]]], _Server]]:
    started: list[_Server] = []

    def start(routes: dict[str, Callable[[BaseHTTPRequestHandler], None]]) -> _Server:
        started.append(_Server(routes))
        return started[-1]

    yield start
    for server in started:
        server.close()


def _redirect(to: str) -> Callable[[BaseHTTPRequestHandler], None]:
    def answer(handler: BaseHTTPRequestHandler) -> None:
        handler.send_response(302)
        handler.send_header("Location", to + handler.path.rpartition("/")[2])
        handler.send_header("Content-Length", "0")
        handler.end_headers()

    return answer


def _serve(folder: Path) -> Callable[[BaseHTTPRequestHandler], None]:
    """Files of ``folder`` by their last path part (404 when absent)."""

    def answer(handler: BaseHTTPRequestHandler) -> None:
        path = folder / handler.path.rpartition("/")[2]
        data = path.read_bytes() if path.is_file() else None
        handler.send_response(200 if data is not None else 404)
        handler.send_header("Content-Length", str(len(data or b"")))
        handler.end_headers()
        handler.wfile.write(data or b"")

    return answer


def _all_logs(*workspaces: Path) -> str:
    return "".join(
        p.read_text(errors="replace")
        for top in workspaces
        for p in (top / ".uros").rglob("*.log")
        if p.is_file() and not p.is_symlink()
    )


def test_credentials_never_follow_a_redirect_to_another_host_and_a_token_is_never_printed(
    seed: Path, tmp_path: Path, servers: Callable[..., _Server], uploaded: Path
) -> None:
    """urllib keeps Authorization on a redirect: the token and the netrc password went to whatever
    host the cache redirected to. A token with a trailing newline (as CI secrets often are) failed
    the build and printed the token on stderr and in the log."""
    files = uploaded  # the seed's entry, served
    elsewhere = servers({"/": _serve(files)})  # another port: another origin
    cache_server = servers({"/uros/": _redirect(f"{elsewhere.url}/entries/"), "/same/": _redirect("/files/"),
                            "/files/": _serve(files)})  # fmt: skip
    netrc = tmp_path / "netrc"
    netrc.write_text("machine 127.0.0.1 login ci password s3cret-pass\n")
    netrc.chmod(0o600)
    token = "tok-123-secret"
    for env in ({**os.environ, "NETRC": str(netrc)}, {**os.environ, "UROS_CACHE_TOKEN": token + "\n"}):
        ws = _fresh_copy(seed, tmp_path / f"ws{len(elsewhere.seen)}")
        took = build_fixture(ws, "--cache", f"{cache_server.url}/uros/", env=env)
        assert "from the cache" in took.stderr, took.stderr  # the redirect was followed...
        assert elsewhere.seen and all(auth is None for _, _, auth in elsewhere.seen)  # ...without credentials
        assert _library(ws) == _library(seed)
        for secret in ("s3cret-pass", "czNjcmV0", token):
            assert secret not in took.stdout + took.stderr + _all_logs(ws)
    # to the cache's own scheme, host and port, the (stripped) token still goes
    ws = _fresh_copy(seed, tmp_path / "same")
    took = build_fixture(
        ws, "--cache", f"{cache_server.url}/same/", env={**os.environ, "UROS_CACHE_TOKEN": token + "\n"}
    )
    assert "from the cache" in took.stderr, took.stderr
    assert ("GET", f"/files/{_key(seed)}.json", f"Bearer {token}") in cache_server.seen
    # a token no header can carry: one warning that does not print it, and a local build (the seed
    # with no output: it asks the cache, then builds here from its own trees)
    library = _library(seed)
    shutil.rmtree(seed / "build" / "cortex-m7")
    bad = build_fixture(
        seed,
        "--cache",
        f"{cache_server.url}/same/",
        env={**os.environ, "UROS_CACHE_TOKEN": "tok 123\x01secret"},
    )
    assert "UROS_CACHE_TOKEN" in bad.stderr and "building instead" in bad.stderr
    assert "secret" not in bad.stderr + _all_logs(seed) and _library(seed) == library


def _build_within(ws: Path, seconds: float, *more: str, env: dict[str, str] | None = None) -> str:
    """A build that must end within ``seconds`` (a FIFO or a trickling server hung it), with exit
    0 and no internal error; its stderr."""
    argv = [sys.executable, "-m", "uros_build", *fixture_build_args(ws)]
    try:
        done = subprocess.run([*argv, *more], capture_output=True, text=True, timeout=seconds, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"uros build did not end within {seconds} s")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert "internal error" not in done.stderr.lower(), done.stderr
    return done.stderr


@pytest.mark.parametrize(
    "case", ["file-folder-clash", "long-name", "huge-include", "fifo-tarball", "dev-zero-tarball",
             "dev-zero-header", "fifo-header", "injected-toolchain", "changed-header", "poisoned-header"],
)  # fmt: skip
def test_a_hostile_file_cache_entry_is_one_warning_and_a_local_build(
    seed: Path, tmp_path: Path, case: str
) -> None:
    """Each was an internal error, a hang or a 64 MB header in include/: now one line (a warning,
    or the info that the entry was built against other headers) and a build here, the same bytes."""
    key = _key(seed)
    out = seed / "build" / "cortex-m7"
    store = tmp_path / "store"
    store.mkdir()
    extra: dict[str, bytes | None] = {
        "file-folder-clash": {"include/fx_core": b"a file where a folder is\n"},
        "long-name": {"include/" + "n" * 300 + ".h": b"int n;\n"},
        "huge-include": {"include/huge.h": bytes(64 * 1024 * 1024)},
        # a firmware's cmake would run this (every checksum consistent)
        "injected-toolchain": {
            "toolchain.cmake": (out / "toolchain.cmake").read_bytes() + b"execute_process(COMMAND id)\n"
        },
    }.get(case, {})
    header = next(p for p in sorted(out.rglob("*.h")))
    header_name = header.relative_to(out).as_posix()
    if case == "changed-header":
        extra = {header_name: header.read_bytes().replace(b"#", b"/", 1)}
    if case == "poisoned-header":  # round 5: a consistent manifest of a header the sources disagree with
        poisoned = "include/fx_core/core.h"
        extra = {poisoned: (out / poisoned).read_bytes() + b"#define FX_CORE_POISONED 1\n"}
    data, files = _crafted(out, extra)
    if case == "changed-header":  # the manifest lists the header as it was built
        files[header_name] = header.read_bytes()
    headers = {}
    if case.endswith("-header") and case != "poisoned-header":
        fifo = tmp_path / "header-fifo"
        os.mkfifo(fifo)
        headers = {"/dev/zero" if case == "dev-zero-header" else str(fifo): "0" * 64}
    (store / f"{key}.json").write_bytes(_manifest_json(key, data, files, headers))
    if case == "fifo-tarball":
        os.mkfifo(store / f"{key}.tar.gz")
    elif case == "dev-zero-tarball":
        (store / f"{key}.tar.gz").symlink_to("/dev/zero")
    else:
        (store / f"{key}.tar.gz").write_bytes(data)
    # the seed with no output asks the cache and, refused, builds here from its own trees (a fresh
    # checkout's cold build would add nothing to what is checked: the refusal and a local build)
    library = _library(seed)
    shutil.rmtree(out)
    said = _build_within(seed, 300, "--cache", store.as_uri())
    expected = "other headers outside the workspace" if case.endswith("-header") else "building instead"
    if case == "poisoned-header":  # one line, no download of the tarball
        expected = "'s include/fx_core/core.h is not the workspace's header of that name: building instead"
    assert expected in said and said.count("warning:") <= 1, said
    assert "==> built " in said and _library(seed) == library
    assert not (out / "include" / "huge.h").exists()


def _answer(
    status: int, body: bytes, length: int | None = None, pause: float = 0.0, forever: bool = False
) -> Callable[[BaseHTTPRequestHandler], None]:
    """An answer: ``body`` after a Content-Length of ``length`` (None: none, the connection closes
    at the end); ``pause`` seconds between bytes (a trickle); ``forever``: ``body`` again and again."""

    def answer(handler: BaseHTTPRequestHandler) -> None:
        handler.send_response(status)
        if length is not None:
            handler.send_header("Content-Length", str(length))
        else:
            handler.send_header("Connection", "close")
            handler.close_connection = True
        handler.end_headers()
        try:
            while True:
                if pause:
                    for i in range(len(body)):
                        handler.wfile.write(body[i : i + 1])
                        handler.wfile.flush()
                        time.sleep(pause)
                else:
                    handler.wfile.write(body)
                if not forever:
                    break
        except OSError:
            pass  # the client gave up: as it should
        handler.close_connection = True

    return answer


HOSTILE_HTTP = {
    "closed": "closed before the end",
    "endless": "more than the",
    "trickle": "no whole answer within",
    "port": "building instead",
    "ipv6": "building instead",
}


@pytest.mark.parametrize(
    "cases",
    [
        pytest.param(("closed", "port", "ipv6"), id="at-once"),
        # against uros's 2 s deadline: read, or waited for, for as long as the machine lets them
        pytest.param(("endless", "trickle"), id="over-time", marks=pytest.mark.serial),
    ],
)
def test_a_hostile_http_cache_is_one_warning_and_a_local_build(
    seed: Path, uploaded: Path, servers: Callable[..., _Server], cases: tuple[str, ...]
) -> None:
    """A connection closed before the end of the body (an internal error), an endless body (read
    until memory ran out), a trickling server (no overall deadline), a redirect to a port that is
    not a number or a malformed IPv6 host (internal errors): each one warning and a build here.
    The cases that last (an endless body, a trickle) are serial, the others not."""
    store = uploaded
    key = _key(seed)
    manifest = (store / f"{key}.json").read_bytes()
    tarball = (store / f"{key}.tar.gz").read_bytes()
    served = _serve(store)
    server = servers({
        "/closed/": lambda h: (served if h.path.endswith(".json") else _answer(200, tarball[:100], len(tarball)))(h),
        "/endless/": lambda h: (served if h.path.endswith(".json") else _answer(200, bytes(65536), forever=True))(h),
        "/trickle/": _answer(200, manifest, len(manifest), pause=0.5),
        "/port/": _redirect("http://127.0.0.1:abc/x/"),
        "/ipv6/": _redirect("http://[::1/x/"),
    })  # fmt: skip
    env = {**os.environ, "UROS_CACHE_TIMEOUT": "2"}
    library = _library(seed)
    for case in cases:
        says = HOSTILE_HTTP[case]
        # the seed with no output asks the cache and, refused, builds here from its own trees
        shutil.rmtree(seed / "build" / "cortex-m7")
        started = time.monotonic()
        said = _build_within(seed, 300, "--cache", f"{server.url}/{case}/", env=env)
        assert says in said and said.count("warning:") == 1 and "==> built " in said, (case, said)
        assert _library(seed) == library
        assert case != "trickle" or time.monotonic() - started < 120


def test_a_corrupt_entry_is_replaced_by_the_next_upload(seed: Path, tmp_path: Path, uploaded: Path) -> None:
    """An entry that fails its checks (here one flipped byte) stayed for good: every upload said
    the cache already had it. Now an upload replaces it, and a teammate takes the new one."""
    store = uploaded
    key = _key(seed)
    tarball = store / f"{key}.tar.gz"
    flipped = bytearray(tarball.read_bytes())
    flipped[len(flipped) // 2] ^= 0xFF
    tarball.write_bytes(bytes(flipped))
    said = _upload_from(seed, store.as_uri())
    assert "fails its checks" in said and f"uploaded entry {key[:16]}" in said, said
    assert "already has entry" in _upload_from(seed, store.as_uri())
    ws = _fresh_copy(seed, tmp_path / "teammate")
    assert "from the cache" in build_fixture(ws, "--cache", store.as_uri()).stderr
    assert _library(ws) == _library(seed)
