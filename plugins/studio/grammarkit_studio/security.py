"""The studio's gatekeeper: an ASGI middleware every HTTP request and websocket passes.

The studio reads and writes a user's files and runs their grammars, so only the person who
started it may drive it, and no web page they visit may either:

- **Token in the path.** Every URL is `/s/<token>/...` with a random per-session token (32
  bytes, `secrets`). The page's own relative URLs (scripts, three.js's module imports, the
  websocket) inherit the prefix, so nothing needs a cookie. A wrong or missing token is 403.
- **Host.** Must be `127.0.0.1:<port>` or `localhost:<port>`: a DNS-rebinding page (a site
  whose name resolves to 127.0.0.1) sends its own host name and is refused.
- **Origin.** A request carrying an `Origin` (browsers send one with websockets and
  cross-origin fetches) must come from the studio's own origin; `Sec-Fetch-Site: cross-site`
  is refused too.
- **Methods and sizes.** Only GET/HEAD over HTTP, with at most `MAX_HTTP_BODY` bytes of body;
  websocket messages are capped by the server (`ws_max_size`).

The token is compared in constant time (`secrets.compare_digest`).
"""
from __future__ import annotations

import secrets
from typing import Any, Awaitable, Callable

MAX_HTTP_BODY = 64 * 1024
PREFIX = "/s/"

Scope = dict
Receive = Callable[[], Awaitable[dict]]
Send = Callable[[dict], Awaitable[None]]


def new_token() -> str:
    return secrets.token_urlsafe(32)


class Gate:
    """Wraps the app; passes on only requests that carry the token and come from the studio."""

    def __init__(self, app: Any, token: str, port: int):
        self.app = app
        self.token = token
        self.port = port
        self.hosts = {f"127.0.0.1:{port}", f"localhost:{port}"}
        self.origins = {f"http://127.0.0.1:{port}", f"http://localhost:{port}"}
        self.refused = 0  # counted for the tests and the log

    def _why_refused(self, scope: Scope) -> str | None:
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        if headers.get("host") not in self.hosts:
            return "wrong host"
        origin = headers.get("origin")
        if origin is not None and origin not in self.origins:
            return "cross-origin"
        if headers.get("sec-fetch-site") == "cross-site":
            return "cross-site"
        if scope["type"] == "http" and scope.get("method") not in ("GET", "HEAD"):
            return "method"
        path: str = scope.get("path", "")
        if not path.startswith(PREFIX):
            return "no token"
        token, _, _ = path[len(PREFIX):].partition("/")
        if not secrets.compare_digest(token.encode(), self.token.encode()):
            return "wrong token"
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)  # lifespan
            return
        why = self._why_refused(scope)
        if why is not None:
            self.refused += 1
            await _refuse(scope, receive, send, why)
            return
        prefix = f"{PREFIX}{self.token}"
        rest = scope["path"][len(prefix):]
        if scope["type"] == "http" and rest == "":
            await _redirect(send, f"{prefix}/")  # /s/TOKEN -> /s/TOKEN/ so relative URLs work
            return
        # Starlette routes on the path below root_path: the app sees /, /ws, /static/...
        inner = dict(scope, root_path=scope.get("root_path", "") + prefix)
        if scope["type"] == "http":
            declared = dict(scope.get("headers", [])).get(b"content-length")
            if declared is not None and (not declared.isdigit() or int(declared) > MAX_HTTP_BODY):
                await _plain(send, 413, "request body too large")
                return
            receive = _bounded(receive)
        await self.app(inner, receive, send)


def _bounded(receive: Receive) -> Receive:
    """A receive that fails once more than MAX_HTTP_BODY bytes of body arrived (chunked bodies
    declare no length)."""
    seen = 0

    async def wrapped() -> dict:
        nonlocal seen
        message = await receive()
        if message.get("type") == "http.request":
            seen += len(message.get("body", b""))
            if seen > MAX_HTTP_BODY:
                raise ValueError("request body too large")
        return message

    return wrapped


async def _plain(send: Send, status: int, text: str) -> None:
    body = text.encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"text/plain; charset=utf-8"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


async def _redirect(send: Send, location: str) -> None:
    await send({"type": "http.response.start", "status": 307,
                "headers": [(b"location", location.encode()), (b"content-length", b"0")]})
    await send({"type": "http.response.body", "body": b""})


async def _refuse(scope: Scope, receive: Receive, send: Send, why: str) -> None:
    if scope["type"] == "websocket":
        message = await receive()  # websocket.connect
        if message.get("type") == "websocket.connect":
            await send({"type": "websocket.close", "code": 1008, "reason": "forbidden"})
        return
    # The reason is told (it helps a user who mistyped the URL) but never the token.
    await _plain(send, 403, f"forbidden ({why}): open the URL that `grammarkit studio` printed")


def security_headers(port: int) -> dict[str, str]:
    """Headers of every page and asset: no framing, no referrer (the URL holds the token), and
    a content security policy that allows only the studio's own scripts and connections."""
    return {
        "Content-Security-Policy": (
            "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' blob: data:; "
            f"connect-src 'self' ws://127.0.0.1:{port} ws://localhost:{port} blob: data:; "
            "frame-ancestors 'none'; base-uri 'none'; form-action 'none'"),
        "X-Frame-Options": "DENY",
        "Referrer-Policy": "no-referrer",
        "X-Content-Type-Options": "nosniff",
        "Cache-Control": "no-store",
        "Cross-Origin-Resource-Policy": "same-origin",
    }
