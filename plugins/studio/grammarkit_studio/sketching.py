"""The sketch canvas's server side: each object type's canvas, strokes to a line drawing, the
sketch recognizer's answer (snippet and parameters, top 3), and the grammar text updated through
grammarkit's printer.

The recognizer is a plugin (grammarkit's own is the `sketch` entry point, Nishida et al. 2016),
never imported by name: plugins do not import each other. It is found through the plugin
registry when the sketch canvas is first used (`recognizer_api`), so the studio works, less its
sketch canvas, when no recognizer is installed or it is disabled (GRAMMARKIT_DISABLE_PLUGINS). As in Nishida et al.'s interface, a sketch is
drawn on the canvas of its object type: the type's fixed camera framed on the anchor (the part
already built), whose outline the canvas shows in light grey
(`get_recognizer().canvas(object_type, size=...)`). An anchor-framed type has its own aspect
ratio (a roof 256x228, a floor 560x128), and the recognizer refuses a drawing of another shape,
so the page draws on that canvas and sends its strokes in the canvas's pixels.
`recognize(image, object_type)` returns the snippet, its parameter values and the top-3
candidates. The studio turns a candidate into grammar text: the `use SNIPPET as Anchor` line of
the anchors of that object type is replaced (or added), and each estimated parameter becomes a
grammar attr of the same name (a grammar attr replaces the snippet attr of that name), and the
whole text is printed by `grammarkit.printer`.
"""
from __future__ import annotations

import base64
import io
import math
import sys
from pathlib import Path
from typing import Any

from grammarkit.errors import GrammarkitError

MAX_STROKES = 500
MAX_POINTS = 50_000
MAX_CANVAS = 4096
CANDIDATES = 3
CANVAS_LONGEST = 512  # pixels of the longest side of the canvas the page draws on
# the pen: 2 px per 256 px of the canvas, the scale of the recognizer's training drawings
PEN_PER_PIXEL = 2.0 / 256.0


class SketchError(GrammarkitError):
    """A sketch the studio cannot use (too large, no strokes, no recognizer installed)."""


def strokes_to_image(strokes: Any, width: int, height: int, line_width: float | None = None) -> Any:
    """Dark strokes on white paper, as the recognizer reads drawings (a PIL image); the pen is
    `line_width` pixels wide, by default the training drawings' (2 px per 256 px)."""
    from PIL import Image, ImageDraw

    if not (isinstance(width, int) and isinstance(height, int) and 16 <= width <= MAX_CANVAS
            and 16 <= height <= MAX_CANVAS):
        raise SketchError(f"sketch canvas must be 16..{MAX_CANVAS} pixels wide and high")
    if not isinstance(strokes, list):
        raise SketchError("strokes must be a list of strokes")
    if not strokes:
        raise SketchError("nothing to recognise: draw some strokes on the canvas first")
    if len(strokes) > MAX_STROKES:
        raise SketchError(f"draw at most {MAX_STROKES} strokes")
    image = Image.new("L", (width, height), 255)
    draw = ImageDraw.Draw(image)
    points = 0
    for stroke in strokes:
        if not isinstance(stroke, list):
            raise SketchError("a stroke is a list of [x, y] points")
        pts = []
        for p in stroke:
            if not (isinstance(p, list) and len(p) == 2 and all(isinstance(v, (int, float)) and math.isfinite(v)
                                                                 for v in p)):
                raise SketchError("a stroke point is [x, y] with finite numbers")
            pts.append((float(p[0]), float(p[1])))
        points += len(pts)
        if points > MAX_POINTS:
            raise SketchError(f"the sketch has more than {MAX_POINTS} points")
        if len(pts) == 1:
            pts = pts * 2
        pen = line_width if line_width is not None else PEN_PER_PIXEL * min(width, height)
        draw.line(pts, fill=0, width=max(1, round(pen)), joint="curve")
    return image


def anchors_of_type(grammar: Any, object_type: str) -> list[str]:
    """The anchors whose snippet is of `object_type` (grammar with imports inlined)."""
    types = {s.name: s.object_type for s in grammar.snippets}
    return [u.anchor for u in grammar.uses if types.get(u.snippet) == object_type]


def apply_snippet(text: str, path: Path, merged: Any, object_type: str, snippet: str,
                  values: dict[str, float]) -> str:
    """The grammar text with `snippet` bound to the anchors of `object_type` and `values` as
    attrs, printed by grammarkit's printer (imports kept as written, comments kept).

    `merged` is the grammar with its imports inlined (to know each snippet's object type)."""
    from grammarkit.dsl import parse
    from grammarkit.ir import Attr, Num, Unary, Use
    from grammarkit.printer import format_grammar

    types = {s.name: s.object_type for s in merged.snippets}
    if types.get(snippet) != object_type:
        raise SketchError(f"snippet {snippet!r} is not a {object_type} snippet of this grammar")
    raw = parse(text, filename=str(path))
    anchors = set(anchors_of_type(merged, object_type)) or {object_type}
    statements = list(raw.statements)
    bound = False
    for i, st in enumerate(statements):
        if isinstance(st, Use) and st.anchor in anchors:
            statements[i] = st.model_copy(update={"snippet": snippet})
            bound = True
    if not bound:
        statements.append(Use(snippet=snippet, anchor=object_type))
    last_attr = max((i for i, st in enumerate(statements) if isinstance(st, Attr)), default=-1)
    for name, value in values.items():
        v = float(value)
        expr = Num(value=abs(v)) if v >= 0 else Unary(op="-", operand=Num(value=-v))
        for i, st in enumerate(statements):
            if isinstance(st, Attr) and st.name == name:
                statements[i] = st.model_copy(update={"value": expr})
                break
        else:
            last_attr += 1
            statements.insert(last_attr, Attr(name=name, value=expr))
    return format_grammar(raw.model_copy(update={"statements": tuple(statements)}))


# The recognizer's API, as a plugin package exposes it: `recognize(image, object_type,
# snippet=None)` and `get_recognizer()` (whose `.canvas(type, size=)` and `.models`).
RECOGNIZER_API = ("recognize", "get_recognizer")


def recognizer_api() -> Any:
    """The sketch recognizer, found through the plugin registry: among the plugins the plugin
    manager loaded (entry points of group `grammarkit`, minus disabled or broken ones), the
    first whose package offers RECOGNIZER_API. Nothing is imported by name: the package is
    the one its entry point already loaded."""
    from grammarkit.plugins import get_plugin_manager

    for info in get_plugin_manager().plugins():
        if info.disabled or not info.ok or not info.module:
            continue
        module = info.module.partition(":")[0]
        package = sys.modules.get(module.rpartition(".")[0] or module)
        try:
            if package is not None and all(callable(getattr(package, n, None)) for n in RECOGNIZER_API):
                return package
        except ImportError:  # the package is there, but its learning extra (torch) is not
            raise SketchError(f"the sketch recognizer of plugin {info.name!r} cannot load: install "
                              "the `learning` extra it uses") from None
    raise SketchError("no sketch recognizer is installed: the sketch canvas needs a plugin that "
                      "provides one (grammarkit's `sketch` plugin, with the `learning` extra)")


def _check_type(object_type: Any, merged: Any) -> str:
    types = sorted({s.object_type for s in merged.snippets})
    if object_type not in types:
        have = ", ".join(types) or "none"
        raise SketchError(f"this grammar has no {object_type!r} snippets to recognise (it has: {have})")
    return object_type


def sketch_canvas(object_type: str, merged: Any) -> dict:
    """The canvas a type is drawn on: its size in pixels (the type's aspect ratio, longest side
    CANVAS_LONGEST) and the blank canvas with the anchor's outline, as a PNG data URL."""
    sketch = recognizer_api()
    _check_type(object_type, merged)
    recognizer = sketch.get_recognizer()
    stage = recognizer.models.type_model(object_type).stage  # ModelFileError names the types it has
    image = recognizer.canvas(object_type, size=CANVAS_LONGEST)
    buf = io.BytesIO()
    image.save(buf, format="PNG", optimize=True)
    width, height = image.size
    return {"object_type": object_type, "width": width, "height": height,
            "stage_canvas": list(stage.canvas_size()), "framing": stage.framing,
            "png": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")}


def recognize_sketch(strokes: Any, width: int, height: int, object_type: str, text: str,
                     path: Path, merged: Any) -> dict:
    """The recognizer's top candidates for the drawing (strokes in pixels of a `width` x
    `height` canvas of the type's shape, see `sketch_canvas`), each with its parameters and the
    grammar text that uses it."""
    sketch = recognizer_api()
    _check_type(object_type, merged)
    image = strokes_to_image(strokes, width, height)
    best = sketch.recognize(image, object_type)
    out = []
    for cand in list(best.top)[:CANDIDATES]:
        r = best if cand.snippet == best.snippet else sketch.recognize(image, object_type, snippet=cand.snippet)
        params = {k: float(r.values[k]) for k in r.estimated}
        item = {"snippet": cand.snippet, "probability": float(cand.probability), "params": params,
                "score": float(r.score), "text": None, "note": None}
        try:
            item["text"] = apply_snippet(text, path, merged, object_type, cand.snippet, params)
        except SketchError as exc:  # a snippet of the recognizer's library this grammar lacks
            item["note"] = str(exc)
        out.append(item)
    return {"object_type": object_type, "candidates": out}
