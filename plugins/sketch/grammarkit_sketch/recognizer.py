"""Recognising one sketch: which snippet, which parameter values, how well it matches.

    from grammarkit_sketch import recognize
    r = recognize("roof.png", "Roof")                 # the shipped models and library
    r.snippet, r.probability, r.values, r.score
    r.use_line()            # 'use roof_hip as Roof'
    r.set_options()         # ['Roof.roof_deg=31.7', 'Roof.roof_over=0.42']

The cascade of Nishida et al. 2016 (s. 6.1): the type's classifier picks the snippet, that
snippet's regressor estimates its parameters, and optionally `refine` steps of a search
against the sketch's distance transform improve them (refine.py).
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grammarkit.errors import GrammarkitError

from .dataset import line_mask, quick_size, render_input, stage_view
from .drawing import draw
from .image import check_aspect, fit_transform, level, load_ink, resize, to_input
from .library import SnippetLibrary, load_library
from .models import ModelFileError, SketchModels, TypeModel, load_models
from .calibration import softmax
from .nets import require_torch
from .rectify import rectify_input
from .strokes import classifier_input
from .refine import EXACT_STYLE, METHODS, SCORE_SHORT, SCORES, VIEW_RANGE, Scorer, centre_on_plateaus, refine
from .stages import StageDeriver, StageSpec

TOP = 3
RERANK_MIN_PROBABILITY = 0.05  # classes less likely than this are not fitted when re-ranking


@dataclass
class _Fit:
    """One snippet fitted to a drawing (Recognizer._fit)."""

    values: dict[str, float]
    params: dict[str, Any]
    names: list[str]
    hidden: list[str]
    match: float
    net_score: float
    evaluations: int
    regress_s: float
    score_s: float


@dataclass(frozen=True)
class Candidate:
    snippet: str
    probability: float
    same_drawing: tuple[str, ...] = ()  # snippets that draw exactly like it

    def to_dict(self) -> dict:
        return {"snippet": self.snippet, "probability": round(self.probability, 4),
                "same_drawing": list(self.same_drawing)}


@dataclass
class Recognition:
    """What a sketch shows: the snippet, its parameter values and the match score."""

    object_type: str
    snippet: str
    probability: float
    top: list[Candidate]
    values: dict[str, float]  # every ranged parameter of the snippet
    normalized: dict[str, float]  # the same, as (v - lo) / (hi - lo)
    estimated: list[str]  # parameters read from the drawing (the rest keep their defaults)
    hidden: list[str]  # parameters no drawing shows
    score: float  # s = exp(-RMS(D(render) - D(sketch))), 1 = perfect
    network_score: float  # the same before refinement
    refine_steps: int = 0
    method: str = "pattern"
    evaluations: int = 0
    timings: dict[str, float] = field(default_factory=dict)  # milliseconds
    stage: StageSpec | None = None
    score_kind: str = "chamfer"  # which score `score` is: "chamfer" or "paper" (refine.SCORES)
    redraw: bool = False  # the classifier is not sure (probability below the type's threshold)
    redraw_below: float = 0.0  # that threshold (0: the models file has none)
    page_turn: float = 0.0  # degrees the drawing was turned back before recognition (rectify.py)

    def use_line(self, anchor: str | None = None) -> str:
        return f"use {self.snippet} as {anchor or self.object_type}"

    def set_options(self, anchor: str | None = None) -> list[str]:
        """`--set` values for `grammarkit derive` that reproduce the recognised parameters."""
        a = anchor or self.object_type
        return [f"{a}.{k}={_fmt(self.values[k])}" for k in self.estimated]

    def to_dict(self) -> dict:
        return {
            "object_type": self.object_type, "snippet": self.snippet,
            "probability": round(self.probability, 4), "top": [c.to_dict() for c in self.top],
            "values": {k: float(_fmt(v)) for k, v in self.values.items()},
            "normalized": {k: round(v, 4) for k, v in self.normalized.items()},
            "estimated": list(self.estimated), "hidden": list(self.hidden),
            "score": round(self.score, 4), "network_score": round(self.network_score, 4),
            "score_kind": self.score_kind, "redraw": self.redraw,
            "redraw_below": round(self.redraw_below, 4), "page_turn": round(self.page_turn, 2),
            "refine_steps": self.refine_steps, "method": self.method, "evaluations": self.evaluations,
            "use": self.use_line(), "set": self.set_options(),
            "timings_ms": {k: round(v, 2) for k, v in self.timings.items()},
        }


def temperature_of(tm: TypeModel) -> float:
    """The type's calibration temperature (metrics "temperature"), 1.0 when uncalibrated."""
    t = tm.metrics.get("temperature", 1.0)
    return float(t) if isinstance(t, (int, float)) and 0 < float(t) < 1e3 else 1.0


def redraw_threshold_of(tm: TypeModel) -> float:
    """The type's redraw threshold (metrics "redraw_below"), 0.0 (never) when uncalibrated."""
    t = tm.metrics.get("redraw_below", 0.0)
    return float(t) if isinstance(t, (int, float)) and 0 <= float(t) < 1 else 0.0


def _fmt(v: float) -> str:
    return f"{float(v):.4g}" if abs(float(v)) < 1000 else f"{float(v):.1f}"


PRIOR_FLOOR = 0.02  # normalised: the prior never claims the network is surer than this


def prior_sigma(tm: Any, snippet: str) -> float | None:
    """The width of the refinement's prior for `snippet`'s parameters: its regressor's
    validation RMSE (models file metrics), at least PRIOR_FLOOR; None without that metric."""
    v = tm.metrics.get(f"val_rmse.{snippet}") if isinstance(tm.metrics, dict) else None
    if not isinstance(v, (int, float)) or not v > 0:
        return None
    return max(float(v), PRIOR_FLOOR)


class Recognizer:
    """Models + library, with the derivers and networks kept warm between sketches."""

    def __init__(self, models: SketchModels, library: SnippetLibrary):
        models.check_library(library)
        self.models = models
        self.library = library
        self._derivers: dict[StageSpec, StageDeriver] = {}

    def deriver(self, stage: StageSpec) -> StageDeriver:
        """The stage's deriver (a session's stages differ from the trained ones in their anchor)."""
        key = stage  # a frozen dataclass: hashable
        got = self._derivers.get(key)
        if got is None:
            if len(self._derivers) > 32:
                self._derivers.clear()
            got = self._derivers[key] = StageDeriver(self.library, stage)
        return got

    # -- the cascade -----------------------------------------------------------------------
    def logits(self, tm: TypeModel, x: np.ndarray) -> np.ndarray:
        """The classifier's raw scores (C,) for one network input."""
        torch = require_torch()
        if len(tm.classes) == 1:
            return np.zeros(1)
        x = classifier_input(np.asarray(x, dtype=np.float32), tm.metrics.get("classifier_input", "as-drawn"))
        with torch.no_grad():
            out = tm.network()(torch.from_numpy(x[None, None].astype(np.float32)))
        return out[0].numpy().astype(np.float64)

    def classify(self, tm: TypeModel, x: np.ndarray, *views: np.ndarray) -> list[Candidate]:
        """Candidates, most probable first, with calibrated probabilities: softmax of the
        logits divided by the type's temperature (calibration.py; 1 when the models file has
        none). With more `views` of the drawing (its rectified input), the logits of all are
        averaged."""
        logits = np.mean([self.logits(tm, v) for v in (x, *views)], axis=0)
        probs = softmax(logits, temperature_of(tm))
        order = np.argsort(-probs, kind="stable")
        return [Candidate(tm.classes[i][0], float(probs[i]), tuple(tm.classes[i][1:])) for i in order]

    def regress(self, tm: TypeModel, snippet: str, x: np.ndarray) -> tuple[np.ndarray, list[str], list[str]]:
        torch = require_torch()
        reg = tm.regressors.get(snippet)
        if reg is None or not reg.params:
            hidden = list(reg.hidden) if reg else []
            return np.zeros(0), [], hidden
        with torch.no_grad():
            u = reg.network()(torch.from_numpy(x[None, None].astype(np.float32)))[0].numpy()
        return u.astype(float), list(reg.params), list(reg.hidden)

    # long: the recognition of one input in order (rectify, classify, calibrate, regress, refine,
    # re-rank, score) with the timings each step adds to the Recognition
    def recognize_input(self, x: np.ndarray, object_type: str, *, stage: StageSpec | None = None,
                        refine_steps: int = 0, method: str = "pattern", snippet: str | None = None,
                        seed: int = 0, t_load: float = 0.0, target: np.ndarray | None = None,
                        score: str = "chamfer", score_short: int = SCORE_SHORT,
                        view_range: float = VIEW_RANGE, prior: bool = True,
                        rectify: bool = True, rerank: bool = False) -> Recognition:
        """Recognise a network input (RES x RES ink); see `recognize`. `rectify`: undo a turn
        of the page first on stages seen straight on (rectify.py; False: the drawing as it is,
        the paper's way); the classifier then averages its logits over the drawing as drawn
        and turned back. `target` is the sketch's
        line mask at the score canvas (dataset.line_mask with `score_short`); without it the
        input stands in (resized to the score canvas, which loses the long side's detail of an
        elongated canvas). `prior`: the default refinement (`pattern`) maximises the score times
        a Gaussian prior around the regressor's estimate, its width the regressor's validation
        RMSE (refine.with_prior); False searches the score alone."""
        if method not in METHODS:
            raise GrammarkitError(f"unknown refinement method {method!r}; expected one of "
                                  f"{', '.join(METHODS)}", None, code="sketch-bad-method")
        if score not in SCORES:
            raise GrammarkitError(f"unknown refinement score {score!r}; expected one of "
                                  f"{', '.join(SCORES)}", None, code="sketch-bad-score")
        if not isinstance(view_range, (int, float)) or isinstance(view_range, bool) or not 0 <= view_range <= 10:
            raise GrammarkitError(f"view range must be a number of degrees in [0, 10], got {view_range!r}",
                                  None, code="sketch-bad-view-range")
        if isinstance(refine_steps, bool) or not isinstance(refine_steps, int) or refine_steps < 0:
            raise GrammarkitError(f"refine steps must be a whole number >= 0, got {refine_steps!r}", None,
                                  code="sketch-bad-refine")
        tm = self.models.type_model(object_type)
        t = next(k for k, v in self.models.types.items() if v is tm)
        stage = stage or tm.stage
        t0 = time.perf_counter()
        turn, drawn = 0.0, x
        if rectify:
            x, turn = rectify_input(x, stage)
        # turned back, the classifier reads the drawing as well as drawn on average but not on
        # every drawing (it was fine-tuned on turned pages): it sees both and averages; the
        # regressors read the turned-back drawing only (their error falls by half there)
        top = self.classify(tm, x, drawn) if turn else self.classify(tm, x)
        t1 = time.perf_counter()
        if snippet is not None:
            if snippet not in self.library.snippets or self.library.snippets[snippet].object_type != t:
                names = ", ".join(s.name for s in self.library.snippets_of(t))
                raise GrammarkitError(f"{snippet!r} is not a {t} snippet of library "
                                      f"{self.library.name!r} ({names})", None, code="sketch-bad-snippet")
            chosen = snippet
            prob = next((c.probability for c in top if c.snippet == snippet or snippet in c.same_drawing), 0.0)
        else:
            chosen, prob = top[0].snippet, top[0].probability
        if target is None:
            target = (resize(x, (score_short, score_short)) if stage.framing == "fit"
                      else level(resize(x, quick_size(stage, score_short)))) > 0.5
        elif turn:  # the drawing's own lines, turned back as the networks saw them
            from .augment import rotate_ink

            target = rotate_ink(np.asarray(target, dtype=np.float32), turn) > 0.5
        fit = self._fit(tm, chosen, x, stage, target, refine_steps=refine_steps, method=method, seed=seed,
                        score=score, score_short=score_short, view_range=view_range, prior=prior)
        t2 = time.perf_counter()
        if rerank and snippet is None and refine_steps > 0:
            # analysis by synthesis over the likely classes: each is fitted to the drawing and
            # the one whose refined model matches the strokes best is the answer
            for c in top[1:TOP]:
                if c.probability < RERANK_MIN_PROBABILITY:
                    break
                alt = self._fit(tm, c.snippet, x, stage, target, refine_steps=refine_steps, method=method,
                                seed=seed, score=score, score_short=score_short, view_range=view_range,
                                prior=prior)
                if alt.match > fit.match:
                    fit, chosen, prob = alt, c.snippet, c.probability
        t3 = time.perf_counter()
        params, values = fit.params, fit.values
        normalized = {n: params[n].normalise(v) for n, v in values.items()}
        timings = {"load": t_load * 1e3, "classify": (t1 - t0) * 1e3, "regress": fit.regress_s * 1e3,
                   "score": fit.score_s * 1e3, "refine": (t2 - t1 - fit.regress_s - fit.score_s) * 1e3,
                   "rerank": (t3 - t2) * 1e3, "total": t_load * 1e3 + (t3 - t0) * 1e3}
        threshold = redraw_threshold_of(tm)
        return Recognition(t, chosen, prob, top[:TOP], values, normalized, fit.names, fit.hidden, fit.match,
                           fit.net_score, refine_steps if fit.names else 0, method, fit.evaluations,
                           timings, stage, score, redraw=snippet is None and prob < threshold,
                           redraw_below=threshold, page_turn=turn)

    def _fit(self, tm: TypeModel, chosen: str, x: np.ndarray, stage: StageSpec, target: np.ndarray, *,
             refine_steps: int, method: str, seed: int, score: str, score_short: int, view_range: float,
             prior: bool) -> _Fit:
        """The parameters of snippet `chosen` for network input `x`: the regressor's estimate,
        refined against `target` (the sketch's line mask at the score canvas)."""
        t0 = time.perf_counter()
        u, names, hidden = self.regress(tm, chosen, x)
        t1 = time.perf_counter()
        info = self.library.snippets[chosen]
        values = info.defaults()
        scorer = Scorer(self.deriver(stage), info, names, dict(values), target, score, score_short,
                        view_range=view_range if refine_steps > 0 else 0.0)
        net_score = scorer(scorer.start(u))
        t2 = time.perf_counter()
        u_ref, match = u, net_score
        params = {p.name: p for p in info.params}
        if refine_steps > 0 and len(u):
            # the prior's width is the regressor's error on the canonical anchor it was trained
            # on; on another anchor (a session's tower face) its estimate is in canonical
            # proportions and no such prior holds: the score alone decides there
            canonical = np.allclose(stage.anchor_size, tm.stage.anchor_size, rtol=0.05)
            sigma = prior_sigma(tm, chosen) if prior and method == "pattern" and canonical else None
            u_ref, match, _ = refine(scorer, u, refine_steps, method, seed, prior_sigma=sigma)
        for n, val in zip(names, u_ref):
            values[n] = params[n].value(val)
        if refine_steps > 0 and names:
            values = centre_on_plateaus(scorer.deriver, info, values, names)
        return _Fit(values, params, names, hidden, match, net_score, scorer.evaluations, t1 - t0, t2 - t1)

    def recognize(self, image: Any, object_type: str, *, stage: StageSpec | None = None, **kw: Any) -> Recognition:
        """Recognise a sketch image (path, PIL image or array) of one object type."""
        t0 = time.perf_counter()
        ink = load_ink(image)
        name = str(image) if isinstance(image, (str, Path)) else "sketch"
        return self.recognize_ink(ink, object_type, stage=stage, what=name, t0=t0, **kw)

    def recognize_ink(self, ink: np.ndarray, object_type: str, *, stage: StageSpec | None = None,
                      what: str = "sketch", t0: float | None = None, **kw: Any) -> Recognition:
        """Recognise an ink map (H x W, 1 = line) drawn on the stage's canvas."""
        t0 = time.perf_counter() if t0 is None else t0
        tm = self.models.type_model(object_type)
        stage = stage or tm.stage
        if stage.framing == "anchor":
            check_aspect(ink, stage.canvas_size(), what)
        x = to_input(ink, stage.framing)
        target = line_mask(ink, stage, kw.get("score_short", SCORE_SHORT))
        return self.recognize_input(x, object_type, stage=stage, t_load=time.perf_counter() - t0,
                                    target=target, **kw)

    # -- pictures --------------------------------------------------------------------------
    def model_of(self, r: Recognition, stage: StageSpec | None = None) -> Any:
        return self.deriver(stage or r.stage).derive(r.snippet, r.values)

    def preview(self, image: Any, r: Recognition, path: Any = None, size: int = 512) -> Any:
        """The sketch (grey) with the recognised model's lines (red) over it, on the sketch's
        canvas (longest side `size`)."""
        from PIL import Image

        ink = load_ink(image)
        stage = r.stage
        h, w = ink.shape
        k = size / max(w, h)
        W, H = max(1, int(round(w * k))), max(1, int(round(h * k)))
        sk = np.asarray(Image.fromarray((ink * 255).astype(np.uint8), "L").resize((W, H), Image.Resampling.BILINEAR),
                        dtype=np.float32) / 255.0
        model = self.model_of(r)
        if stage.framing == "anchor":
            mk = draw(model, stage_view(stage, model, (W, H)), EXACT_STYLE, stage.host_box())
        else:
            own = draw(model, stage_view(stage, model, (512, 512)), EXACT_STYLE, stage.host_box())
            sm, mdx, mdy = fit_transform(own)
            ss, sdx, sdy = fit_transform(sk)
            # model canvas -> input -> sketch canvas: p_s = (sm * p_m + dm - ds) / ss
            a = sm / ss
            inv = (1 / a, 0.0, -((mdx - sdx) / ss) / a, 0.0, 1 / a, -((mdy - sdy) / ss) / a)
            img = Image.fromarray((own * 255).astype(np.uint8), "L")
            mk = np.asarray(img.transform((W, H), Image.Transform.AFFINE, inv, Image.Resampling.BILINEAR),
                            dtype=np.float32) / 255.0
        rgb = np.ones((H, W, 3), dtype=np.float32)
        rgb -= sk[..., None] * 0.55
        red = np.array([0.85, 0.1, 0.1], dtype=np.float32)
        a = np.clip(mk, 0, 1)[..., None]
        rgb = rgb * (1 - a) + red * a
        out = Image.fromarray(np.clip(rgb * 255, 0, 255).astype(np.uint8), "RGB")
        if path is not None:
            from grammarkit.geometry.render import save_image

            save_image(out, path)
        return out

    def canvas(self, object_type: str, path: Any = None, size: int | None = None) -> Any:
        """A blank canvas of a type: the anchor's outline in light grey, where to draw."""
        from PIL import Image

        tm = self.models.type_model(object_type)
        stage = tm.stage
        W, H = stage.canvas_size()
        if size:
            k = size / max(W, H)
            W, H = int(round(W * k)), int(round(H * k))
        rgb = np.ones((H, W, 3), dtype=np.float32)
        outline = anchor_outline(stage, (W, H))
        rgb -= outline[..., None] * 0.25
        out = Image.fromarray(np.clip(rgb * 255, 0, 255).astype(np.uint8), "RGB")
        if path is not None:
            from grammarkit.geometry.render import save_image

            save_image(out, path)
        return out


def anchor_outline(stage: StageSpec, size: tuple[int, int]) -> np.ndarray:
    """Ink of the anchor's outline (the host block's visible edges) on a stage canvas."""
    from PIL import Image, ImageDraw

    W, H = size
    img = Image.new("L", (W, H), 0)
    box = stage.host_box()
    if stage.framing == "fit" or box is None:
        w, d = stage.anchor_size  # the lot, seen from the stage camera framed on itself
        pts = np.array([(0, 0, 0), (w, 0, 0), (w, d, 0), (0, d, 0)], float)
        view = stage.camera().resolve(np.vstack([pts, pts + (0, 0, max(w, d))]), (W, H))
        loops = [pts]
    else:
        view = stage.camera().resolve(stage.frame_points(), (W, H))
        w, d = stage.anchor_size
        if stage.anchor_kind == "top":
            z = stage.host_height
            loops = [np.array([(0, 0, z), (w, 0, z), (w, d, z), (0, d, z)], float)]
        else:
            x0, z0 = stage.anchor_origin()
            loops = [np.array([(x0, 0, z0), (x0 + w, 0, z0), (x0 + w, 0, z0 + d), (x0, 0, z0 + d)], float)]
    draw_ = ImageDraw.Draw(img)
    for loop in loops:
        px = view.to_pixels(loop)
        draw_.line([tuple(p) for p in px.tolist()] + [tuple(px[0].tolist())], fill=255, width=2)
    return np.asarray(img, dtype=np.float32) / 255.0


# ------------------------------------------------------------------------------------------
_lock = threading.Lock()
_models: dict[tuple, SketchModels] = {}  # (resolved path, mtime) -> loaded models
_recognizers: dict[tuple, Recognizer] = {}  # (id of models, library hash) -> recognizer


def get_recognizer(models: Any = None, library: Any = None) -> Recognizer:
    """A (cached) Recognizer: `models` a path or SketchModels (default: the shipped weights),
    `library` a path, text or SnippetLibrary (default: the library the models embed)."""
    from .embedded import embedded_library
    from .models import SHIPPED

    if isinstance(models, SketchModels):
        m = models
    else:
        p = Path(models) if models is not None else SHIPPED
        try:
            key = (str(p.resolve()), p.stat().st_mtime_ns)
        except OSError:
            key = None
        with _lock:
            m = _models.get(key) if key else None
        if m is None:
            m = load_models(models)
            if key:
                with _lock:
                    if len(_models) > 8:
                        _models.clear()
                    _models[key] = m
    lib = embedded_library(m) if library is None else load_library(library)
    rkey = (id(m), lib.hash, lib.path)
    with _lock:
        rec = _recognizers.get(rkey)
    if rec is None or rec.models is not m:
        rec = Recognizer(m, lib)
        with _lock:
            if len(_recognizers) > 8:
                _recognizers.clear()
            _recognizers[rkey] = rec
    return rec


def recognize(image: Any, object_type: str, *, models: Any = None, library: Any = None,
              refine: int = 0, method: str = "pattern", snippet: str | None = None,
              seed: int = 0, score: str = "chamfer", view_range: float = VIEW_RANGE,
              prior: bool = True, rectify: bool = True, rerank: bool = False) -> Recognition:
    """Recognise a sketch of one object type.

    image:   a path, a PIL image or an array (dark lines on light paper). An object type with
             anchor framing needs the type's canvas aspect ratio (`Recognizer.canvas`).
    models:  a models file (default: the weights shipped for grammars/library.grammar).
    library: the snippet library (default: the copy embedded in the models file). A library
             that differs from the one trained on is refused ("retrain").
    refine:  refinement steps; `method` "pattern" (line scans + compass search, the default),
             "greedy" (Nishida's code) or "metropolis" (the paper).
    score:   "chamfer" (truncated symmetric chamfer distance, the default), "pen" (the same
             with the proposals drawn in the sketch's own line width: a felt pen's band costs
             nothing) or "paper" (exp(-RMS(D(render) - D(sketch))), the paper's equation 1).
    rerank:  with refinement, fit each class at least 0.05 likely (of the top 3) and answer the
             one whose refined model matches the sketch best (analysis by synthesis).
    view_range: degrees the refinement may turn the view to fit the sketch's perspective.
    prior:   "pattern" maximises the score times a Gaussian prior around the network's estimate
             (as wide as the regressor's validation RMSE); False: the score alone.
    snippet: skip the classifier and estimate this snippet's parameters.
    rectify: undo a turn of the page (a few degrees) on stages seen straight on before the
             networks see the drawing (rectify.py); False feeds it as drawn (the paper).
    """
    rec = get_recognizer(models, library)
    return rec.recognize(image, object_type, refine_steps=refine, method=method, snippet=snippet, seed=seed,
                         score=score, view_range=view_range, prior=prior, rectify=rectify, rerank=rerank)


__all__ = ["Candidate", "ModelFileError", "Recognition", "Recognizer", "get_recognizer", "recognize",
           "render_input"]
