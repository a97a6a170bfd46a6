"""Sketching a whole building, stage by stage (Nishida et al. 2016, s. 3, 4.2, 6).

A session holds one recognised snippet per object type, sketched coarse to fine (the
library's type order: mass, roof, facade, floor, window, ledge). Each stage is drawn on its own
canvas: the type's fixed camera framed on the anchor the building so far offers for it (the
top face of the recognised mass for the roof, a facade face for the facade, one floor of it
for the floor, ...). `grammar()` is the *generated grammar*: one grammar for the whole model,
with a copy of every snippet used (recognised parameter values as its attr values), each bound
to its anchor by `use S as Anchor` (its `Start` renamed to the anchor), the library's default
snippets filling the stages that were not sketched, and a lot rule. It is written through
grammarkit's printer and needs no other file.

session.json (see docs/sketch.md)::

    {"format": "grammarkit-sketch-session", "version": 1,
     "name": "my_building",                      # optional grammar name
     "lot": [16, 12],                            # optional lot width, depth (m)
     "line_width": 4,                            # optional pen width for the strokes (px;
                                                 #   default 2 per 256 px of the canvas)
     "refine": 10, "method": "pattern",           # optional refinement of every stage
     "stages": [
        {"type": "Mass", "canvas": [512, 512], "strokes": [[[x, y], [x, y], ...], ...]},
        {"type": "Roof", "canvas": [512, 456], "strokes": [...], "snippet": "roof_hip"},
        ...]}

Stroke points are pixels of the stage's canvas (x right, y down). An anchor-framed stage
needs a canvas of its stage's aspect ratio (`Session.canvas(type)` tells it, and
`grammarkit sketch-session --canvases DIR` draws them); the mass may be drawn anywhere.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from grammarkit.errors import GrammarkitError

from .drawing import draw, strokes_to_ink
from .recognizer import Recognition, Recognizer, get_recognizer
from .refine import EXACT_STYLE
from .stages import StageSpec

SESSION_FORMAT = "grammarkit-sketch-session"
SESSION_VERSION = 1
LOT_ATTRS = ("lot_w", "lot_d")


RERANK_MIN_PROBABILITY = 0.05  # classes re-ranked by match score on a non-canonical anchor

class SessionError(GrammarkitError):
    """A session file or stage that cannot be used: names the file and stage and says why."""


@dataclass(frozen=True)
class StageCanvas:
    """Where a stage is drawn: its canvas size (pixels), camera view and stage settings."""

    object_type: str
    size: tuple[int, int]
    stage: StageSpec
    view: Any  # grammarkit View: view.to_pixels(world points) -> canvas pixels
    anchor: str

    def to_dict(self) -> dict:
        return {"type": self.object_type, "canvas": list(self.size), "anchor": self.anchor,
                "anchor_size": list(self.stage.anchor_size), "framing": self.stage.framing}


@dataclass
class StageResult:
    object_type: str
    recognition: Recognition
    canvas: tuple[int, int]
    strokes: list


class Session:
    """An interactive sketching session; see the module docstring."""

    def __init__(self, *, models: Any = None, library: Any = None, lot: Sequence[float] | None = None,
                 name: str = "building", line_width: float | None = None):
        self.recognizer: Recognizer = get_recognizer(models, library)
        self.library = self.recognizer.library
        self.models = self.recognizer.models
        self.name = name
        mass = self.library.types[0]
        default_lot = self.models.types[mass].stage.anchor_size if mass in self.models.types else (16.0, 12.0)
        self.lot = tuple(float(v) for v in (lot or default_lot))
        if len(self.lot) != 2 or not all(0 < v < 1e4 for v in self.lot):
            raise SessionError(f"lot must be two positive sizes in metres, got {lot!r}", None)
        self.line_width = None if line_width is None else float(line_width)
        self.stages: dict[str, StageResult] = {}
        self._anchors: dict[tuple, tuple] = {}

    # -- the generated grammar ---------------------------------------------------------------
    def choices(self, skip: str | None = None) -> dict[str, tuple[str, dict]]:
        """{type: (snippet, attr values)} for every type: recognised, else the default."""
        out = {}
        for t in self.library.types:
            if t == skip:
                continue
            if t in self.stages:
                r = self.stages[t].recognition
                out[t] = (r.snippet, dict(r.values))
            else:
                out[t] = (self.library.default_for(t), {})
        return out

    def grammar(self, out_dir: str | Path | None = None, *, skip: str | None = None, source: str | None = None):  # noqa: ANN201
        """The generated grammar (IR). `out_dir`: where it will be written (inserted part
        paths are made relative to it); `skip`: leave that type's anchors unbound (leaves)."""
        import grammarkit
        from grammarkit.ir import Attr, Grammar, Num, Use

        lib = self.library
        choices = self.choices(skip)
        statements: list[Any] = []
        head = [f" Generated by grammarkit sketch-session{f' from {source}' if source else ''}: one grammar for",
                " the whole model, a copy of each snippet bound to its anchor (Nishida et al. 2016).",
                f" Snippets from library {lib.name!r}."]
        lot_w, lot_d = self.lot
        statements.append(Attr(name=LOT_ATTRS[0], value=Num(value=round(lot_w, 3)),
                               range=(Num(value=round(lot_w / 2, 3)), Num(value=round(lot_w * 2, 3))),
                               comments=(" the lot (width x depth, metres)",)))
        statements.append(Attr(name=LOT_ATTRS[1], value=Num(value=round(lot_d, 3)),
                               range=(Num(value=round(lot_d / 2, 3)), Num(value=round(lot_d * 2, 3)))))
        statements.extend(a for a in lib.grammar.attrs)
        statements.extend(c for c in lib.grammar.consts)
        first = lib.types[0]
        lot_rule = grammarkit.parse(f"grammar x\nLot --> footprint(rect({LOT_ATTRS[0]}, {LOT_ATTRS[1]})) {first}\n")
        statements.extend(lot_rule.rules)
        base = Path(out_dir).resolve() if out_dir is not None else None
        uses = []
        for t, (snip, values) in choices.items():
            info = lib.snippets[snip]
            statements.append(_snippet_copy(info.snippet, values, base, self._stage_note(t)))
            note = () if t in self.stages else (" default: not sketched",)
            uses.append(Use(snippet=snip, anchor=t, comments=note))
        statements.extend(uses)
        return Grammar(name=_ident(self.name), statements=tuple(statements), comments=head,
                       source_path=str(base / "generated.grammar") if base else None)

    def grammar_text(self, out_dir: str | Path | None = None, source: str | None = None) -> str:
        from grammarkit.printer import print_grammar

        return print_grammar(self.grammar(out_dir, source=source))

    def _stage_note(self, t: str) -> tuple[str, ...]:
        if t not in self.stages:
            return ()
        r = self.stages[t].recognition
        return (f" sketched {t}: {r.snippet} (p = {r.probability:.2f}), match score {r.score:.2f}",)

    def derive(self, seed: int = 0):  # noqa: ANN201
        """The model of the generated grammar so far."""
        from grammarkit.split import derive

        return derive(self.grammar(Path.cwd()), seed=seed)

    # -- stages --------------------------------------------------------------------------------
    def anchor_size(self, object_type: str) -> tuple[tuple[float, float], str]:
        """Size of the anchor the building so far offers to a type, and a description."""
        from grammarkit.split import derive

        t = self.library.check_type(object_type)
        kind = self.library.anchor_kinds[t]
        if kind == "ground":
            return self.lot, "the lot"
        key = (t, tuple(sorted((k, v[0], tuple(sorted(v[1].items()))) for k, v in self.choices(skip=t).items())),
               self.lot)
        if key in self._anchors:
            return self._anchors[key]
        model = derive(self.grammar(Path.cwd(), skip=t), seed=0)
        leaves = [p for p in model.parts if p.name == t and p.kind == "face"]
        if not leaves:
            used = ", ".join(f"{k}: {s}" for k, (s, _) in self.choices(skip=t).items())
            raise SessionError(f"the building so far has no {t} anchor for this stage ({used}); "
                               f"sketch an earlier stage whose snippet offers {t} faces", None,
                               code="sketch-no-anchor")

        # the anchors facing the stage cameras (the front, -y) and, among those, the most common
        # size: a typical storey rather than a taller ground floor
        facing = [round(float(-np.asarray(p.axes[2], float)[1]), 3) for p in leaves]
        front = [p for p, f in zip(leaves, facing) if f == max(facing)]
        sizes: dict[tuple, list] = {}
        for p in front:
            sizes.setdefault((round(p.size[0], 2), round(p.size[1], 2)), []).append(p)
        best = max(sizes.values(), key=lambda ps: (len(ps), ps[0].size[0] * ps[0].size[1]))[0]
        out = ((float(best.size[0]), float(best.size[1])),
               f"{t} face {best.id} ({best.size[0]:.2f} x {best.size[1]:.2f} m)")
        self._anchors[key] = out
        return out

    def canvas(self, object_type: str, longest: int | None = None) -> StageCanvas:
        """The canvas a type is drawn on now (it depends on the earlier stages)."""
        t = self.library.check_type(object_type)
        tm = self.models.type_model(t)
        size, anchor = self.anchor_size(t)
        stage = tm.stage.with_anchor(size)
        w, h = stage.canvas_size()
        if longest:
            k = longest / max(w, h)
            w, h = int(round(w * k)), int(round(h * k))
        view = stage.view((w, h))
        return StageCanvas(t, (w, h), stage, view, anchor)

    def add_strokes(self, object_type: str, strokes: Sequence[Sequence[Sequence[float]]],
                    canvas: Sequence[int] | None = None, *, refine: int = 0, method: str = "pattern",
                    snippet: str | None = None, line_width: float | None = None, seed: int = 0) -> Recognition:
        """Recognise the strokes of one stage (replacing an earlier sketch of the same type).

        strokes: polylines of (x, y) canvas pixels; canvas: (width, height) they were drawn on
        (default: the stage's own canvas size)."""
        t = self.library.check_type(object_type)
        sc = self.canvas(t)
        size = tuple(int(v) for v in (canvas or sc.size))
        if len(size) != 2 or min(size) < 16:
            raise SessionError(f"stage {t}: canvas must be [width, height] in pixels, got {canvas!r}", None)
        lines = _check_strokes(strokes, size, t)
        # the pen: as given, else 2 px per 256 px of the canvas (the training drawings' scale)
        pen = line_width or self.line_width or 2.0 * min(size) / 256.0
        ink = strokes_to_ink(lines, size, pen)
        if not (ink > 0.25).any():
            raise SessionError(f"stage {t}: no strokes to recognise", None, code="sketch-blank")
        r = self.recognizer.recognize_ink(ink, t, stage=sc.stage, what=f"stage {t}", refine_steps=refine,
                                          method=method, snippet=snippet, seed=seed)
        canonical = self.models.type_model(t).stage.anchor_size
        if snippet is None and not np.allclose(sc.stage.anchor_size, canonical, rtol=0.05):
            # The networks were trained on the canonical anchor; on an anchor of other
            # proportions (a 40 m tower's facade) the classifier may prefer a snippet that,
            # drawn on the real anchor, matches the strokes far worse. The likely classes are
            # re-ranked on the real anchor: with refinement by the match score of each at its
            # refined parameters (the classifier, trained on other proportions, only nominates
            # them); without, by probability x match score of the networks' estimates (which
            # are in canonical proportions, so the score alone would mislead).
            def rank(x: Recognition) -> float:
                return x.score if refine > 0 else x.probability * x.score
            for c in r.top[1:]:
                if c.probability < RERANK_MIN_PROBABILITY:
                    break
                alt = self.recognizer.recognize_ink(ink, t, stage=sc.stage, what=f"stage {t}",
                                                    refine_steps=refine, method=method, snippet=c.snippet,
                                                    seed=seed)
                if rank(alt) > rank(r):
                    r = alt
        self.stages[t] = StageResult(t, r, size, [list(map(list, ln)) for ln in lines])
        return r

    def stage_picture(self, object_type: str, size: int = 384) -> Any:
        """The stage canvas: the anchor outline (light), the strokes (grey), the recognised
        snippet (red)."""
        from PIL import Image

        from .recognizer import anchor_outline

        t = self.library.check_type(object_type)
        res = self.stages.get(t)
        stage = res.recognition.stage if res else self.canvas(t).stage
        w, h = stage.canvas_size()
        k = size / max(w, h)
        W, H = int(round(w * k)), int(round(h * k))
        rgb = np.ones((H, W, 3), dtype=np.float32)
        if stage.framing == "anchor":  # (a fit-framed mass may be drawn anywhere: no outline)
            rgb -= anchor_outline(stage, (W, H))[..., None] * 0.2
        if res is not None:
            sx, sy = W / res.canvas[0], H / res.canvas[1]
            lines = [[(x * sx, y * sy) for x, y in ln] for ln in res.strokes]
            rgb -= strokes_to_ink(lines, (W, H), 2.0)[..., None] * 0.55
            if stage.framing == "anchor":
                model = self.recognizer.model_of(res.recognition)
                mk = draw(model, stage.view((W, H)), EXACT_STYLE, stage.host_box())
                a = np.clip(mk, 0, 1)[..., None]
                rgb = rgb * (1 - a) + np.array([0.85, 0.1, 0.1], dtype=np.float32) * a
        return Image.fromarray(np.clip(rgb * 255, 0, 255).astype(np.uint8), "RGB")

    # -- files ---------------------------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | Path, *, models: Any = None, library: Any = None,
                  refine: int | None = None, method: str | None = None,
                  canvases: str | Path | None = None,
                  progress: Callable[[str, int, int], None] | None = None) -> "Session":
        """Run a session.json: every stage in coarse-to-fine order. `progress(type, done,
        total)` is called before each stage (done = stages finished) and once at the end."""
        p = Path(path)
        data = read_session_file(p)
        session = cls(models=models, library=library, lot=data.get("lot"),
                      name=data.get("name") or p.stem,
                      line_width=float(data["line_width"]) if data.get("line_width") else None)
        order = {t: i for i, t in enumerate(session.library.types)}
        stages = []
        for i, st in enumerate(data["stages"]):
            where = f"{p}: stage {i + 1}"
            if not isinstance(st, dict) or "type" not in st or "strokes" not in st:
                raise SessionError(f"{where}: each stage needs \"type\" and \"strokes\"", None,
                                   code="sketch-bad-session")
            try:
                t = session.library.check_type(st["type"])
            except GrammarkitError as exc:
                raise SessionError(f"{where}: {exc}", None, code="sketch-bad-session") from None
            if any(t == s[1] for s in stages):
                raise SessionError(f"{where}: object type {t} is sketched twice", None,
                                   code="sketch-bad-session")
            stages.append((order[t], t, st, where))
        stages.sort(key=lambda s: s[0])
        for k, (_, t, st, where) in enumerate(stages):
            if progress is not None:
                progress(t, k, len(stages))
            steps = st.get("refine", data.get("refine", 0)) if refine is None else refine
            how = st.get("method", data.get("method", "pattern")) if method is None else method
            try:
                session.add_strokes(t, st["strokes"], st.get("canvas"), refine=int(steps), method=how,
                                    snippet=st.get("snippet"), line_width=st.get("line_width"))
            except GrammarkitError as exc:
                raise SessionError(f"{where} ({t}): {exc.diagnostics[0].message}", None,
                                   hint=exc.diagnostics[0].hint, code="sketch-bad-stage") from None
            if canvases is not None:
                from grammarkit.geometry.render import save_image

                folder = Path(canvases)
                folder.mkdir(parents=True, exist_ok=True)
                save_image(session.stage_picture(t), folder / f"{order[t] + 1:02d}_{t}.png")
        if progress is not None:
            progress("", len(stages), len(stages))
        return session


def read_session_file(p: Path) -> dict:
    if not p.is_file():
        raise SessionError(f"{p}: session file not found", None, code="sketch-bad-session")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise SessionError(f"{p}: cannot read the session file ({exc})", None, code="sketch-bad-session") from None
    except json.JSONDecodeError as exc:
        raise SessionError(f"{p}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}", None,
                           code="sketch-bad-session") from None
    if not isinstance(data, dict) or data.get("format") != SESSION_FORMAT:
        raise SessionError(f"{p}: not a sketch session (expected \"format\": \"{SESSION_FORMAT}\")", None,
                           code="sketch-bad-session")
    if data.get("version", SESSION_VERSION) != SESSION_VERSION:
        raise SessionError(f"{p}: session format version {data.get('version')!r}; this grammarkit reads "
                           f"version {SESSION_VERSION}", None, code="sketch-bad-session")
    if not isinstance(data.get("stages"), list) or not data["stages"]:
        raise SessionError(f"{p}: \"stages\" must be a non-empty list", None, code="sketch-bad-session")
    return data


def _check_strokes(strokes: Any, size: tuple[int, int], t: str) -> list[list[tuple[float, float]]]:
    if not isinstance(strokes, (list, tuple)) or not strokes:
        raise SessionError(f"stage {t}: strokes must be a non-empty list of polylines", None,
                           code="sketch-blank")
    out = []
    W, H = size
    for k, line in enumerate(strokes):
        if not isinstance(line, (list, tuple)) or not line:
            raise SessionError(f"stage {t}: stroke {k + 1} is not a list of [x, y] points", None,
                               code="sketch-bad-session")
        pts = []
        for pt in line:
            if (not isinstance(pt, (list, tuple)) or len(pt) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pt)
                    or not all(np.isfinite(v) for v in pt)):
                raise SessionError(f"stage {t}: stroke {k + 1} has a bad point {pt!r}; expected [x, y]",
                                   None, code="sketch-bad-session")
            x, y = float(pt[0]), float(pt[1])
            if not (-0.5 * W <= x <= 1.5 * W and -0.5 * H <= y <= 1.5 * H):
                raise SessionError(f"stage {t}: stroke {k + 1} point {pt!r} lies far outside the "
                                   f"{W}x{H} canvas", None, code="sketch-bad-session")
            pts.append((x, y))
        out.append(pts)
    return out


def _ident(name: str) -> str:
    import re

    s = re.sub(r"[^A-Za-z0-9_]", "_", str(name)) or "building"
    return s if not s[0].isdigit() else "b_" + s


def _snippet_copy(snippet: Any, values: dict, base: Path | None, comments: tuple[str, ...]) -> Any:
    """A copy of a library snippet with recognised values as its attr values and inserted
    part paths made relative to the output folder."""
    from grammarkit.ir import Num

    attrs = []
    for a in snippet.attrs:
        if a.name in values and a.range is not None:
            v = float(values[a.name])
            v = round(v, 3) if abs(v) < 1000 else round(v, 1)
            a = a.model_copy(update={"value": Num(value=v)})
        attrs.append(a)
    rules = tuple(_rebase_inserts(r, base) for r in snippet.rules) if base is not None else snippet.rules
    return snippet.model_copy(update={"attrs": tuple(attrs), "rules": rules,
                                      "comments": comments or snippet.comments})


def _rebase_inserts(node: Any, base: Path) -> Any:
    """`i("parts/x.glb")` of a library snippet, relative to the library file, rewritten
    relative to the generated grammar's folder."""
    from grammarkit.ir import Arg, OpCall, Str

    if isinstance(node, OpCall) and node.name == "i" and node.args and isinstance(node.args[0].value, Str) \
            and node.span is not None and node.span.file:
        target = (Path(node.span.file).parent / node.args[0].value.value).resolve()
        rel = os.path.relpath(target, base)
        args = (Arg(name=node.args[0].name, value=Str(value=Path(rel).as_posix())), *node.args[1:])
        node = node.model_copy(update={"args": args})
    updates = {}
    for key, child in node.__dict__.items():
        if key == "span":
            continue
        if isinstance(child, tuple) and any(hasattr(c, "model_copy") for c in child):
            new = tuple(_rebase_inserts(c, base) if hasattr(c, "model_copy") else c for c in child)
            if any(a is not b for a, b in zip(new, child)):
                updates[key] = new
        elif hasattr(child, "model_copy") and not isinstance(child, (str, bytes)):
            new = _rebase_inserts(child, base)
            if new is not child:
                updates[key] = new
    return node.model_copy(update=updates) if updates else node
