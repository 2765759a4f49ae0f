"""The team cache's pure parts: URLs, the entry's bytes, manifests, credentials (issue 19)."""

from __future__ import annotations

import hashlib
import io
import os
import tarfile
from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.output import cache_store
from uros_build.output import team_cache as cache


def test_urls() -> None:
    assert cache.parse_url("file:///srv/uros cache", "--cache").location == "/srv/uros cache"
    assert cache.parse_url("/srv/c", "--cache") == cache.CacheUrl("file", "/srv/c", "file:///srv/c")
    url = cache.parse_url("https://cache.example.com:8443/uros?sig=SECRET", "--cache")
    assert url.location == "https://cache.example.com:8443/uros/?sig=SECRET"
    assert url.shown == "https://cache.example.com:8443/uros/"  # a presigned query is never printed


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("https://me:hunter2@cache.example.com/uros", "holds credentials"),
        ("s3://bucket/uros", "not a file://, http:// or https:// URL"),
        ("cache", "not a file://"),
        ("file://host/srv/c", "absolute folder"),
        ("http:///uros", "names no host"),
    ],
)
def test_bad_urls_name_the_flag(text: str, says: str) -> None:
    with pytest.raises(ConfigError) as err:
        cache.parse_url(text, "--cache")
    assert says in str(err.value) and str(err.value).startswith("--cache")
    assert "hunter2" not in str(err.value) + str(err.value.hint)


def _output(folder: Path) -> Path:
    (folder / "include" / "pkg").mkdir(parents=True)
    (folder / "include" / "pkg" / "a.h").write_text("int a;\n")
    (folder / "libmicroros.a").write_bytes(b"!<arch>\n")
    (folder / "build-info.json").write_text("{}\n")
    return folder


def _manifest(
    data: bytes, key: str = "k" * 64, files: dict[str, tuple[int, str]] | None = None
) -> cache.Manifest:
    sha = hashlib.sha256(data).hexdigest()
    return cache.Manifest(key, sha, len(data), "cortex-m7", "uros 0", files=files or {})


def _entry(folder: Path, names: list[str]) -> tuple[bytes, cache.Manifest]:
    data, files = cache.pack_entry(folder, names)
    return data, _manifest(data, files=files)


def test_the_entry_depends_on_content_only(tmp_path: Path) -> None:
    one = _output(tmp_path / "one")
    two = _output(tmp_path / "two")
    (two / "libmicroros.a").touch()  # another mtime
    names = ["build-info.json", "include", "libmicroros.a"]
    assert cache.pack(one, names) == cache.pack(two, list(reversed(names)))
    (two / "include" / "pkg" / "a.h").write_text("int b;\n")
    assert cache.pack(one, names) != cache.pack(two, names)


def test_unpack_round_trip_and_fresh_times(tmp_path: Path) -> None:
    data, manifest = _entry(_output(tmp_path / "one"), ["include", "libmicroros.a", "build-info.json"])
    tops = cache.unpack(data, manifest, tmp_path / "out")
    assert tops == ["build-info.json", "include", "libmicroros.a"]
    assert (tmp_path / "out" / "include" / "pkg" / "a.h").read_text() == "int a;\n"
    # the download's time, not the tar's 1970: a firmware linked against an older library relinks
    assert (tmp_path / "out" / "libmicroros.a").stat().st_mtime > 1e9


def test_cut_or_corrupt_entries_are_refused(tmp_path: Path) -> None:
    data, manifest = _entry(_output(tmp_path / "one"), ["libmicroros.a"])
    with pytest.raises(cache.CacheUnusable, match="cut short"):
        cache.unpack(data[:-3], manifest, tmp_path / "a")
    flipped = bytes([data[0] ^ 1]) + data[1:]
    with pytest.raises(cache.CacheUnusable, match="corrupt"):
        cache.unpack(flipped, manifest, tmp_path / "b")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


@pytest.mark.parametrize("name", ["../evil", "/etc/evil", "a/../../evil", "link"])
def test_entries_never_write_outside_their_folder(tmp_path: Path, name: str) -> None:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        info = tarfile.TarInfo(name)
        if name == "link":
            info.type, info.linkname = tarfile.SYMTYPE, "/etc/passwd"
            tar.addfile(info)
        else:
            info.size = 4
            tar.addfile(info, io.BytesIO(b"evil"))
    data = buffer.getvalue()
    with pytest.raises(cache.CacheUnusable, match="refused"):
        cache.unpack(data, _manifest(data), tmp_path / "x" / "out")
    assert not (tmp_path / "evil").exists() and not (tmp_path / "x" / "evil").exists()


def test_manifests() -> None:
    manifest = cache.Manifest(
        "k" * 64, "5" * 64, 10, "cortex-m7", "uros 1", {"/usr/include/a.h": "1" * 64},
        {"libmicroros.a": (8, "2" * 64), "include/pkg/a.h": (7, "3" * 64)},
    )  # fmt: skip
    back = cache.parse_manifest(manifest.to_json().encode(), "k" * 64)
    assert back == manifest
    with pytest.raises(cache.CacheUnusable, match="not a format-2 manifest of this key"):
        cache.parse_manifest(manifest.to_json().encode(), "j" * 64)
    with pytest.raises(cache.CacheUnusable, match="not JSON"):
        cache.parse_manifest(b'{"format": 1, "key"', "k" * 64)
    assert cache.headers_differ(back, {"/usr/include/a.h": "1" * 64}) == []
    assert cache.headers_differ(back, {"/usr/include/a.h": "missing"}) == ["/usr/include/a.h"]


def test_credentials_from_the_environment_or_netrc(tmp_path: Path) -> None:
    assert (
        cache_store.authorization("c.example", {"UROS_CACHE_TOKEN": "t0k", "HOME": str(tmp_path)})
        == "Bearer t0k"
    )
    assert cache_store.authorization("c.example", {"HOME": str(tmp_path)}) == ""
    netrc = tmp_path / "netrc"
    netrc.write_text("machine c.example login ci password s3cret\n")
    netrc.chmod(0o600)
    assert cache_store.authorization("c.example", {"NETRC": str(netrc)}) == "Basic Y2k6czNjcmV0"
    assert cache_store.authorization("other.example", {"NETRC": str(netrc)}) == ""


def test_file_store(tmp_path: Path) -> None:
    store = cache_store.FileStore(tmp_path / "c")
    assert store.get("x.json", 10) is None
    store.put("x.json", b"{}")
    assert store.get("x.json", 10) == b"{}" and [p.name for p in (tmp_path / "c").iterdir()] == ["x.json"]
    with pytest.raises(cache.CacheUnusable, match="more than the 1 "):
        store.get("x.json", 1)


def test_a_store_reads_only_regular_files_and_never_waits(tmp_path: Path) -> None:
    """A FIFO or /dev/zero where an entry should be: refused at once (a FIFO with no writer used to
    hang the build, /dev/zero to fill the memory); as an outside header a manifest names: missing."""
    store = cache_store.FileStore(tmp_path)
    os.mkfifo(tmp_path / "k.tar.gz")
    (tmp_path / "z.tar.gz").symlink_to("/dev/zero")
    for name in ("k.tar.gz", "z.tar.gz"):
        with pytest.raises(cache.CacheUnusable, match="not a regular file"):
            store.get(name, 1 << 30)
        assert cache.local_sha256(str(tmp_path / name)) == "missing"
    assert cache.local_sha256("/dev/zero") == "missing"


def test_an_entry_holds_only_uros_files(tmp_path: Path) -> None:
    out = _output(tmp_path / "one")
    (out / "notes.txt").write_text("mine\n")
    with pytest.raises(cache.CacheUnusable, match="not what an entry may hold"):
        cache.pack_entry(out, ["libmicroros.a", "notes.txt"])
    assert cache.may_hold("include/pkg/a.h") and cache.may_hold("microrosConfig.cmake")
    for name in ("notes.txt", "private/cred.txt", "include", "include/../x", "include/" + "a" * 300):
        assert not cache.may_hold(name), name


def _tar(members: list[tuple[str, bytes | None]]) -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for name, data in members:
            info = tarfile.TarInfo(name)
            if data is None:
                info.type = tarfile.DIRTYPE
                tar.addfile(info)
            else:
                info.size = len(data)
                tar.addfile(info, io.BytesIO(data))
    return buffer.getvalue()


def _listed(members: list[tuple[str, bytes | None]]) -> dict[str, tuple[int, str]]:
    return {
        n: (len(d), hashlib.sha256(d).hexdigest()) for n, d in members if d is not None and cache.may_hold(n)
    }


@pytest.mark.parametrize(
    ("members", "says"),
    [
        ([("libmicroros.a", b"!<arch>\n"), ("notes.txt", b"mine")], "its manifest does not list"),
        ([("include", b"a file"), ("include/a.h", b"int a;")], "its manifest does not list"),
        ([("include/a.h", b"int a;"), ("include/a.h", b"int a;")], "its manifest does not list"),
        ([("include/a.h", b"int a;"), ("include/a.h/b.h", b"int b;")], "not a tarball uros can unpack"),
    ],
)
def test_an_entry_with_other_names_or_clashes_is_refused(
    tmp_path: Path, members: list[tuple[str, bytes | None]], says: str
) -> None:
    data = _tar(members)
    with pytest.raises(cache.CacheUnusable, match=says):
        cache.unpack(data, _manifest(data, files=_listed(members)), tmp_path / "out")


def test_a_small_entry_never_unpacks_to_more_than_its_manifest_lists(tmp_path: Path) -> None:
    big = b"\0" * (64 * 1024 * 1024)  # 64 MB of zeros: 64 KB gzipped
    data = _tar([("include/a.h", big)])
    assert len(data) < 200_000
    small = {"include/a.h": (10, hashlib.sha256(b"x").hexdigest())}
    with pytest.raises(cache.CacheUnusable, match="is 67,108,864 bytes, its manifest says 10"):
        cache.unpack(data, _manifest(data, files=small), tmp_path / "out")
    assert not (tmp_path / "out" / "include" / "a.h").exists()
    # a manifest may not list more than a header may be
    listed = cache.Manifest("k" * 64, "5" * 64, 10, "m7", "uros", {}, {"include/a.h": (1 << 30, "3" * 64)})
    with pytest.raises(cache.CacheUnusable, match="within bounds"):
        cache.parse_manifest(listed.to_json().encode(), "k" * 64)


def test_a_token_is_stripped_and_never_printed() -> None:
    env = {"UROS_CACHE_TOKEN": "tok-123-secret\n"}
    assert cache_store.authorization("c.example", env) == "Bearer tok-123-secret"
    with pytest.raises(cache.CacheUnusable) as err:
        cache_store.authorization("c.example", {"UROS_CACHE_TOKEN": "tok 123\x01"})
    assert "tok" not in str(err.value).replace("token", "")
    said = "Invalid header value b'Bearer tok-123-secret\\n' for http://x/"
    assert "secret" not in cache_store.scrub(said, env)


def test_credentials_stay_with_the_caches_origin() -> None:
    assert cache_store.origin("http://C.example/uros/") == cache_store.origin("http://c.example:80/x")
    assert cache_store.origin("http://c.example/") != cache_store.origin("https://c.example/")
    assert cache_store.origin("http://c.example:8080/") != cache_store.origin("http://c.example/")


@pytest.mark.parametrize("text", ["http://127.0.0.1:abc/uros", "http://[::1/uros", "http://h:99999/"])
def test_a_url_that_does_not_parse_is_one_line(text: str) -> None:
    with pytest.raises(ConfigError, match="is not a URL"):
        cache.parse_url(text, "--cache")


def test_the_token_never_reaches_colcon_whose_logs_hold_its_environment() -> None:
    from uros_build.colcon import command

    env, _ = command.build_env({cache.TOKEN_VARIABLE: "t0k", "PATH": "/usr/bin"}, python_bin_dir="/py")
    assert cache.TOKEN_VARIABLE in command.SECRET_VARIABLES and cache.TOKEN_VARIABLE not in env
