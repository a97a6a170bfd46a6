"""Line drawings of stage models (training sketches, refinement proposals, previews) and the
drawing styles used to train and to test robustness.

The renderer (grammarkit.geometry.render) draws every feature edge of what it is given. Here
the host (see stages.py) must hide what lies behind it without being drawn, so the prepared
geometry's edge list is filtered: an edge is kept when at least one of its two triangles does
not lie on the host block's surface. (Membership is decided by geometry, not by colour: face
terminals only paint whole triangles of the surface they lie on, so colours would follow the
host's triangulation rather than the snippet's shapes.) Colour boundaries are not drawn for
the same reason: a sketch shows shapes. Dropping a random share of the remaining edges gives
the "missing strokes" style.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np


#: drawing styles: "sketchy" is the paper's training style (hand-drawn polylines), "plain"
#: the exact line drawing (the paper's Table 3 baseline); the others are robustness tests
#: never trained on.
STYLES = ("sketchy", "plain", "jitter", "missing", "overdrawn", "thick", "perspective",
          "rotated", "partial")
PERTURBATIONS = ("rotated", "perspective", "partial")


@dataclass(frozen=True)
class DrawStyle:
    """Pen settings of one drawing. Sizes are pixels of a 256 x 256 canvas; on another
    canvas they scale with its shorter side (the side the network input does not squeeze)."""

    sketchy: bool = True
    width: float = 2.0
    jitter: float = 1.2
    overshoot: float = 5.0
    strokes: int = 2
    missing: float = 0.0  # share of edges left out
    seed: int = 0
    pitch_offset: float = 0.0  # a slightly wrong perspective (degrees)
    yaw_offset: float = 0.0
    rotation: float = 0.0  # the drawing turned on the page (degrees; augment.rotate_ink)
    partial: float = 0.0  # share of the ink cut out in gaps (augment.break_strokes)

    def line_style(self, scale: float = 1.0):  # noqa: ANN201
        from grammarkit.geometry.render import LineStyle

        return LineStyle(width=max(0.5, self.width * scale), sketchy=self.sketchy, material_edges=False,
                         jitter=self.jitter * scale, overshoot=self.overshoot * scale,
                         strokes=self.strokes if self.sketchy else 1, seed=self.seed)


def training_style(rng: np.random.Generator, kind: str = "sketchy") -> DrawStyle:
    """A random pen for a training image: sketchy lines of varied width, wobble, overshoot and
    passes (from nearly clean to shaky), or the plain line drawing; the view may be off by up
    to 2 degrees (people do not draw exact perspective). "augmented": the sketchy pen with the
    view off by up to 6 degrees, the page turned by up to 6 degrees, and in 40% of the
    drawings 5-30% of the ink cut out (partial strokes)."""
    seed = int(rng.integers(0, 2**31 - 1))
    width = float(rng.uniform(1.0, 3.5))
    pitch, yaw = (float(v) for v in rng.uniform(-2.0, 2.0, 2))
    if kind == "plain":
        return DrawStyle(sketchy=False, width=width, seed=seed, pitch_offset=pitch, yaw_offset=yaw)
    pen = DrawStyle(sketchy=True, width=width, jitter=float(rng.uniform(0.3, 2.0)),
                    overshoot=float(rng.uniform(1.0, 7.0)), strokes=int(rng.integers(1, 4)),
                    seed=seed, pitch_offset=pitch, yaw_offset=yaw)
    if kind == "augmented":  # issue 30: page turned, perspective off, strokes broken off
        from .augment import MAX_PARTIAL, MAX_PERSPECTIVE, MAX_ROTATION

        p2, y2, rot = (float(v) for v in rng.uniform(-1.0, 1.0, 3))
        partial = float(rng.uniform(0.05, MAX_PARTIAL)) if rng.random() < 0.4 else 0.0
        return replace(pen, pitch_offset=p2 * MAX_PERSPECTIVE, yaw_offset=y2 * MAX_PERSPECTIVE,
                       rotation=rot * MAX_ROTATION, partial=partial)
    return pen


def test_style(kind: str, rng: np.random.Generator) -> DrawStyle:
    """Held-out drawing styles: the trained one with new seeds, or one never trained on.

    "PEN+PERTURBATION" (e.g. "thick+rotated") draws with the pen of style PEN and the page
    turn, perspective error or broken strokes of style PERTURBATION ("rotated",
    "perspective", "partial"): the robustness tests on pens no training augmentation used."""
    if "+" in kind:
        pen, _, perturbation = kind.partition("+")
        if perturbation not in PERTURBATIONS or pen not in STYLES:
            raise ValueError(f"unknown drawing style {kind!r}; expected PEN+PERTURBATION with PEN one "
                             f"of {', '.join(STYLES)} and PERTURBATION one of {', '.join(PERTURBATIONS)}")
        drawn = test_style(pen, rng)
        moved = test_style(perturbation, rng)
        return replace(drawn, rotation=moved.rotation, partial=moved.partial,
                       pitch_offset=moved.pitch_offset, yaw_offset=moved.yaw_offset)
    base = training_style(rng, "sketchy")
    if kind == "sketchy":
        return base
    if kind == "plain":
        return training_style(rng, "plain")
    if kind == "jitter":  # a shakier hand: twice the largest trained wobble
        return replace(base, jitter=4.0, overshoot=10.0)
    if kind == "missing":  # a quarter of the edges not drawn
        return replace(base, missing=0.25)
    if kind == "overdrawn":  # every edge gone over five times
        return replace(base, strokes=5, jitter=2.0)
    if kind == "thick":  # a felt pen: twice the widest trained line
        return replace(base, width=7.0)
    if kind == "rotated":  # the page turned by 3-5 degrees
        return replace(base, rotation=float(rng.choice([-1.0, 1.0]) * rng.uniform(3, 5)))
    if kind == "partial":  # strokes that stop short: 15-30% of the ink cut out in gaps
        return replace(base, partial=float(rng.uniform(0.15, 0.3)))
    if kind == "perspective":  # the view off by 3-6 degrees (trained: up to 2)
        sign = rng.choice([-1.0, 1.0], size=2)
        return replace(base, pitch_offset=float(sign[0] * rng.uniform(3, 6)),
                       yaw_offset=float(sign[1] * rng.uniform(3, 6)))
    raise ValueError(f"unknown drawing style {kind!r}; expected one of {', '.join(STYLES)}")


def on_box_surface(vertices: np.ndarray, faces: np.ndarray, box: tuple[np.ndarray, np.ndarray] | None,
                   tol: float = 2e-3) -> np.ndarray:
    """For each triangle: does it lie in one face of the axis-aligned box (within `tol`)?"""
    if box is None or len(faces) == 0:
        return np.zeros(len(faces), dtype=bool)
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    tri = vertices[faces]  # (F, 3, 3)
    inside = ((tri >= lo - tol) & (tri <= hi + tol)).all(axis=(1, 2))
    flat = np.zeros(len(faces), dtype=bool)
    for axis in range(3):
        for plane in (lo[axis], hi[axis]):
            flat |= (np.abs(tri[:, :, axis] - plane) <= tol).all(axis=1)
    return inside & flat


def drawable_geometry(model: Any, host_box: Any = None, missing: float = 0.0, seed: int = 0):  # noqa: ANN201
    """The prepared geometry of a stage model without the host block's own edges (and, for the
    "missing strokes" style, without a random share of the others)."""
    from grammarkit.geometry.render import prepare

    geom = prepare(model)
    host = on_box_surface(geom.vertices, geom.faces, host_box)
    f1, f2 = geom.edge_faces[:, 0], geom.edge_faces[:, 1]
    keep = ~(host[f1] & np.where(f2 >= 0, host[np.maximum(f2, 0)], True))
    if missing > 0:
        rng = np.random.default_rng(seed ^ 0x4D15)
        keep &= rng.random(len(keep)) >= missing
    idx = np.flatnonzero(keep)
    return replace(geom, edges=geom.edges[idx], edge_faces=geom.edge_faces[idx],
                   edge_angle=geom.edge_angle[idx], edge_material=geom.edge_material[idx],
                   edge_open=geom.edge_open[idx])


def draw(model: Any, view: Any, style: DrawStyle, host_box: Any = None, *,
         supersample: int = 2) -> np.ndarray:
    """Ink image (float32, H x W, 1 = black line) of a stage model seen through `view`."""
    from grammarkit.geometry.render import render

    geom = drawable_geometry(model, host_box, style.missing, style.seed)
    scale = min(view.size) / 256.0
    img = render(geom, view, style="lines", size=view.size, line_style=style.line_style(scale),
                 supersample=supersample)
    ink = 1.0 - np.asarray(img.convert("L"), dtype=np.float32) / 255.0
    if style.rotation or style.partial:
        from .augment import break_strokes, rotate_ink

        ink = rotate_ink(ink, style.rotation)
        if style.partial:
            ink = break_strokes(ink, np.random.default_rng([style.seed, 0x9A27]), style.partial)
    return ink


def strokes_to_ink(strokes: Any, size: tuple[int, int], width: float = 2.0) -> np.ndarray:
    """Rasterise polylines (lists of (x, y) in canvas pixels) into an ink image."""
    from PIL import Image, ImageDraw

    W, H = size
    img = Image.new("L", (W, H), 0)
    d = ImageDraw.Draw(img)
    w = max(1, int(round(width)))
    for line in strokes:
        pts = [(float(x), float(y)) for x, y in line]
        if len(pts) == 1:
            x, y = pts[0]
            d.ellipse([x - w / 2, y - w / 2, x + w / 2, y + w / 2], fill=255)
        elif pts:
            d.line(pts, fill=255, width=w, joint="curve")
    return np.asarray(img, dtype=np.float32) / 255.0


def _feature_edges(geom: Any, front: np.ndarray, crease_angle: float = 30.0) -> np.ndarray:
    """Silhouette, crease and boundary edges (as the renderer's line style draws them)."""
    f1, f2 = geom.edge_faces[:, 0], geom.edge_faces[:, 1]
    both = f2 >= 0
    fr1 = front[f1]
    fr2 = np.where(both, front[np.maximum(f2, 0)], fr1)
    want = geom.edge_open | (both & (fr1 != fr2)) | (both & (geom.edge_angle > crease_angle))
    hidden = geom.closed[f1] & ~fr1 & ~fr2
    return np.flatnonzero(want & ~hidden)


def model_strokes(model: Any, view: Any, host_box: Any = None, *, jitter: float = 0.0,
                  seed: int = 0, spacing: float = 1.0) -> list[list[tuple[float, float]]]:
    """The visible lines of a stage model as polylines of canvas pixels: what a person tracing
    the drawing would put in a session file. Each visible run of a feature edge becomes one
    stroke; `jitter` (pixels) moves its ends and bends it a little, like a hand would.

    Visibility is tested like the renderer does, at sample points every `spacing` pixels: a
    sample is visible when no face is drawn at its pixel (or a neighbour) or it is not behind
    the plane of the face drawn there.
    """
    from grammarkit.geometry.render import rasterize

    geom = drawable_geometry(model, host_box)
    raster = rasterize(geom, view)
    edges = _feature_edges(geom, raster.front)
    px, key = view.project(geom.vertices)
    W, H = view.size
    finite = key[np.isfinite(key)]
    tol = 1e-6 * (float(np.ptp(finite)) if finite.size else 1.0) + 1e-12
    rng = np.random.default_rng([seed, 17])
    out: list[list[tuple[float, float]]] = []
    for e in edges:
        a, b = geom.edges[e]
        p0, p1, k0, k1 = px[a], px[b], key[a], key[b]
        if not (np.isfinite(p0).all() and np.isfinite(p1).all()):
            continue
        n = max(2, int(np.ceil(np.hypot(*(p1 - p0)) / spacing)) + 1)
        t = np.linspace(0.0, 1.0, n)
        pos = p0[None] + (p1 - p0)[None] * t[:, None]
        sk = k0 + (k1 - k0) * t
        vis = np.zeros(n, dtype=bool)
        ix, iy = np.floor(pos[:, 0]).astype(int), np.floor(pos[:, 1]).astype(int)
        inside = (ix >= 0) & (ix < W) & (iy >= 0) & (iy < H)
        for dx in (0, -1, 1):
            for dy in (0, -1, 1):
                jx, jy = np.clip(ix + dx, 0, W - 1), np.clip(iy + dy, 0, H - 1)
                f = raster.face[jy, jx]
                pl = raster.plane[np.maximum(f, 0)]
                surface = pl[:, 0] * pos[:, 0] + pl[:, 1] * pos[:, 1] + pl[:, 2]
                vis |= inside & ((f < 0) | (sk <= surface + tol))
        # visible runs -> strokes
        runs = np.flatnonzero(np.diff(np.r_[0, vis.astype(int), 0]))
        for s, e2 in zip(runs[::2], runs[1::2]):
            if e2 - s < 2:
                continue
            pts = pos[s:e2]
            q = [pts[0], pts[len(pts) // 2], pts[-1]]
            if jitter > 0:
                d = q[-1] - q[0]
                nrm = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
                q = [q[0] + rng.normal(0, jitter, 2), q[1] + nrm * rng.normal(0, jitter * 0.7),
                     q[2] + rng.normal(0, jitter, 2)]
            out.append([(round(float(x), 2), round(float(y), 2)) for x, y in q])
    return out
