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

import hashlib
import io
import json
import os
import urllib.parse
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from _typeshed import WriteableBuffer

from uros_build import defaults
from uros_build.errors import ConfigError
from uros_build.files import reason as _reason
from uros_build.files import sha256_regular
from uros_build.loader import is_count, is_sha256

FORMAT = 2  # 2: the manifest names every file with its size and sha256 (1: the tarball's only)
TOKEN_VARIABLE = "UROS_CACHE_TOKEN"
# a socket's silence, unless $UROS_CACHE_TIMEOUT says otherwise (config/settings.py); the whole of a
# request has a deadline too (HttpStore)
TIMEOUT_SECONDS = defaults.CACHE_TIMEOUT_SECONDS
MIN_RATE = 256 * 1024  # bytes per second a download may not fall below, on average, for its deadline
_SCHEMES = ("file", "http", "https")

# What an entry may hold: the files and the folder `uros build` writes into an output, nothing
# else (not the user's notes beside them, nor what `uros export` adds in place). An entry is
# input from a server: a name outside these is refused, never written beside a user's files.
ENTRY_FILES = frozenset(
    {
        "build-info.json",
        "libmicroros.a",
        "toolchain.cmake",
        "microrosConfig.cmake",
        "microrosConfigVersion.cmake",
        "microros.cmake",
    }
)
INCLUDE = "include"  # the one folder: headers and the folders that hold them
# Bounds (a server's answer is read and unpacked only up to these): a real micro-ROS output is a
# library of 5-40 MB and ~1,700 headers of at most a few hundred KB.
MAX_MANIFEST_BYTES = 4 * 1024 * 1024  # ~300 KB for micro-ROS's ~1,700 headers
MAX_ARCHIVE_BYTES = 1024 * 1024 * 1024
MAX_LIBRARY_BYTES = 1024 * 1024 * 1024
MAX_HEADER_BYTES = 16 * 1024 * 1024
MAX_OTHER_BYTES = 4 * 1024 * 1024  # build-info.json, toolchain.cmake, the CMake package
MAX_TOTAL_BYTES = 2 * 1024 * 1024 * 1024
MAX_NAME_BYTES = 255  # one part of a path (Linux's NAME_MAX)
MAX_PATH_BYTES = 1024


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
    try:
        parts = urllib.parse.urlsplit(text)
        port = parts.port  # ValueError for a port that is not a number from 0 to 65535
    except ValueError as exc:
        raise ConfigError(f"{where}: {_no_credentials(text)!r} is not a URL ({exc})", hint) from None
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
    if port == 0:
        raise ConfigError(f"{where}: {text!r}: port 0 is no server's", hint)
    path = parts.path.rstrip("/") + "/"
    base = urllib.parse.urlunsplit((parts.scheme, parts.netloc, path, parts.query, ""))
    shown = urllib.parse.urlunsplit((parts.scheme, parts.netloc, path, "", ""))
    return CacheUrl(parts.scheme, base, shown)


def _no_credentials(text: str) -> str:
    """``text`` without what sits before an ``@`` in its authority (a URL that does not parse
    may still hold a password)."""
    scheme, sep, rest = text.partition("://")
    if not sep:
        return text
    authority, slash, path = rest.partition("/")
    return f"{scheme}://{authority.rpartition('@')[2]}{slash}{path}"


@dataclass(frozen=True)
class CacheSettings:
    url: CacheUrl
    upload: bool  # write entries after a build (CI); developers read only by default
    timeout: float = TIMEOUT_SECONDS  # an HTTP store's wait for a socket ($UROS_CACHE_TIMEOUT)


def may_hold(name: str) -> bool:
    """Whether an entry may hold the file ``name`` (/-separated, relative): one of ENTRY_FILES,
    or a header under include/ with plain, not too long parts."""
    if name in ENTRY_FILES:
        return True
    parts = name.split("/")
    return (
        len(parts) >= 2
        and parts[0] == INCLUDE
        and len(name.encode("utf-8", "replace")) <= MAX_PATH_BYTES
        and all(_plain_part(p) for p in parts)
    )


def _plain_part(part: str) -> bool:
    return (
        part not in ("", ".", "..")
        and len(part.encode("utf-8", "replace")) <= MAX_NAME_BYTES
        and not any(c in part for c in "\0\\")
        and part.isprintable()
    )


def _may_hold_folder(name: str) -> bool:
    parts = name.split("/")
    return parts[0] == INCLUDE and len(name) <= MAX_PATH_BYTES and all(_plain_part(p) for p in parts)


def max_bytes(name: str) -> int:
    """The largest file ``name`` an entry may hold."""
    if name == "libmicroros.a":
        return MAX_LIBRARY_BYTES
    return MAX_HEADER_BYTES if name.startswith(f"{INCLUDE}/") else MAX_OTHER_BYTES


@dataclass(frozen=True)
class Manifest:
    key: str
    archive_sha256: str
    archive_bytes: int
    target: str
    generated_by: str
    # path -> sha256 of every header the build read from outside the workspace
    outside_headers: Mapping[str, str] = field(default_factory=dict)
    # every file of the entry: its relative path -> (size, sha256)
    files: Mapping[str, tuple[int, str]] = field(default_factory=dict)

    def to_json(self) -> str:
        data = {
            "format": FORMAT,
            "key": self.key,
            "archive_sha256": self.archive_sha256,
            "archive_bytes": self.archive_bytes,
            "target": self.target,
            "generated_by": self.generated_by,
            "outside_headers": dict(self.outside_headers),
            "files": {p: {"bytes": n, "sha256": s} for p, (n, s) in self.files.items()},
        }
        return json.dumps(data, indent=1, sort_keys=True) + "\n"


def parse_manifest(data: bytes, key: str) -> Manifest:
    """The manifest of the entry ``key``; CacheUnusable when it is not one uros wrote for it."""
    try:
        top = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise CacheUnusable(f"the manifest of {key[:16]} is not JSON ({exc})") from None
    if not isinstance(top, dict) or top.get("format") != FORMAT or top.get("key") != key:
        raise CacheUnusable(f"the manifest of {key[:16]} is not a format-{FORMAT} manifest of this key")
    headers = top.get("outside_headers", {})
    sha, size, listed = top.get("archive_sha256"), top.get("archive_bytes"), top.get("files")
    if (
        not is_sha256(sha)
        or not is_count(size, MAX_ARCHIVE_BYTES)
        or not isinstance(headers, dict)
        or not all(isinstance(k, str) and isinstance(v, str) for k, v in headers.items())
        or not isinstance(listed, dict)
    ):
        raise CacheUnusable(f"the manifest of {key[:16]} is malformed")
    files: dict[str, tuple[int, str]] = {}
    for name, about in listed.items():
        if not may_hold(name):
            raise CacheUnusable(f"the manifest of {key[:16]} names {name!r}, which no entry may hold")
        if (
            not isinstance(about, dict)
            or not is_count(about.get("bytes"), max_bytes(name))
            or not is_sha256(about.get("sha256"))
        ):
            raise CacheUnusable(f"the manifest of {key[:16]}: {name!r} has no size and sha256 within bounds")
        files[name] = (about["bytes"], about["sha256"])
    if sum(n for n, _ in files.values()) > MAX_TOTAL_BYTES:
        raise CacheUnusable(f"the manifest of {key[:16]} lists more than {MAX_TOTAL_BYTES:,} bytes")
    return Manifest(
        key=key,
        archive_sha256=str(sha),
        archive_bytes=int(str(size)),
        target=str(top.get("target", "")),
        generated_by=str(top.get("generated_by", "")),
        outside_headers=headers,
        files=files,
    )


def archive_name(key: str) -> str:
    return f"{key}.tar.gz"


def manifest_name(key: str) -> str:
    return f"{key}.json"


# ---------------------------------------------------------------------------------------------
# the entry's bytes (pure)


def pack(folder: Path, names: Iterable[str]) -> bytes:
    """The entries ``names`` of ``folder`` as a gzipped tar (see :func:`pack_entry`)."""
    return pack_entry(folder, names)[0]


def pack_entry(folder: Path, names: Iterable[str]) -> tuple[bytes, dict[str, tuple[int, str]]]:
    """The entries ``names`` of ``folder`` (each one an entry may hold: ENTRY_FILES, include/) as a
    gzipped tar whose bytes depend only on the files' names, contents and executable bits (sorted,
    no times, owners or modes beyond that), so that two machines that build the same output upload
    the same bytes; and every file's size and sha256, for the manifest."""
    import gzip  # here and in unpack: every build imports this module, few pack or unpack (start-up cost)
    import tarfile

    files: dict[str, tuple[int, str]] = {}
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
                if not may_hold(path) or len(data) > max_bytes(path):
                    raise CacheUnusable(f"{full}: not a file an entry may hold, so nothing is uploaded")
                files[path] = (len(data), hashlib.sha256(data).hexdigest())
                info.size = len(data)
                info.mode = 0o755 if os.access(full, os.X_OK) else 0o644
                tar.addfile(info, io.BytesIO(data))
    return buffer.getvalue(), files


def _walk(folder: Path, names: Iterable[str]) -> list[str]:
    out: list[str] = []
    for name in names:
        top = folder / name
        if top.is_symlink() or not (top.is_file() or top.is_dir()):
            raise CacheUnusable(f"{top}: not a regular file or folder, so it is not uploaded")
        if top.is_dir() != (name == INCLUDE) or not (name == INCLUDE or name in ENTRY_FILES):
            raise CacheUnusable(f"{top}: not what an entry may hold, so nothing is uploaded")
        out.append(name)
        if top.is_dir():
            for path in top.rglob("*"):
                if path.is_symlink() or not (path.is_file() or path.is_dir()):
                    raise CacheUnusable(f"{path}: not a regular file or folder, so it is not uploaded")
                out.append(path.relative_to(folder).as_posix())
    return out


class _Bounded(io.RawIOBase):
    """A stream read only up to ``limit`` bytes (a gzip stream's output: a small entry must not
    unpack to more than its manifest says)."""

    def __init__(self, source: io.BufferedIOBase, limit: int, key: str) -> None:
        self._source, self._left, self._key = source, limit, key

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: WriteableBuffer) -> int:
        view = memoryview(buffer).cast("B")
        data = self._source.read(min(len(view), self._left + 1))
        if len(data) > self._left:
            raise CacheUnusable(f"the entry {self._key[:16]} unpacks to more than its manifest lists")
        self._left -= len(data)
        view[: len(data)] = data
        return len(data)


def check_archive(data: bytes, manifest: Manifest) -> None:
    """The tarball's size and sha256 are the manifest's."""
    if len(data) != manifest.archive_bytes:
        raise CacheUnusable(
            f"the entry {manifest.key[:16]} is {len(data):,} bytes, its manifest says "
            f"{manifest.archive_bytes:,} (cut short or replaced)"
        )
    if hashlib.sha256(data).hexdigest() != manifest.archive_sha256:
        raise CacheUnusable(f"the entry {manifest.key[:16]} does not have its manifest's sha256 (corrupt)")


def unpack(data: bytes, manifest: Manifest, dest: Path | None) -> list[str]:
    """Check ``data`` against the manifest, then unpack it into ``dest`` (which must not exist;
    None: check only). Every file is checked against the manifest (listed, its size before it is
    read, its sha256 before it is written) and every file the manifest lists must be there; only
    regular files and folders an entry may hold (:func:`may_hold`) are accepted: a tarball is
    input from a server, and no entry may write outside ``dest`` or beside a user's files. Any
    trouble is CacheUnusable. Returns the top-level names."""
    import gzip  # here and in pack_entry: start-up cost
    import tarfile

    check_archive(data, manifest)
    key = manifest.key[:16]
    tops: set[str] = set()
    seen: set[str] = set()
    # what the tar stream may hold beyond the files' bytes: a header and padding per member, the
    # PAX records (a path of up to MAX_PATH_BYTES), the end blocks
    slack = 4096 * (len(manifest.files) + 256) + 64 * 1024
    limit = sum(n for n, _ in manifest.files.values()) + slack
    try:
        if dest is not None:
            dest.mkdir(parents=True)
        with (
            gzip.GzipFile(fileobj=io.BytesIO(data), mode="rb") as gz,
            io.BufferedReader(_Bounded(gz, limit, manifest.key)) as stream,
            tarfile.open(fileobj=stream, mode="r|") as tar,
        ):
            for member in tar:
                name = member.name
                if member.isdir() and _may_hold_folder(name):
                    tops.add(INCLUDE)
                    if dest is not None:
                        dest.joinpath(*name.split("/")).mkdir(parents=True, exist_ok=True)
                    continue
                listed = manifest.files.get(name)
                if not member.isfile() or listed is None or name in seen:
                    raise CacheUnusable(
                        f"the entry {key} holds {name!r}, which its manifest does not list: refused"
                    )
                seen.add(name)
                size, sha = listed
                if member.size != size:
                    raise CacheUnusable(
                        f"the entry {key}: {name} is {member.size:,} bytes, its manifest says {size:,}"
                    )
                source = tar.extractfile(member)
                content = source.read(size + 1) if source is not None else b""
                if len(content) != size or hashlib.sha256(content).hexdigest() != sha:
                    raise CacheUnusable(f"the entry {key}: {name} does not have its manifest's sha256")
                tops.add(name.split("/")[0])
                if dest is None:
                    continue
                target = dest.joinpath(*name.split("/"))
                target.parent.mkdir(parents=True, exist_ok=True)
                with open(target, "xb") as f:
                    f.write(content)
                target.chmod(0o755 if member.mode & 0o111 else 0o644)
                # The files get the time of this download (written just now), not the tar's: a
                # firmware build that linked an older library must see this one as newer.
    except CacheUnusable:
        raise
    except Exception as exc:  # a tarball from a server: whatever it makes fail is not this build's failure
        raise CacheUnusable(f"the entry {key} is not a tarball uros can unpack ({_reason(exc)})") from None
    missing = sorted(set(manifest.files) - seen)
    if missing:
        raise CacheUnusable(f"the entry {key} lacks {missing[0]}, which its manifest lists")
    return sorted(tops)


def headers_differ(manifest: Manifest, sha256_of: Mapping[str, str]) -> list[str]:
    """The headers the entry's build read outside the workspace whose content here differs
    (``sha256_of``: their sha256 here, "" for a missing file)."""
    return sorted(p for p, sha in manifest.outside_headers.items() if sha256_of.get(p, "") != sha)


def workspace_headers(sources: Mapping[str, str]) -> dict[str, frozenset[str]]:
    """A header's path below an ``include/`` folder of the workspace's sources -> the sha256s of
    the files at that path (``sources``: path in the sources -> sha256, as the build scanned them):
    what a package installs from its ``include/`` lands at that path in the output's include tree
    (output/includes.py flattens ``include/<pkg>/<pkg>/`` to ``include/<pkg>/``, which is the same
    path below the source's ``include/``)."""
    found: dict[str, set[str]] = {}
    for rel, sha in sources.items():
        parts = rel.split("/")
        for i, part in enumerate(parts[:-1]):
            if part == INCLUDE:
                found.setdefault("/".join(parts[i + 1 :]), set()).add(sha)
    return {path: frozenset(shas) for path, shas in found.items()}


def headers_not_the_workspaces(manifest: Manifest, workspace: Mapping[str, frozenset[str]]) -> list[str]:
    """The entry's headers whose path the workspace's sources hold below an ``include/`` folder
    but with none of their contents (``workspace``: :func:`workspace_headers`): an entry whose
    include tree disagrees with the sources its build key names (its library does not match
    them), as toolchain.cmake is compared with what this uros writes. Headers generated by the
    build (rosidl's, configured ones) have no copy in the sources and are not compared."""
    prefix = INCLUDE + "/"
    return sorted(
        name
        for name, (_, sha) in manifest.files.items()
        if name.startswith(prefix)
        and name[len(prefix) :] in workspace
        and sha not in workspace[name[len(prefix) :]]
    )


def local_sha256(path: str, limit: int = MAX_HEADER_BYTES) -> str:
    """The sha256 of a header named by a manifest, or "missing": only a regular file of at most
    ``limit`` bytes (a manifest is input from a server: /dev/zero never ends, a FIFO never answers)."""
    try:
        return sha256_regular(path, limit)
    except (OSError, ValueError):
        return "missing"
