"""Issue 31: the studio's HTTP and websocket inputs answer bad requests with a message, never a
500 or a dropped connection: a 5,000-digit (or non-ASCII-digit) gallery index, websocket
messages nested 100,000 deep, numbers beyond int()'s digit limit, NaN where the reply echoes a
value. After each bad message the same connection still answers.

`STUDIO_ATTACKS` is the catalogue that benchmarks/bench_hardening.py also runs (group "studio
server"); each attack takes a running studio and returns (verdict, detail), verdict "clear"
when the studio answered with a clear refusal and kept working.
"""
from __future__ import annotations

import json
import urllib.error
import urllib.request
from typing import Any, Callable

import pytest

TIMEOUT = 30


def http_get(studio: Any, path: str) -> tuple[int, str]:
    """(status, body) of a GET on the studio (its token in the path)."""
    url = f"http://127.0.0.1:{studio.port}/s/{studio.token}{path}"
    try:
        with urllib.request.urlopen(url, timeout=TIMEOUT) as r:
            return r.status, r.read().decode("utf-8", "replace")
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode("utf-8", "replace")


def _export(query: str, words: str) -> Callable[[Any], tuple[str, str]]:
    def attack(studio: Any) -> tuple[str, str]:
        status, body = http_get(studio, f"/export/glb?{query}")
        if status >= 500:
            return "traceback", f"HTTP {status}: {body[:200]}"
        if not 400 <= status < 500 or words not in body:
            return "wrong", f"HTTP {status}: {body[:200]}"
        return "clear", ""
    return attack


def _ws_url(studio: Any) -> str:
    return f"ws://127.0.0.1:{studio.port}/s/{studio.token}/ws"


def _still_answers(ws: Any, text: str) -> bool:
    """Whether the connection answers a good message after the bad one."""
    ws.send(json.dumps({"op": "backends", "text": text}))
    while True:
        reply = json.loads(ws.recv(timeout=TIMEOUT))
        if reply.get("type") == "backends":
            return "split" in reply["backends"]


def _ws(message: str, words: str) -> Callable[[Any], tuple[str, str]]:
    def attack(studio: Any) -> tuple[str, str]:
        from websockets.sync.client import connect

        try:
            with connect(_ws_url(studio), open_timeout=TIMEOUT, max_size=None) as ws:
                if json.loads(ws.recv(timeout=TIMEOUT)).get("type") != "file":
                    return "wrong", "the studio did not send the file first"
                ws.send(message)
                reply = ws.recv(timeout=TIMEOUT)
                data = json.loads(reply)
                if data.get("type") not in ("error", "derive-error") or words not in data.get("message", ""):
                    return "wrong", f"reply {reply[:200]}"
                if not _still_answers(ws, studio.disk.text):
                    return "wrong", "the connection no longer answers"
                return "clear", ""
        except Exception as exc:  # noqa: BLE001 - ConnectionClosed, TimeoutError: the finding
            return "traceback", f"the connection dropped: {type(exc).__name__}: {exc}"
    return attack


DEEP = "[" * 100_000 + "]" * 100_000
STUDIO_ATTACKS: list[tuple[str, Callable[[Any], tuple[str, str]]]] = [
    ("export gallery=<5000 digits>", _export("gallery=" + "9" * 5000, "gallery= must be")),
    ("export gallery=<superscript two>", _export("gallery=%C2%B2", "gallery= must be")),
    ("export gallery=-1", _export("gallery=-1", "gallery= must be")),
    ("export gallery=64", _export("gallery=64", "gallery= must be")),
    ("export gallery= (empty)", _export("gallery=", "gallery= must be")),
    ("websocket: a list nested 100,000 deep", _ws(DEEP, "nested deeper")),
    ("websocket: an object nested 100,000 deep", _ws('{"a":' * 100_000 + "1" + "}" * 100_000, "nested deeper")),
    ("websocket: rev nested 40 deep", _ws('{"op": "tree", "rev": ' + "[" * 40 + "]" * 40 + "}", "nested deeper")),
    ("websocket: strokes nested 500 deep", _ws('{"op": "sketch", "strokes": ' + "[" * 500 + "]" * 500 + "}",
                                                 "nested deeper")),
    ("websocket: a 5000-digit number", _ws('{"op": "edit", "rev": ' + "9" * 5000 + "}", "malformed")),
    ("websocket: NaN as the op", _ws('{"op": NaN}', "unknown op")),
    ("websocket: Infinity as a pick point", _ws('{"op": "pick", "point": [Infinity, 0, 0]}', "")),
    ("websocket: a list, not an object", _ws("[1, 2, 3]", "malformed")),
    ("websocket: attrs nested in attrs", _ws(json.dumps({"op": "edit", "text": "", "attrs": {"a": {"b": 1}}}),
                                           "attrs")),
]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from grammarkit_studio import running

    path = tmp_path_factory.mktemp("studio-attacks") / "g.grammar"
    path.write_text("grammar g\nLot --> footprint(rect(8, 6)) extrude(9) Mass.\n")
    with running(path, poll=0.5) as studio:
        yield studio


@pytest.mark.parametrize("name,attack", STUDIO_ATTACKS, ids=[n for n, _ in STUDIO_ATTACKS])
def test_studio_attack_is_answered(served, name, attack):
    verdict, detail = attack(served)
    assert verdict == "clear", f"{name}: {verdict}: {detail}"


def test_a_good_gallery_index_still_reaches_the_worker(served):
    status, body = http_get(served, "/export/glb?gallery=3")
    assert status == 409 and "no variant 3" in body  # the worker answers: nothing sampled yet
