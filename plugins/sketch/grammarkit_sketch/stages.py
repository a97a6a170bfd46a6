"""Stages: for each object type, the anchor a snippet is drawn on, the fixed camera, and the canvas.

Nishida et al. 2016 (s. 5.3) fix the view per object type: the building mass and the roof are
seen from theta = 30 deg about X and phi = 45 deg about Z (here `pitch=30, yaw=-45`, fov 45, the
renderer's `Camera.nishida()`), facade-like types straight on (`pitch=0`, perpendicular to the
anchor face), ledges from phi = rho - 72 deg (`yaw=-72`) so that their profile shows. The camera
is placed so that the anchor is centred on the canvas.

How the picture is framed:
- "anchor" framing (roofs, facades, floors, windows, ledges): the camera frames a box around the
  anchor (the anchor face plus room for what snippets of the type build on it), so the scale of
  the drawing is fixed by the anchor: a 1 m overhang is 1 m whatever the sketch shows. The
  canvas has the aspect ratio of that box; a sketch must be drawn on such a canvas.
- "fit" framing (the mass, the first stage, which stands on an empty lot): the sketch may be
  drawn anywhere at any size; the drawn extent is cropped and scaled to the network input, and
  the lot (a fixed footprint) gives the scale. This replaces the paper's sampling of positions
  on the ground plane.

Every stage is derived on a *host*: the lot (ground), a block whose top face is the anchor
(top), or a wall slab whose front face is the anchor (face). The host hides what lies behind it
but is not drawn: only what the snippet builds is (an edge is drawn when one of its faces
does not lie on the host block's surface). On face stages, the object types downstream of the
snippet (a facade's floors and ledges, a floor's windows) are drawn as thin inset panels, the
rectangles a person draws to subdivide a facade (the paper's repetition strokes, s. 6.2).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any, Mapping

import numpy as np

from grammarkit.errors import GrammarError

from .library import SnippetInfo, SnippetLibrary

HOST_COLOR = "#c8c8c8"
PANEL_DEPTH = 0.03  # downstream-anchor panels: thin enough not to change the silhouette
#: longest canvas side used for training renders (then reduced to the network input)
CANVAS = 256


@dataclass(frozen=True)
class StageSpec:
    """The fixed view and canonical anchor of one object type (stored in the models file)."""

    object_type: str
    anchor_kind: str  # "ground" | "top" | "face"
    anchor_size: tuple[float, float]  # lot (w, d) | top face (w, d) | face (w, h), metres
    pitch: float
    yaw: float
    fov: float = 45.0
    framing: str = "anchor"  # "anchor" | "fit"
    # room around the anchor in the framed box, metres: sideways, below, above, in front
    side: float = 0.3
    below: float = 0.3
    above: float = 0.3
    protrude: float = 0.5
    above_rel: float = 0.0  # extra room above, as a fraction of the anchor's smaller side
    below_rel: float = 0.0
    anchor_index: int = 0  # split.index the anchor face carries (floor_balcony reads it)
    wall: float = 0.0  # host wall left around a face anchor (a window sits in a wall)
    # frame only this many metres at the anchor's +x end (ledges: their profile, seen from the
    # side, would be a few pixels if the whole facade-wide strip were framed); 0: all of it
    frame_length: float = 0.0
    host_height: float = 18.0  # height of the block under a top anchor

    def to_dict(self) -> dict:
        d = asdict(self)
        d["anchor_size"] = list(self.anchor_size)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "StageSpec":
        d = dict(d)
        d["anchor_size"] = tuple(float(v) for v in d["anchor_size"])
        return cls(**d)

    def with_anchor(self, size: tuple[float, float]) -> "StageSpec":
        return replace(self, anchor_size=(float(size[0]), float(size[1])))

    # -- geometry of the framed box -----------------------------------------------------
    def frame_points(self) -> np.ndarray:
        """Corners of the box the camera frames, world coordinates (see `host_text`)."""
        w, d = self.anchor_size
        if self.anchor_kind == "top":
            small = min(w, d)
            z0 = self.host_height - self.below - self.below_rel * small
            z1 = self.host_height + self.above + self.above_rel * small
            lo = (-self.side, -self.side, z0)
            hi = (w + self.side, d + self.side, z1)
        elif self.anchor_kind == "face":
            ax, az = self.anchor_origin()
            x0 = ax + max(0.0, w - self.frame_length) if self.frame_length > 0 else ax
            lo = (x0 - self.side, -self.protrude, az - self.below)
            hi = (ax + w + self.side, 0.0, az + d + self.above)
        else:  # ground: the lot and a nominal height (only used for the canvas aspect)
            lo, hi = (0.0, 0.0, 0.0), (w, d, max(w, d))
        xs, ys, zs = zip(lo, hi)
        return np.array([(x, y, z) for x in xs for y in ys for z in zs], dtype=float)

    def anchor_origin(self) -> tuple[float, float]:
        """(x, z) of a face anchor's lower left corner on the host slab's front (y = 0)."""
        h = self.anchor_size[1]
        return self.wall, self.wall + self.anchor_index * h

    def host_box(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(lo, hi) corners of the host block (None on the ground: there is no host)."""
        w, d = self.anchor_size
        if self.anchor_kind == "top":
            return np.zeros(3), np.array([w, d, self.host_height])
        if self.anchor_kind == "face":
            return np.zeros(3), np.array([w + 2 * self.wall, 1.0,
                                          d * (self.anchor_index + 1) + 2 * self.wall])
        return None

    def camera(self):  # noqa: ANN201 - grammarkit Camera
        from grammarkit.geometry.render import Camera

        return Camera(pitch=self.pitch, yaw=self.yaw, fov=self.fov)

    def aspect(self) -> float:
        """Width / height of the framed box as seen by the camera (1 for fit framing)."""
        if self.framing == "fit":
            return 1.0
        pts = self.frame_points()
        view = self.camera().resolve(pts, (1000, 1000))
        px = view.to_pixels(pts)
        span = px.max(axis=0) - px.min(axis=0)
        aspect = float(span[0] / max(span[1], 1e-9))
        return min(max(aspect, 1 / 6), 6.0)

    def canvas_size(self) -> tuple[int, int]:
        """Canvas (width, height) of training renders: the framed box's aspect ratio, the
        longer side CANVAS pixels, the shorter at least CANVAS / 2 (the network input is
        square: an elongated canvas is squeezed along its long side, never stretched)."""
        a = self.aspect()
        long_side = max(CANVAS, int(round(CANVAS / 2 * max(a, 1 / a))))
        short = max(CANVAS // 2, int(round(long_side / max(a, 1 / a))))
        long_side, short = 4 * round(long_side / 4), 4 * round(short / 4)
        return (long_side, short) if a >= 1 else (short, long_side)

    def view(self, size: tuple[int, int] | None = None, geometry: Any = None):  # noqa: ANN201
        """The resolved camera for a canvas: framed on the anchor box, or (fit framing) on the
        drawn geometry's vertices."""
        size = size or self.canvas_size()
        if self.framing == "fit":
            pts = geometry if geometry is not None else self.frame_points()
            return self.camera().resolve(pts, size)
        return self.camera().resolve(self.frame_points(), size)

    # -- the host grammar ---------------------------------------------------------------
    def host_text(self) -> str:
        """Rules deriving the host and handing the anchor to `SketchAnchor` (axiom `SketchLot`).

        The host keeps its volume (`volume: SketchHost.`): comp(f) consumes the volume it
        decomposes, and windows and ledges are recessed into / extruded from a solid host."""
        host = f'color("{HOST_COLOR}")'
        if self.anchor_kind == "ground":
            return "SketchLot --> SketchAnchor"
        if self.anchor_kind == "top":
            return (f"SketchLot --> {host} extrude({self.host_height:g}) comp(f) "
                    "{ top: SketchAnchor | side: SketchHost. | bottom: NIL | volume: SketchHost. }")
        w, h = self.anchor_size
        m = self.wall
        # the anchor is part `anchor_index` of a vertical split (floors below it are host);
        # a wall margin is split off around the whole column
        parts = [f"{h:g}: SketchHost."] * self.anchor_index + [f"{h:g}: SketchAnchor"]
        lines = [f"SketchLot --> {host} extrude({h * (self.anchor_index + 1) + 2 * m:g}) comp(f) "
                 "{ front: SketchFront | back: SketchHost. | side: SketchHost. | top: SketchHost. "
                 "| bottom: NIL | volume: SketchHost. }"]
        if m > 0:
            lines += [f"SketchFront --> split(x) {{ {m:g}: SketchHost. | ~1: SketchMiddle | {m:g}: SketchHost. }}",
                      f"SketchMiddle --> split(y) {{ {m:g}: SketchHost. | ~1: SketchColumn | {m:g}: SketchHost. }}",
                      f"SketchColumn --> split(y) {{ {' | '.join(parts)} }}"]
        else:
            lines.append(f"SketchFront --> split(y) {{ {' | '.join(parts)} }}")
        return "\n".join(lines)

    def lot(self) -> list[tuple[float, float]]:
        w, d = self.anchor_size
        if self.anchor_kind == "face":
            w, d = w + 2 * self.wall, 1.0  # wall slab thickness: deeper than any recess
        return [(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)]


# Canonical stages of the object types of grammars/library.grammar (and of any library using
# these type names). Sizes follow the library's defaults: a 16 x 12 m lot, an 18 m mass, 3.2 m
# floors, 1.2 x 1.8 m windows, a 0.6 m cornice.
KNOWN_STAGES: dict[str, dict[str, Any]] = {
    "Mass": dict(anchor_kind="ground", anchor_size=(16.0, 12.0), pitch=30.0, yaw=-45.0, framing="fit"),
    "Roof": dict(anchor_kind="top", anchor_size=(16.0, 12.0), pitch=30.0, yaw=-45.0, side=1.2,
                 below=0.0, below_rel=0.12, above=0.5, above_rel=0.9),
    "Facade": dict(anchor_kind="face", anchor_size=(16.0, 18.0), pitch=0.0, yaw=0.0, protrude=0.3),
    "Floor": dict(anchor_kind="face", anchor_size=(16.0, 3.2), pitch=0.0, yaw=0.0, protrude=1.3,
                  anchor_index=2),
    "Window": dict(anchor_kind="face", anchor_size=(1.2, 1.8), pitch=0.0, yaw=0.0, side=0.15,
                   below=0.15, above=0.15, protrude=0.35, wall=0.5),
    "Ledge": dict(anchor_kind="face", anchor_size=(16.0, 0.6), pitch=0.0, yaw=-72.0, side=0.3,
                  below=0.3, above=1.3, protrude=1.5, frame_length=3.0),
}
_BY_KIND: dict[str, dict[str, Any]] = {
    "ground": KNOWN_STAGES["Mass"],
    "top": KNOWN_STAGES["Roof"],
    "face": dict(anchor_kind="face", anchor_size=(4.0, 3.0), pitch=0.0, yaw=0.0, protrude=1.0),
}


def default_stage(library: SnippetLibrary, object_type: str) -> StageSpec:
    """The stage of a type: the known settings for the library's type names, else by how the
    library anchors the type (ground / top face / face)."""
    kind = library.anchor_kinds[object_type]
    base = KNOWN_STAGES.get(object_type)
    if base is None or base["anchor_kind"] != kind:
        base = _BY_KIND[kind]
    return StageSpec(object_type=object_type, **base)


def _panel_rules(library: SnippetLibrary, skip: str) -> list[str]:
    """Stand-ins for the anchors downstream of a snippet: a thin inset panel per leaf, so that
    a facade's floors or a floor's windows show as the rectangles one would draw."""
    out = []
    for t in library.types:
        if t == skip:
            continue
        inset = "min(0.05, 0.12 * min(scope.sx, scope.sy))"
        out.append(f"{t} --> offset(-{inset}) {{ inside: extrude({PANEL_DEPTH}) "
                   f"color(\"#8a8a8a\") {t}Panel. | border: NIL }}")
    return out


def stage_grammar(library: SnippetLibrary, stage: StageSpec, snippet: SnippetInfo):
    """The grammar that derives `snippet` on the stage's host (axiom `SketchLot`)."""
    import grammarkit

    t = stage.object_type
    # Panels only subdivide faces: on a mass they would just retrace its outline.
    panels = _panel_rules(library, t) if stage.anchor_kind == "face" else []
    text = "\n".join(["grammar sketch_stage", stage.host_text(), f"SketchAnchor --> {t}",
                      *panels, f"use {snippet.name} as {t}", ""])
    host = grammarkit.parse(text)
    # the library's snippets (not its defaults: unbound downstream anchors get the panels)
    return host.model_copy(update={"statements": tuple(library.grammar.snippets) + host.statements,
                                   "source_path": library.grammar.source_path})


class StageDeriver:
    """Derives snippet instances on a stage, with the stage grammar compiled once per snippet."""

    def __init__(self, library: SnippetLibrary, stage: StageSpec):
        self.library = library
        self.stage = stage
        self._grammars: dict[str, Any] = {}

    def grammar(self, snippet: str):  # noqa: ANN201
        g = self._grammars.get(snippet)
        if g is None:
            info = self.library.snippets[snippet]
            if info.object_type != self.stage.object_type:
                raise GrammarError(f"snippet {snippet!r} is a {info.object_type}, not a "
                                   f"{self.stage.object_type}", None, code="sketch-wrong-type")
            g = self._grammars[snippet] = stage_grammar(self.library, self.stage, info)
        return g

    def derive(self, snippet: str, values: Mapping[str, float] | None = None, seed: int = 0):  # noqa: ANN201
        """The derived stage model for the snippet with attr `values` (by attr name)."""
        from grammarkit.split import derive

        t = self.stage.object_type
        attrs = {f"{t}.{k}": v for k, v in (values or {}).items()}
        return derive(self.grammar(snippet), seed=seed, attrs=attrs, lot=self.stage.lot(),
                      start="SketchLot")


def stage_for(stages: Mapping[str, StageSpec], object_type: str) -> StageSpec:
    try:
        return stages[object_type]
    except KeyError:
        raise GrammarError(f"no stage for object type {object_type!r}", None) from None


