"""The studio's web server: the page, its websocket, exports, saving and the file watcher.

One `Studio` serves one grammar file. The page talks over one websocket (JSON messages, and
binary frames for models: a 4-byte big-endian header length, the JSON header, then the
payloads the header lists). The work (check, derive, export...) runs in worker processes
(worker.py); this process only routes messages, so the page stays responsive whatever the
grammar does. Edits are coalesced per connection: while one derive runs, newer edits replace
the pending one, so dragging a slider never queues stale work.
"""
from __future__ import annotations

import asyncio
import contextlib
import hashlib
import json
import logging
import math
import struct
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.responses import FileResponse, PlainTextResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

from grammarkit.errors import GrammarkitError

from .security import Gate, new_token, security_headers
from .work import EXPORT_FORMATS
from .worker import BudgetExceeded, CallFailed, Worker, WorkerFailed

STATIC = Path(__file__).with_name("static")
MAX_TEXT = 1024 * 1024  # characters of grammar text the page may send
MAX_MESSAGE = 4 * 1024 * 1024  # bytes of one websocket message (sketch images included)
MAX_GALLERY = 64
MAX_DEPTH = 32  # nesting of a websocket message's JSON (the page sends at most 4 levels)
log = logging.getLogger("grammarkit.studio")


def frame(header: dict, *payloads: bytes) -> bytes:
    """A binary websocket message: header length, JSON header (with payload sizes), payloads."""
    header = dict(header, sizes=[len(p) for p in payloads])
    head = json.dumps(header, separators=(",", ":")).encode()
    return b"".join([struct.pack(">I", len(head)), head, *payloads])


def text_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


@dataclass
class DiskState:
    """What the studio last saw of the grammar file (to notice external edits)."""

    text: str
    hash: str
    mtime_ns: int


@dataclass(eq=False)  # kept in a set, by identity
class Connection:
    ws: WebSocket
    pending: dict | None = None  # the newest edit not yet derived
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    gallery: asyncio.Task | None = None
    send_lock: asyncio.Lock = field(default_factory=asyncio.Lock)

    async def send_json(self, data: dict) -> None:
        async with self.send_lock:
            await self.ws.send_text(json.dumps(data, separators=(",", ":"), allow_nan=False))

    async def send_bytes(self, data: bytes) -> None:
        async with self.send_lock:
            await self.ws.send_bytes(data)


class Studio:
    """The studio of one grammar file: `app` is the ASGI app (wrapped in the security gate)."""

    def __init__(self, path: str | Path, *, port: int, token: str | None = None, budget: float = 30.0,
                 gallery_budget: float = 300.0, poll: float = 0.5):
        path = Path(path).expanduser().resolve()
        if path.suffix != ".grammar":
            raise GrammarkitError(f"{path}: the studio edits .grammar files")
        if not path.is_file():
            raise GrammarkitError(f"{path}: no such file")
        self.path = path
        self.root = path.parent
        self.port = port
        self.token = token or new_token()
        self.budget = float(budget)
        self.gallery_budget = float(gallery_budget)
        self.poll = poll
        try:
            self.disk = self._read_disk()
        except UnicodeDecodeError as exc:
            raise GrammarkitError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
        except OSError as exc:
            raise GrammarkitError(f"{path}: cannot read: {exc.strerror or exc}") from None
        self._disk_lock = threading.Lock()  # a save and the watcher's read never interleave
        self.derive_worker = Worker(str(path), str(self.root), "derive")
        self.gallery_worker = Worker(str(path), str(self.root), "gallery")
        self.connections: set[Connection] = set()
        self._watch_task: asyncio.Task | None = None
        routes = [
            Route("/", self.index),
            Route("/export/{fmt}", self.export),
            WebSocketRoute("/ws", self.websocket),
            Mount("/static", app=StaticFiles(directory=STATIC), name="static"),
        ]
        inner = Starlette(routes=routes, lifespan=self._lifespan)
        inner.add_middleware(_Headers, headers=security_headers(port))
        self.gate = Gate(inner, self.token, port)
        self.app = self.gate

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/s/{self.token}/"

    # -- lifetime ------------------------------------------------------------------------------------
    @contextlib.asynccontextmanager
    async def _lifespan(self, app: Any) -> Any:
        await self._startup()
        try:
            yield
        finally:
            await self._shutdown()

    async def _startup(self) -> None:
        loop = asyncio.get_running_loop()
        text = self.disk.text
        # start both workers and warm the derive worker with the file (the first view is quick)
        loop.run_in_executor(None, self._warm, text)
        self._watch_task = asyncio.create_task(self._watch())

    def _warm(self, text: str) -> None:
        with contextlib.suppress(GrammarkitError):
            self.derive_worker.call("warm", max(self.budget, 60.0), text=text)
        with contextlib.suppress(GrammarkitError):
            self.gallery_worker.call("check", max(self.budget, 60.0), text=text)

    async def _shutdown(self) -> None:
        if self._watch_task is not None:
            self._watch_task.cancel()
        self.close()

    def close(self) -> None:
        self.derive_worker.close()
        self.gallery_worker.close()

    # -- the file on disk ---------------------------------------------------------------------------
    def _read_disk(self) -> DiskState:
        st = self.path.stat()
        text = self.path.read_text(encoding="utf-8")
        return DiskState(text, text_hash(text), st.st_mtime_ns)

    async def _watch(self) -> None:
        """Poll the file; an external edit is sent to every page (which reloads it if the user
        has no unsaved edits, or asks)."""
        while True:
            await asyncio.sleep(self.poll)
            try:
                st = self.path.stat()
            except OSError:
                continue  # being replaced right now (atomic save by an editor)
            if st.st_mtime_ns == self.disk.mtime_ns:
                continue
            with self._disk_lock:
                try:
                    disk = self._read_disk()
                except (OSError, UnicodeDecodeError):
                    continue
                changed = disk.hash != self.disk.hash
                self.disk = disk
            if changed:
                for conn in list(self.connections):
                    with contextlib.suppress(Exception):
                        await conn.send_json({"type": "disk-changed", "text": disk.text, "hash": disk.hash})

    def save(self, text: str, base_hash: str | None, force: bool) -> dict:
        """Write the text to the grammar file atomically, unless the file changed on disk since
        the page loaded it (`base_hash`) and the user has not confirmed (`force`)."""
        from grammarkit.run import write_files

        with self._disk_lock:
            try:
                current = self._read_disk()
            except FileNotFoundError:
                current = None
            if current is not None and not force and base_hash is not None and current.hash != base_hash:
                return {"type": "save-conflict", "text": current.text, "hash": current.hash}
            write_files({self.path: text})
            self.disk = self._read_disk()
            return {"type": "saved", "hash": self.disk.hash, "path": str(self.path)}

    # -- HTTP ------------------------------------------------------------------------------------------
    async def index(self, request: Any) -> Response:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    async def export(self, request: Any) -> Response:
        fmt = request.path_params["fmt"].lower()
        if fmt not in EXPORT_FORMATS:
            return PlainTextResponse(f"unknown format {fmt!r} (the studio exports "
                                     f"{', '.join(EXPORT_FORMATS)})", status_code=404)
        gallery = request.query_params.get("gallery")
        index = None if gallery is None else _gallery_index(gallery)
        if gallery is not None and index is None:
            return PlainTextResponse(f"gallery= must be a variant's index, 0..{MAX_GALLERY - 1}",
                                     status_code=400)
        # a tiling gallery's variant lives in the gallery worker; everything else in the view's
        worker = self.derive_worker if gallery is None else self.gallery_worker
        try:
            out = await asyncio.to_thread(worker.call, "export", self.budget, fmt=fmt, gallery=index)
        except CallFailed as exc:
            return PlainTextResponse(exc.info.get("message", "export failed"), status_code=409)
        except (BudgetExceeded, WorkerFailed) as exc:
            return PlainTextResponse(str(exc), status_code=503)
        media = {"glb": "model/gltf-binary", "obj": "model/obj", "stl": "model/stl"}[fmt]
        filename = "".join(c for c in out["filename"] if c.isalnum() or c in "._-") or f"model.{fmt}"
        return Response(out["data"], media_type=media,
                        headers={"Content-Disposition": f'attachment; filename="{filename}"'})

    # -- the websocket ----------------------------------------------------------------------------------
    async def websocket(self, ws: WebSocket) -> None:
        await ws.accept()
        conn = Connection(ws)
        self.connections.add(conn)
        worker_task = asyncio.create_task(self._edits(conn))
        try:
            await conn.send_json({"type": "file", "text": self.disk.text, "hash": self.disk.hash,
                                  "path": str(self.path), "name": self.path.name,
                                  "formats": list(EXPORT_FORMATS), "budget": self.budget})
            while True:
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    break
                raw = message.get("text")
                if raw is None:
                    await conn.send_json({"type": "error", "message": "the studio takes JSON messages"})
                    continue
                if len(raw) > MAX_MESSAGE:
                    await conn.send_json({"type": "error", "message": "message too large"})
                    continue
                msg, problem = _parse_message(raw)
                if problem is not None:
                    await conn.send_json({"type": "error", "message": problem})
                    continue
                try:
                    await self._dispatch(conn, msg)
                except (WebSocketDisconnect, asyncio.CancelledError):
                    raise
                except Exception as exc:  # noqa: BLE001 - a bug must not drop the connection
                    log.exception("studio: message %r failed", msg.get("op"))
                    await conn.send_json({"type": "error", "op": _echo(msg.get("op")),
                                          "message": f"internal error: {type(exc).__name__}: {exc}"})
        except WebSocketDisconnect:
            pass
        finally:
            self.connections.discard(conn)
            worker_task.cancel()
            if conn.gallery is not None and not conn.gallery.done():
                conn.gallery.cancel()
                self.gallery_worker.interrupt()

    async def _dispatch(self, conn: Connection, msg: dict) -> None:
        op = msg.get("op")
        try:
            if op == "edit":
                conn.pending = _edit_args(msg)
                conn.wake.set()
            elif op == "tree":
                out = await self._call("tree")
                await conn.send_json({"type": "tree", "rev": _echo(msg.get("rev")), **out})
            elif op == "pick":
                point = msg.get("point")
                if not (isinstance(point, list) and len(point) == 3 and all(isinstance(v, (int, float)) for v in point)):
                    raise ValueError("pick: point must be three numbers")
                terminal = msg.get("terminal")
                out = await self._call("pick", point=[float(v) for v in point],
                                       terminal=terminal if isinstance(terminal, str) else None)
                await conn.send_json({"type": "pick", "rev": _echo(msg.get("rev")), **out})
            elif op == "node":  # a tree row, or the shapes of a source line: their parts
                ids = msg.get("ids")
                if not (isinstance(ids, list) and 0 < len(ids) <= 10_000):
                    raise ValueError("node: ids must be a list of shape ids")
                out = await self._call("node_box", nodes=[_int(i, "shape id") for i in ids])
                await conn.send_json({"type": "node", "ids": ids, **out})
            elif op == "save":
                text = _text(msg.get("text"))
                out = await asyncio.to_thread(self.save, text, msg.get("base") if isinstance(msg.get("base"), str) else None,
                                              bool(msg.get("force")))
                await conn.send_json(out)
                if out["type"] == "saved":  # the other pages learn of the new file now
                    for other in list(self.connections - {conn}):
                        with contextlib.suppress(Exception):
                            await other.send_json({"type": "disk-changed", "text": self.disk.text,
                                                   "hash": self.disk.hash})
            elif op == "format":
                out = await self._call("format", text=_text(msg.get("text")))
                await conn.send_json({"type": "formatted", **out})
            elif op == "gallery":
                await self._start_gallery(conn, msg)
            elif op == "gallery-stop":
                if conn.gallery is not None and not conn.gallery.done():
                    conn.gallery.cancel()
                    self.gallery_worker.interrupt()
            elif op == "backends":
                out = await self._call("backends", text=_text(msg.get("text")))
                await conn.send_json({"type": "backends", **out})
            elif op == "sketch":
                out = await self._call("sketch", strokes=msg.get("strokes"), width=msg.get("width"),
                                       height=msg.get("height"), object_type=str(msg.get("object_type")),
                                       text=_text(msg.get("text")))
                await conn.send_json({"type": "sketch", **out})
            elif op == "sketch-canvas":
                out = await self._call("sketch_canvas", object_type=str(msg.get("object_type")),
                                       text=_text(msg.get("text")))
                await conn.send_json({"type": "sketch-canvas", **out})
            else:
                await conn.send_json({"type": "error", "message": f"unknown op {repr(op)[:100]}"})
        except CallFailed as exc:
            await conn.send_json({"type": "error", "op": _echo(op), **exc.info})
        except (BudgetExceeded, WorkerFailed, ValueError, GrammarkitError) as exc:
            await conn.send_json({"type": "error", "op": _echo(op), "message": str(exc)})

    async def _call(self, op: str, **kwargs: Any) -> Any:
        return await asyncio.to_thread(self.derive_worker.call, op, self.budget, **kwargs)

    async def _edits(self, conn: Connection) -> None:
        """Derive the newest edit, one at a time; intermediate edits are dropped."""
        while True:
            await conn.wake.wait()
            conn.wake.clear()
            edit, conn.pending = conn.pending, None
            if edit is None:
                continue
            try:
                await self._edit(conn, edit)
            except (WebSocketDisconnect, asyncio.CancelledError):
                raise
            except Exception as exc:  # noqa: BLE001 - a bug must not end the page's updates
                log.exception("studio: edit %s failed", edit["rev"])
                with contextlib.suppress(Exception):
                    await conn.send_json({"type": "derive-error", "rev": edit["rev"], "diagnostics": [],
                                          "message": f"internal error: {type(exc).__name__}: {exc}"})

    async def _edit(self, conn: Connection, edit: dict) -> None:
        t0 = time.perf_counter()
        try:
            out = await self._call("derive", text=edit["text"], attrs=edit["attrs"],
                                   seed=edit["seed"], example=edit["example"],
                                   variation=edit["variation"])
        except CallFailed as exc:
            # a derive error: the page keeps the last good model and shows this
            await conn.send_json({"type": "derive-error", "rev": edit["rev"], **exc.info})
            return
        except (BudgetExceeded, WorkerFailed) as exc:
            await conn.send_json({"type": "derive-error", "rev": edit["rev"], "message": str(exc),
                                  "diagnostics": []})
            return
        check = out.get("check")
        await conn.send_json({"type": "check", "rev": edit["rev"], **(check or {})})
        if out.get("ok"):
            facts = dict(out["facts"], server_ms=round(1000 * (time.perf_counter() - t0), 1))
            await conn.send_bytes(frame({"type": "model", "rev": edit["rev"], "facts": facts}, out["glb"]))
        elif out.get("error"):
            await conn.send_json({"type": "derive-error", "rev": edit["rev"], **out["error"]})

    async def _start_gallery(self, conn: Connection, msg: dict) -> None:
        if conn.gallery is not None and not conn.gallery.done():
            conn.gallery.cancel()
            self.gallery_worker.interrupt()
            with contextlib.suppress(BaseException):
                await conn.gallery
        n = _int(msg.get("n", 8), "n")
        if not 1 <= n <= MAX_GALLERY:
            raise ValueError(f"gallery: n must be 1..{MAX_GALLERY}")
        kwargs = {"text": _text(msg.get("text")), "n": n, "seed": _int(msg.get("seed", 0), "seed"),
                  "backend": msg.get("backend") if isinstance(msg.get("backend"), str) and msg.get("backend") else None,
                  "iterations": _int(msg.get("iterations", 2), "iterations"),
                  "attrs": _attrs(msg.get("attrs")), "timeout": self.gallery_budget}
        conn.gallery = asyncio.create_task(self._gallery(conn, _echo(msg.get("id")), kwargs))

    async def _gallery(self, conn: Connection, gid: Any, kwargs: dict) -> None:
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue = asyncio.Queue()

        def on_item(item: dict) -> None:
            loop.call_soon_threadsafe(queue.put_nowait, ("item", item))

        def run() -> None:
            try:
                self.gallery_worker.stream("gallery", self.gallery_budget + 5.0, on_item, **kwargs)
                loop.call_soon_threadsafe(queue.put_nowait, ("end", None))
            except CallFailed as exc:
                loop.call_soon_threadsafe(queue.put_nowait, ("error", exc.info))
            except (BudgetExceeded, WorkerFailed, GrammarkitError) as exc:
                loop.call_soon_threadsafe(queue.put_nowait, ("error", {"message": str(exc)}))

        fut = loop.run_in_executor(None, run)
        try:
            while True:
                kind, item = await queue.get()
                if kind == "item":
                    if item.get("done"):
                        await conn.send_json({"type": "gallery-done", **item, "gallery": gid})
                        continue
                    glb, png = item.pop("glb"), item.pop("png")
                    await conn.send_bytes(frame({"type": "gallery-item", **item, "gallery": gid}, glb, png))
                elif kind == "error":
                    await conn.send_json({"type": "gallery-error", **item, "gallery": gid})
                    break
                else:
                    break
        except asyncio.CancelledError:
            with contextlib.suppress(Exception):
                await conn.send_json({"type": "gallery-done", "gallery": gid, "stopped": True})
            raise
        finally:
            with contextlib.suppress(BaseException):
                await fut


class _Headers:
    """Adds the security headers to every HTTP response."""

    def __init__(self, app: Any, headers: dict[str, str]):
        self.app = app
        self.headers = [(k.lower().encode(), v.encode()) for k, v in headers.items()]

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: dict) -> None:
            if message["type"] == "http.response.start":
                names = {k for k, _ in message.get("headers", [])}
                message = dict(message, headers=[*message.get("headers", []),
                                                 *[(k, v) for k, v in self.headers if k not in names]])
            await send(message)

        await self.app(scope, receive, send_with_headers)


def _gallery_index(value: str) -> int | None:
    """A gallery variant's index from a query string (ASCII digits, below MAX_GALLERY), else
    None: `int()` of 5,000 digits raises, and str.isdigit() accepts digits int() refuses."""
    if not (0 < len(value) <= len(str(MAX_GALLERY)) and value.isascii() and value.isdigit()):
        return None
    index = int(value)
    return index if index < MAX_GALLERY else None


def _depth_exceeds(value: Any, limit: int) -> bool:
    """Whether a parsed JSON value nests deeper than `limit` (iterative: no recursion)."""
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            if depth > limit:
                return True
            stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
    return False


def _parse_message(raw: str) -> tuple[dict, str | None]:
    """A websocket message as a dict, or the reason it is refused (the connection stays)."""
    try:
        msg = json.loads(raw)
    except RecursionError:
        return {}, f"malformed message: nested deeper than {MAX_DEPTH} levels"
    except ValueError:  # bad JSON, or a number of more digits than int() converts
        return {}, "malformed message"
    if not isinstance(msg, dict):
        return {}, "malformed message"
    if _depth_exceeds(msg, MAX_DEPTH):
        return {}, f"malformed message: nested deeper than {MAX_DEPTH} levels"
    return msg, None


def _echo(value: Any) -> Any:
    """A value of the page's message sent back in a reply (rev, id, op): scalars only."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value if value is None or isinstance(value, (str, bool)) or (
        isinstance(value, int) and abs(value) <= 2**63) else None


def _int(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or abs(value) > 2**63:
        raise ValueError(f"{what} must be an integer, got {value!r}")
    return value


def _text(value: Any) -> str:
    if not isinstance(value, str):
        raise ValueError("text must be a string")
    if len(value) > MAX_TEXT:
        raise ValueError(f"the grammar text is longer than {MAX_TEXT} characters")
    return value


def _attrs(value: Any) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict) or len(value) > 1000:
        raise ValueError("attrs must be an object of names to values")
    out = {}
    for k, v in value.items():
        if not isinstance(k, str) or not isinstance(v, (int, float, str, bool)):
            raise ValueError(f"attrs: {k!r} must be a name with a number, string or boolean value")
        out[k] = v
    return out


def _edit_args(msg: dict) -> dict:
    variation = msg.get("variation")
    return {"rev": _int(msg.get("rev", 0), "rev"), "text": _text(msg.get("text")),
            "attrs": _attrs(msg.get("attrs")), "seed": _int(msg.get("seed", 0), "seed"),
            "example": _int(msg.get("example", 0), "example"),
            "variation": None if variation is None else _int(variation, "variation")}
