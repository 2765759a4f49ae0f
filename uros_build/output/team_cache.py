"""A team cache of build outputs, keyed by the portable build key (issue 19).

The store is a folder (``file:///srv/uros-cache``) or an HTTP server that answers GET, HEAD and PUT
(nginx with WebDAV PUT, bazel-remote, Artifactory, an S3 gateway): nothing uros-specific runs on it.
An entry is two objects under the store: ``<key>.tar.gz``, the output folder as a deterministic
tarball, and ``<key>.json``, its manifest (the tarball's sha256 and size, the target, and the
headers the compiler read from outside the workspace with their sha256). The manifest is written
last, so a reader never sees a half-uploaded entry as complete; a tarball whose sha256 or size is
not the manifest's is never unpacked.

The headers outside the workspace (the C library's, a profile's ``-I`` folders, ESP-IDF's) are not
part of the key: they are known only after a build, from the compiler's own dependency output. The
manifest names them, and an entry is used only when every one of them has the same content here.

Credentials never come from the URL (it sits in uros.yaml and in logs): a bearer token from
``UROS_CACHE_TOKEN``, else the machine's ``~/.netrc`` entry (``NETRC`` names another file).
Every failure to read or write the cache is a warning and the build goes on: a cache is never
the reason a build fails.
"""

from __future__ import annotations

import base64
import gzip
import hashlib
import io
import json
import os
import tarfile
import urllib.parse
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import urllib.request

from uros_build.errors import ConfigError

FORMAT = 1
TOKEN_VARIABLE = "UROS_CACHE_TOKEN"
TIMEOUT_SECONDS = 60.0
_SCHEMES = ("file", "http", "https")


class CacheUnusable(Exception):
    """The cache could not be read or written: a warning, never a failed build."""


@dataclass(frozen=True)
class CacheUrl:
    scheme: str
    location: str  # a folder for file://, the base URL (ending in /) for http(s)://
    shown: str  # what messages and logs print: never credentials or a query string

    @property
    def is_file(self) -> bool:
        return self.scheme == "file"


def parse_url(text: str, where: str) -> CacheUrl:
    """``file:///DIR``, a plain absolute folder, or ``http(s)://host[:port]/path``."""
    hint = "e.g. --cache file:///srv/uros-cache or --cache https://cache.example.com/uros"
    if text.startswith("/"):
        text = Path(text).as_uri()
    parts = urllib.parse.urlsplit(text)
    if parts.scheme not in _SCHEMES:
        raise ConfigError(f"{where}: {text!r} is not a file://, http:// or https:// URL", hint)
    if parts.username is not None or parts.password is not None:
        raise ConfigError(
            f"{where}: the cache URL holds credentials, which would end up in logs and uros.yaml",
            f"remove them from the URL and put a token in ${TOKEN_VARIABLE} or the host in ~/.netrc",
        )
    if parts.scheme == "file":
        if parts.netloc not in ("", "localhost") or not parts.path.startswith("/"):
            raise ConfigError(f"{where}: {text!r}: a file:// URL names an absolute folder", hint)
        folder = urllib.parse.unquote(parts.path)
        return CacheUrl("file", folder, Path(folder).as_uri())
    if not parts.hostname:
        raise ConfigError(f"{where}: {text!r} names no host", hint)
    path = parts.path.rstrip("/") + "/"
    base = urllib.parse.urlunsplit((parts.scheme, parts.netloc, path, parts.query, ""))
    shown = urllib.parse.urlunsplit((parts.scheme, parts.netloc, path, "", ""))
    return CacheUrl(parts.scheme, base, shown)


@dataclass(frozen=True)
class CacheSettings:
    url: CacheUrl
    upload: bool  # write entries after a build (CI); developers read only by default


@dataclass(frozen=True)
class Manifest:
    key: str
    archive_sha256: str
    archive_bytes: int
    target: str
    generated_by: str
    # path -> sha256 of every header the build read from outside the workspace
    outside_headers: Mapping[str, str] = field(default_factory=dict)

    def to_json(self) -> str:
        data = {
            "format": FORMAT,
            "key": self.key,
            "archive_sha256": self.archive_sha256,
            "archive_bytes": self.archive_bytes,
            "target": self.target,
            "generated_by": self.generated_by,
            "outside_headers": dict(self.outside_headers),
        }
        return json.dumps(data, indent=1, sort_keys=True) + "\n"


def parse_manifest(data: bytes, key: str) -> Manifest:
    """The manifest of the entry ``key``; CacheUnusable when it is not one uros wrote for it."""
    try:
        top = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise CacheUnusable(f"the manifest of {key[:16]} is not JSON ({exc})") from None
    if not isinstance(top, dict) or top.get("format") != FORMAT or top.get("key") != key:
        raise CacheUnusable(f"the manifest of {key[:16]} is not a format-{FORMAT} manifest of this key")
    headers = top.get("outside_headers", {})
    sha, size = top.get("archive_sha256"), top.get("archive_bytes")
    if (
        not isinstance(sha, str)
        or not isinstance(size, int)
        or not isinstance(headers, dict)
        or not all(isinstance(k, str) and isinstance(v, str) for k, v in headers.items())
    ):
        raise CacheUnusable(f"the manifest of {key[:16]} is malformed")
    return Manifest(
        key=key,
        archive_sha256=sha,
        archive_bytes=size,
        target=str(top.get("target", "")),
        generated_by=str(top.get("generated_by", "")),
        outside_headers=headers,
    )


def archive_name(key: str) -> str:
    return f"{key}.tar.gz"


def manifest_name(key: str) -> str:
    return f"{key}.json"


# ---------------------------------------------------------------------------------------------
# the entry's bytes (pure)


def pack(folder: Path, names: Iterable[str]) -> bytes:
    """The entries ``names`` of ``folder`` as a gzipped tar whose bytes depend only on the files'
    names, contents and executable bits (sorted, no times, owners or modes beyond that), so that
    two machines that build the same output upload the same bytes."""
    buffer = io.BytesIO()
    with (
        gzip.GzipFile(fileobj=buffer, mode="wb", mtime=0, compresslevel=6) as gz,
        tarfile.open(fileobj=gz, mode="w", format=tarfile.PAX_FORMAT) as tar,
    ):
        for path in sorted(_walk(folder, names)):
            full = folder / path
            info = tarfile.TarInfo(path)
            info.mtime = 0
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            if full.is_dir():
                info.type = tarfile.DIRTYPE
                info.mode = 0o755
                tar.addfile(info)
            else:
                data = full.read_bytes()
                info.size = len(data)
                info.mode = 0o755 if os.access(full, os.X_OK) else 0o644
                tar.addfile(info, io.BytesIO(data))
    return buffer.getvalue()


def _walk(folder: Path, names: Iterable[str]) -> list[str]:
    out: list[str] = []
    for name in names:
        top = folder / name
        if top.is_symlink() or not (top.is_file() or top.is_dir()):
            raise CacheUnusable(f"{top}: not a regular file or folder, so it is not uploaded")
        out.append(name)
        if top.is_dir():
            for path in top.rglob("*"):
                if path.is_symlink() or not (path.is_file() or path.is_dir()):
                    raise CacheUnusable(f"{path}: not a regular file or folder, so it is not uploaded")
                out.append(path.relative_to(folder).as_posix())
    return out


def unpack(data: bytes, manifest: Manifest, dest: Path) -> list[str]:
    """Check ``data`` against the manifest, then unpack it into ``dest`` (which must not exist).
    Only regular files and folders with plain relative names are accepted: a tarball is input
    from a server, and no entry may write outside ``dest``. Returns the top-level names."""
    if len(data) != manifest.archive_bytes:
        raise CacheUnusable(
            f"the entry {manifest.key[:16]} is {len(data):,} bytes, its manifest says "
            f"{manifest.archive_bytes:,} (cut short or replaced)"
        )
    if hashlib.sha256(data).hexdigest() != manifest.archive_sha256:
        raise CacheUnusable(f"the entry {manifest.key[:16]} does not have its manifest's sha256 (corrupt)")
    tops: set[str] = set()
    dest.mkdir(parents=True)
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            for member in tar:
                parts = Path(member.name).parts
                if (
                    not parts
                    or member.name.startswith("/")
                    or any(p in ("..", ".", "") for p in parts)
                    or not (member.isfile() or member.isdir())
                ):
                    raise CacheUnusable(f"the entry {manifest.key[:16]} holds {member.name!r}: refused")
                target = dest.joinpath(*parts)
                tops.add(parts[0])
                if member.isdir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                source = tar.extractfile(member)
                if source is None:
                    raise CacheUnusable(f"the entry {manifest.key[:16]}: {member.name} unreadable")
                target.write_bytes(source.read())
                target.chmod(0o755 if member.mode & 0o111 else 0o644)
                # The files get the time of this download (written just now), not the tar's: a
                # firmware build that linked an older library must see this one as newer.
    except (tarfile.TarError, EOFError, OSError, gzip.BadGzipFile) as exc:
        if isinstance(exc, OSError) and not isinstance(exc, gzip.BadGzipFile) and exc.filename:
            raise
        raise CacheUnusable(f"the entry {manifest.key[:16]} is not a readable tarball ({exc})") from None
    return sorted(tops)


def headers_differ(manifest: Manifest, sha256_of: Mapping[str, str]) -> list[str]:
    """The headers the entry's build read outside the workspace whose content here differs
    (``sha256_of``: their sha256 here, "" for a missing file)."""
    return sorted(p for p, sha in manifest.outside_headers.items() if sha256_of.get(p, "") != sha)


# ---------------------------------------------------------------------------------------------
# the stores


class Store(Protocol):
    def get(self, name: str) -> bytes | None: ...  # None: no such object
    def put(self, name: str, data: bytes) -> None: ...


@dataclass(frozen=True)
class FileStore:
    folder: Path

    def get(self, name: str) -> bytes | None:
        try:
            return (self.folder / name).read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise CacheUnusable(f"{self.folder / name}: {exc.strerror}") from None

    def put(self, name: str, data: bytes) -> None:
        # written beside and renamed: a reader never sees half a file, two writers never mix
        path = self.folder / name
        tmp = path.with_name(f".{name}.tmp-{os.getpid()}")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            tmp.write_bytes(data)
            tmp.replace(path)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise CacheUnusable(f"{path}: {exc.strerror}") from None


@dataclass(frozen=True)
class HttpStore:
    url: CacheUrl
    timeout: float = TIMEOUT_SECONDS

    def _request(self, name: str, method: str, data: bytes | None = None) -> urllib.request.Request:
        import urllib.request  # here, not at the top: it pulls in http, email and ssl (slow to import)

        base = urllib.parse.urlsplit(self.url.location)
        address = urllib.parse.urlunsplit(
            (base.scheme, base.netloc, base.path + urllib.parse.quote(name), base.query, "")
        )
        request = urllib.request.Request(address, data=data, method=method)
        auth = authorization(base.hostname or "", os.environ)
        if auth:
            request.add_header("Authorization", auth)
        if data is not None:
            request.add_header("Content-Type", "application/octet-stream")
        return request

    def get(self, name: str) -> bytes | None:
        import urllib.error
        import urllib.request

        try:
            with urllib.request.urlopen(self._request(name, "GET"), timeout=self.timeout) as answer:
                data: bytes = answer.read()
                return data
        except urllib.error.HTTPError as exc:
            if exc.code == 404:
                return None
            raise CacheUnusable(f"GET {self.url.shown}{name}: HTTP {exc.code} {exc.reason}") from None
        except (urllib.error.URLError, OSError) as exc:
            reason = getattr(exc, "reason", exc)
            raise CacheUnusable(f"GET {self.url.shown}{name}: {reason}") from None

    def put(self, name: str, data: bytes) -> None:
        import urllib.error
        import urllib.request

        try:
            with urllib.request.urlopen(self._request(name, "PUT", data), timeout=self.timeout):
                pass
        except urllib.error.HTTPError as exc:
            raise CacheUnusable(f"PUT {self.url.shown}{name}: HTTP {exc.code} {exc.reason}") from None
        except (urllib.error.URLError, OSError) as exc:
            reason = getattr(exc, "reason", exc)
            raise CacheUnusable(f"PUT {self.url.shown}{name}: {reason}") from None


def store(url: CacheUrl) -> Store:
    return FileStore(Path(url.location)) if url.is_file else HttpStore(url)


def authorization(host: str, environ: Mapping[str, str]) -> str:
    """The Authorization header for ``host``: the token of UROS_CACHE_TOKEN, else the netrc
    entry's login and password (Basic), else none."""
    import netrc

    token = environ.get(TOKEN_VARIABLE, "")
    if token:
        return f"Bearer {token}"
    path = environ.get("NETRC") or os.path.join(environ.get("HOME", os.path.expanduser("~")), ".netrc")
    try:
        entry = netrc.netrc(path).authenticators(host)
    except (OSError, netrc.NetrcParseError):
        return ""
    if entry is None:
        return ""
    login, _account, password = entry
    return "Basic " + base64.b64encode(f"{login}:{password or ''}".encode()).decode("ascii")
