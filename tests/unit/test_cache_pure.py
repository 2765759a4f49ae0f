"""The team cache's pure parts: URLs, the entry's bytes, manifests, credentials (issue 19)."""

from __future__ import annotations

import hashlib
import io
import tarfile
from pathlib import Path

import pytest

from uros_build.errors import ConfigError
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


def _manifest(data: bytes, key: str = "k" * 64) -> cache.Manifest:
    return cache.Manifest(key, hashlib.sha256(data).hexdigest(), len(data), "cortex-m7", "uros 0")


def test_the_entry_depends_on_content_only(tmp_path: Path) -> None:
    one = _output(tmp_path / "one")
    two = _output(tmp_path / "two")
    (two / "libmicroros.a").touch()  # another mtime
    names = ["build-info.json", "include", "libmicroros.a"]
    assert cache.pack(one, names) == cache.pack(two, list(reversed(names)))
    (two / "include" / "pkg" / "a.h").write_text("int b;\n")
    assert cache.pack(one, names) != cache.pack(two, names)


def test_unpack_round_trip_and_fresh_times(tmp_path: Path) -> None:
    data = cache.pack(_output(tmp_path / "one"), ["include", "libmicroros.a", "build-info.json"])
    tops = cache.unpack(data, _manifest(data), tmp_path / "out")
    assert tops == ["build-info.json", "include", "libmicroros.a"]
    assert (tmp_path / "out" / "include" / "pkg" / "a.h").read_text() == "int a;\n"
    # the download's time, not the tar's 1970: a firmware linked against an older library relinks
    assert (tmp_path / "out" / "libmicroros.a").stat().st_mtime > 1e9


def test_cut_or_corrupt_entries_are_refused(tmp_path: Path) -> None:
    data = cache.pack(_output(tmp_path / "one"), ["libmicroros.a"])
    manifest = _manifest(data)
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
    manifest = cache.Manifest("k" * 64, "s" * 64, 10, "cortex-m7", "uros 1", {"/usr/include/a.h": "1" * 64})
    back = cache.parse_manifest(manifest.to_json().encode(), "k" * 64)
    assert back == manifest
    with pytest.raises(cache.CacheUnusable, match="not a format-1 manifest of this key"):
        cache.parse_manifest(manifest.to_json().encode(), "j" * 64)
    with pytest.raises(cache.CacheUnusable, match="not JSON"):
        cache.parse_manifest(b'{"format": 1, "key"', "k" * 64)
    assert cache.headers_differ(back, {"/usr/include/a.h": "1" * 64}) == []
    assert cache.headers_differ(back, {"/usr/include/a.h": "missing"}) == ["/usr/include/a.h"]


def test_credentials_from_the_environment_or_netrc(tmp_path: Path) -> None:
    assert (
        cache.authorization("c.example", {"UROS_CACHE_TOKEN": "t0k", "HOME": str(tmp_path)}) == "Bearer t0k"
    )
    assert cache.authorization("c.example", {"HOME": str(tmp_path)}) == ""
    netrc = tmp_path / "netrc"
    netrc.write_text("machine c.example login ci password s3cret\n")
    netrc.chmod(0o600)
    assert cache.authorization("c.example", {"NETRC": str(netrc)}) == "Basic Y2k6czNjcmV0"
    assert cache.authorization("other.example", {"NETRC": str(netrc)}) == ""


def test_file_store(tmp_path: Path) -> None:
    store = cache.FileStore(tmp_path / "c")
    assert store.get("x.json") is None
    store.put("x.json", b"{}")
    assert store.get("x.json") == b"{}" and [p.name for p in (tmp_path / "c").iterdir()] == ["x.json"]
