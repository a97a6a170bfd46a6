"""The studio's security model: localhost only, the per-session token on every request and
websocket, no cross-origin or foreign-Host requests, GET only with bounded bodies, bounded
websocket messages, a content security policy, and file access limited to the grammar's folder."""
from __future__ import annotations

import http.client
import json
import socket
from pathlib import Path

import pytest

pytest.importorskip("starlette", reason="the studio extra is not installed")


def request(studio, path: str, *, method: str = "GET", headers: dict | None = None,
            body: bytes | None = None) -> tuple[int, dict, bytes]:
    conn = http.client.HTTPConnection("127.0.0.1", studio.port, timeout=10)
    try:
        conn.request(method, path, body=body, headers=headers or {})
        resp = conn.getresponse()
        return resp.status, {k.lower(): v for k, v in resp.getheaders()}, resp.read()
    finally:
        conn.close()


def ws_connect(studio, path: str, origin: str | None) -> str:
    """'open' when the studio accepts the websocket, else why it did not."""
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    try:
        with connect(f"ws://127.0.0.1:{studio.port}{path}", origin=origin, open_timeout=10) as ws:
            first = json.loads(ws.recv(timeout=10))
            return "open" if first.get("type") == "file" else f"unexpected {first}"
    except InvalidStatus as exc:
        return f"refused {exc.response.status_code}"
    except Exception as exc:  # noqa: BLE001 - closed during the handshake
        return f"refused {type(exc).__name__}"


def test_listens_on_loopback_only(studio):
    assert studio.url.startswith(f"http://127.0.0.1:{studio.port}/s/")
    # the port is not reachable through another local address of the machine
    others = {ip for *_, (ip, *_) in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)}
    for ip in others - {"127.0.0.1"}:
        with socket.socket() as s:
            s.settimeout(2)
            assert s.connect_ex((ip, studio.port)) != 0, ip


def test_token_is_required_everywhere(studio):
    prefix = f"/s/{studio.token}"
    status, headers, body = request(studio, f"{prefix}/")
    assert status == 200 and b"grammarkit studio" in body
    for path in ("/", "/static/studio.js", "/export/glb", "/s/", "/s/wrong/", f"/s/{studio.token[:-1]}/",
                 "/s/wrong/static/studio.js", "/s/wrong/export/glb", f"/static/../s/{studio.token}x/"):
        status, _, body = request(studio, path)
        assert status == 403, path
        assert studio.token.encode() not in body
    assert request(studio, f"{prefix}/static/studio.js")[0] == 200
    assert request(studio, f"{prefix}/static/../../../etc/passwd")[0] == 404


def test_page_headers(studio):
    _, headers, _ = request(studio, f"/s/{studio.token}/")
    csp = headers["content-security-policy"]
    assert "default-src 'self'" in csp and "script-src 'self'" in csp and "frame-ancestors 'none'" in csp
    assert headers["x-frame-options"] == "DENY" and headers["referrer-policy"] == "no-referrer"


def test_cross_origin_and_foreign_host_refused(studio):
    prefix = f"/s/{studio.token}"
    assert request(studio, f"{prefix}/", headers={"Origin": "http://evil.example"})[0] == 403
    assert request(studio, f"{prefix}/", headers={"Origin": f"http://127.0.0.1:{studio.port + 1}"})[0] == 403
    assert request(studio, f"{prefix}/", headers={"Sec-Fetch-Site": "cross-site"})[0] == 403
    # DNS rebinding: a page of evil.example whose name resolves to 127.0.0.1 sends its own Host
    assert request(studio, f"{prefix}/", headers={"Host": f"evil.example:{studio.port}"})[0] == 403
    assert request(studio, f"{prefix}/", headers={"Origin": f"http://localhost:{studio.port}",
                                                  "Host": f"localhost:{studio.port}"})[0] == 200


def test_methods_and_sizes(studio):
    prefix = f"/s/{studio.token}"
    assert request(studio, f"{prefix}/", method="POST", body=b"x")[0] == 403
    assert request(studio, f"{prefix}/", method="PUT", body=b"x")[0] == 403
    # a body on GET is bounded
    status, _, _ = request(studio, f"{prefix}/", headers={"Content-Length": str(10**7)}, body=b"")
    assert status == 413


def test_websocket_needs_token_and_same_origin(studio):
    prefix = f"/s/{studio.token}"
    own = f"http://127.0.0.1:{studio.port}"
    assert ws_connect(studio, f"{prefix}/ws", own) == "open"
    assert ws_connect(studio, f"{prefix}/ws", None) == "open"  # a non-browser client with the token
    assert ws_connect(studio, "/s/wrong/ws", own).startswith("refused")
    assert ws_connect(studio, "/ws", own).startswith("refused")
    assert ws_connect(studio, f"{prefix}/ws", "http://evil.example").startswith("refused")


def test_websocket_messages_are_bounded_and_checked(studio):
    from websockets.sync.client import connect

    with connect(f"ws://127.0.0.1:{studio.port}/s/{studio.token}/ws", open_timeout=10,
                 max_size=None) as ws:
        assert json.loads(ws.recv(timeout=10))["type"] == "file"
        ws.send("not json")
        assert json.loads(ws.recv(timeout=10)) == {"type": "error", "message": "malformed message"}
        ws.send(json.dumps({"op": "edit", "rev": 1, "text": 5}))
        reply = json.loads(ws.recv(timeout=10))
        assert reply["type"] == "error" and "text must be a string" in reply["message"]
        ws.send(json.dumps({"op": "gallery", "text": "", "n": 10_000}))
        assert "n must be" in json.loads(ws.recv(timeout=10))["message"]
        try:
            ws.send("x" * (8 * 1024 * 1024))  # over ws_max_size: the server closes the socket
            ws.recv(timeout=10)
            closed = False
        except Exception:  # noqa: BLE001 - ConnectionClosed
            closed = True
        assert closed


def test_imports_outside_the_folder_are_refused(tmp_path):
    from grammarkit_studio.work import Work

    inside = tmp_path / "proj"
    inside.mkdir()
    (tmp_path / "secret.grammar").write_text("grammar secret\nattr a = 1\n")
    path = inside / "g.grammar"
    text = 'grammar g\nimport "../secret.grammar"\nLot --> extrude(3) NIL\n'
    path.write_text(text)
    out = Work(str(path), str(inside)).check(text)
    assert not out["ok"]
    (d,) = out["diagnostics"]
    assert d["code"] == "outside-folder" and d["line"] == 2
    assert "the only folder the studio reads files from" in d["message"]


def test_asset_files_outside_the_folder_are_refused(tmp_path):
    from grammarkit_studio.work import Work

    inside = tmp_path / "proj"
    inside.mkdir()
    path = inside / "g.grammar"
    text = ('grammar g\nLot --> footprint(rect(8, 6)) extrude(10) comp(f) { top: Top | side: NIL | bottom: NIL }\n'
            'Top --> i("../../etc/passwd.glb") Chimney.\n')
    path.write_text(text)
    out = Work(str(path), str(inside)).check(text)
    assert not out["ok"]
    (d,) = [d for d in out["diagnostics"] if d["code"] == "outside-folder"]
    assert d["line"] == 3 and "passwd.glb" in d["message"]
    tiling = 'grammar t\npart A = mesh("/tmp/elsewhere.glb")\nexample e = assembly("../e.glb")\n'
    path.write_text(tiling)
    out = Work(str(path), str(inside)).check(tiling)
    lines = sorted(d["line"] for d in out["diagnostics"] if d["code"] == "outside-folder")
    assert lines == [2, 3]
    # the shipped examples read only files beside them
    root = Path(__file__).resolve().parents[2] / "grammars"
    for grammar in (root / "paris.grammar", root / "tiling" / "castle" / "castle.grammar"):
        assert Work(str(grammar), str(grammar.parent)).check(grammar.read_text())["ok"], grammar


def test_a_page_from_another_origin_cannot_drive_the_studio(studio, browser, tmp_path):
    """A real page on another local origin (as a malicious site would be) that even knows the
    token: its websocket is closed and its requests are refused by the studio itself."""
    import functools
    import http.server
    import threading

    (tmp_path / "index.html").write_text("<!doctype html><title>elsewhere</title>")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        page = browser.new_page()
        page.goto(f"http://127.0.0.1:{server.server_address[1]}/")
        refused = studio.gate.refused
        result = page.evaluate("""async (base) => {
            const ws = await new Promise((resolve) => {
                const s = new WebSocket(base.replace("http", "ws") + "ws");
                s.onopen = () => resolve("open");
                s.onclose = () => resolve("closed");
                s.onerror = () => {};
            });
            let fetched;
            try { fetched = (await fetch(base + "export/glb")).status; } catch (e) { fetched = "blocked"; }
            let blind;  // a no-cors request the page cannot read, but the server must still refuse
            try { await fetch(base + "export/glb", {mode: "no-cors"}); blind = "sent"; } catch (e) { blind = "blocked"; }
            return {ws, fetched, blind};
        }""", studio.url)
        assert result["ws"] == "closed" and result["fetched"] == "blocked"
        assert studio.gate.refused >= refused + 2  # the websocket and the requests reached the gate
        page.close()
    finally:
        server.shutdown()
        server.server_close()
