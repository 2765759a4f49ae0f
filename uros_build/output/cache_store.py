"""Where team cache entries live and how uros talks to them: a folder (``file://``) or an HTTP
server (GET, HEAD, PUT), each bounded in size and time, and the credentials that go only to the
cache's own origin (a bearer token from ``UROS_CACHE_TOKEN``, else ``~/.netrc``), never printed.
The entries themselves (names, manifest, tarball, checks) are output/team_cache.py's.
"""

from __future__ import annotations

import base64
import os
import time
import urllib.parse
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    pass

from uros_build.files import read_regular, write_atomic
from uros_build.files import reason as _reason
from uros_build.output.team_cache import (
    MAX_MANIFEST_BYTES,
    MIN_RATE,
    TIMEOUT_SECONDS,
    TOKEN_VARIABLE,
    CacheUnusable,
    CacheUrl,
)

# ---------------------------------------------------------------------------------------------
# the stores


class Store(Protocol):
    # None: no such object; CacheUnusable when it cannot be read or is larger than ``limit``
    def get(self, name: str, limit: int) -> bytes | None: ...
    def put(self, name: str, data: bytes) -> None: ...


@dataclass(frozen=True)
class FileStore:
    folder: Path

    def get(self, name: str, limit: int) -> bytes | None:
        path = self.folder / name
        try:  # only a regular file, bounded (a FIFO is refused at once, /dev/zero never read)
            return read_regular(path, limit)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise CacheUnusable(f"{path}: {_reason(exc)}") from None

    def put(self, name: str, data: bytes) -> None:
        # written beside and renamed: a reader never sees half a file, two writers never mix
        path = self.folder / name
        try:
            write_atomic(path, data)
        except OSError as exc:
            raise CacheUnusable(f"{path}: {_reason(exc)}") from None


def origin(url: str) -> tuple[str, str, int | None]:
    """(scheme, host, port) of a URL, the port spelled out: credentials go only where these are the
    cache's own. ValueError for a URL that does not parse."""
    parts = urllib.parse.urlsplit(url)
    default = {"http": 80, "https": 443}.get(parts.scheme.lower())
    return parts.scheme.lower(), (parts.hostname or "").lower(), parts.port or default


@dataclass(frozen=True)
class HttpStore:
    url: CacheUrl
    timeout: float = TIMEOUT_SECONDS  # a socket's silence; a request's deadline is longer (below)

    def _address(self, name: str) -> str:
        base = urllib.parse.urlsplit(self.url.location)
        return urllib.parse.urlunsplit(
            (base.scheme, base.netloc, base.path + urllib.parse.quote(name), base.query, "")
        )

    def _call(self, method: str, name: str, data: bytes | None, limit: int, size: int) -> bytes | None:
        """One request, within its deadline (twice the socket's timeout, plus the time for
        ``size`` bytes at MIN_RATE: a trickling server never holds a build); the answer's body,
        read up to ``limit`` bytes, None for a 404. Credentials are sent only to the cache's own
        scheme, host and port: a redirect elsewhere gets none."""
        import threading

        deadline = 2 * self.timeout + size / MIN_RATE
        host = urllib.parse.urlsplit(self.url.location).hostname or ""
        shown = f"{method} {self.url.shown}{name}"
        outcome: list[bytes | BaseException | None] = []

        def work() -> None:
            try:
                outcome.append(self._exchange(method, name, data, limit, time.monotonic() + deadline))
            except BaseException as exc:  # handed to the caller's thread
                outcome.append(exc)

        worker = threading.Thread(target=work, name="uros-cache-http", daemon=True)
        worker.start()
        worker.join(deadline)
        if worker.is_alive() or not outcome:
            # the thread is left to its socket's timeout; nothing waits for it
            raise CacheUnusable(f"{shown}: no whole answer within {deadline:.0f} s")
        result = outcome[0]
        if isinstance(result, BaseException):
            if isinstance(result, CacheUnusable):
                raise CacheUnusable(f"{shown}: {scrub(str(result), host=host)}")
            raise CacheUnusable(f"{shown}: {scrub(_http_reason(result), host=host)}")
        return result

    def _exchange(self, method: str, name: str, data: bytes | None, limit: int, until: float) -> bytes | None:
        import urllib.error
        import urllib.request

        address = self._address(name)
        own = origin(address)
        auth = authorization(own[1], os.environ)

        class SameOriginOnly(urllib.request.HTTPRedirectHandler):
            """urllib keeps every header of a redirected request (Authorization included): here
            only a redirect to the cache's own scheme, host and port gets the credentials again."""

            def redirect_request(self, req, fp, code, msg, headers, newurl):  # type: ignore[no-untyped-def]
                new = super().redirect_request(req, fp, code, msg, headers, newurl)
                if new is not None:
                    new.remove_header("Authorization")
                    if auth and _same_origin(new.full_url, own):
                        new.add_unredirected_header("Authorization", auth)
                return new

        request = urllib.request.Request(address, data=data, method=method)
        if auth:
            # unredirected: never copied onto a redirect by urllib (SameOriginOnly decides)
            request.add_unredirected_header("Authorization", auth)
        if data is not None:
            request.add_header("Content-Type", "application/octet-stream")
        opener = urllib.request.build_opener(SameOriginOnly)
        try:
            with opener.open(request, timeout=self.timeout) as answer:
                if data is not None:
                    return b""
                length = answer.headers.get("Content-Length")
                if length is not None and length.strip().isdigit() and int(length) > limit:
                    raise CacheUnusable(
                        f"the answer is {int(length):,} bytes, more than the {limit:,} expected"
                    )
                chunks: list[bytes] = []
                got = 0
                while True:
                    if time.monotonic() > until:
                        raise CacheUnusable("the server sends too slowly (past the deadline)")
                    chunk = answer.read(min(1024 * 1024, limit + 1 - got))
                    if not chunk:
                        break
                    chunks.append(chunk)
                    got += len(chunk)
                    if got > limit:
                        raise CacheUnusable(f"the answer is more than the {limit:,} bytes expected")
                missing = getattr(answer, "length", None)  # what its Content-Length still promised
                if isinstance(missing, int) and missing > 0:
                    raise CacheUnusable(
                        f"the connection closed before the end of the answer ({missing:,} bytes missing)"
                    )
                return b"".join(chunks)
        except urllib.error.HTTPError as exc:
            if exc.code == 404 and data is None:
                return None
            raise CacheUnusable(f"HTTP {exc.code} {exc.reason}") from None

    def get(self, name: str, limit: int) -> bytes | None:
        # a manifest (limit MAX_MANIFEST_BYTES) is small: its deadline is the timeout's alone
        return self._call("GET", name, None, limit, 0 if limit == MAX_MANIFEST_BYTES else limit)

    def put(self, name: str, data: bytes) -> None:
        self._call("PUT", name, data, 0, len(data))


def _same_origin(url: str, own: tuple[str, str, int | None]) -> bool:
    try:
        return origin(url) == own
    except ValueError:
        return False


def _http_reason(exc: BaseException) -> str:
    reason = getattr(exc, "reason", None)
    if reason is not None and not isinstance(exc, CacheUnusable):
        return str(reason)
    if type(exc).__name__ == "IncompleteRead":
        return "the connection closed before the end of the answer"
    return _reason(exc)


def store(url: CacheUrl, timeout: float = TIMEOUT_SECONDS) -> Store:
    """The store of ``url``; an HTTP one waits ``timeout`` seconds for a socket."""
    if url.is_file:
        return FileStore(Path(url.location))
    return HttpStore(url, timeout)


def token(environ: Mapping[str, str]) -> str:
    """UROS_CACHE_TOKEN without the whitespace around it (a CI secret often ends in a newline);
    CacheUnusable, without the token, when what is left cannot be sent in a header."""
    text = environ.get(TOKEN_VARIABLE, "").strip()
    if text and not all(33 <= ord(c) <= 126 for c in text):
        raise CacheUnusable(
            f"${TOKEN_VARIABLE} holds a space or a character an HTTP header cannot carry (not shown here)"
        )
    return text


def authorization(host: str, environ: Mapping[str, str]) -> str:
    """The Authorization header for ``host``: the token of UROS_CACHE_TOKEN, else the netrc
    entry's login and password (Basic), else none."""
    found = token(environ)
    if found:
        return f"Bearer {found}"
    entry = _netrc_entry(host, environ)
    if entry is None:
        return ""
    login, password = entry
    return "Basic " + base64.b64encode(f"{login}:{password}".encode()).decode("ascii")


def _netrc_entry(host: str, environ: Mapping[str, str]) -> tuple[str, str] | None:
    import netrc

    path = environ.get("NETRC") or os.path.join(environ.get("HOME", os.path.expanduser("~")), ".netrc")
    try:
        entry = netrc.netrc(path).authenticators(host)
    except (OSError, netrc.NetrcParseError, UnicodeDecodeError):
        return None
    if entry is None:
        return None
    login, _account, password = entry
    return login, password or ""


def secrets(environ: Mapping[str, str], host: str = "") -> list[str]:
    """What must never be printed: the token as set and stripped, the netrc password of ``host``,
    and their header forms."""
    out = [environ.get(TOKEN_VARIABLE, ""), environ.get(TOKEN_VARIABLE, "").strip()]
    entry = _netrc_entry(host, environ) if host else None
    if entry is not None:
        out += [entry[1], base64.b64encode(f"{entry[0]}:{entry[1]}".encode()).decode("ascii")]
    return sorted({s for s in out if len(s) >= 4}, key=len, reverse=True)


def scrub(text: str, environ: Mapping[str, str] | None = None, host: str = "") -> str:
    """``text`` with every credential replaced by ``***`` (a message from a library may quote a
    header, or the URL it was redirected to)."""
    env = environ if environ is not None else os.environ
    for secret in secrets(env, host):
        text = text.replace(secret, "***").replace(repr(secret)[1:-1], "***")
    return text
