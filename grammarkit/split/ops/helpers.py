"""The bottom of grammarkit.split.ops: what several operations share (imports no operation).

- `operation(...)`: the registration written above an operation's body (ShapeML's
  REGISTER_SHAPE_OP): the spec the language checks against and the body that runs, in one place;
- `lazy_module(name)`: geometry libraries imported on first use, so that loading the specs (every
  `grammarkit check` does) stays free of numpy and manifold3d;
- argument checks (`number`, `axis_index`, `face_only`), child shapes from cross sections
  (`piece`), split's layout and the cut of a shape along an axis (`layout`, `split_geometry`),
  colours and rotations.
"""
from __future__ import annotations

import math
from functools import lru_cache
from importlib import import_module
from typing import Any, Callable

from ...dsl.binding import parse_color
from ...registry import OperationSpec
from ..shape import FACE, VOLUME, Shape

AXES = ("x", "y", "z")
AXIS = {"x": 0, "y": 1, "z": 2}
EPS = 1e-9


class LazyModule:
    """A module imported when one of its attributes is first read.

    Why: every operation module declares its spec beside its body, and the specs are read by
    `grammarkit check`, which must not pay for numpy and manifold3d. After the first read the
    module's names are copied onto this object, so later reads cost what a module's do."""

    def __init__(self, name: str) -> None:
        self.__dict__["_lazy_name"] = name

    def __getattr__(self, attr: str) -> Any:
        module = import_module(self.__dict__["_lazy_name"])
        self.__dict__.update(vars(module))
        return getattr(module, attr)


def lazy_module(name: str) -> Any:
    """`name` (absolute) imported on first use; see LazyModule."""
    return LazyModule(name)


manifold3d = lazy_module("manifold3d")
fp = lazy_module("grammarkit.geometry.footprints")


def operation(name: str, params: tuple = (), **fields: Any) -> Callable:
    """Register the decorated function as the built-in operation `name` (ShapeML's
    REGISTER_SHAPE_OP): `fn.spec` is its OperationSpec (params, block kind, selectors, doc);
    grammarkit.split.ops collects the specs in its table."""
    def register(fn: Callable) -> Callable:
        fn.spec = OperationSpec(name, tuple(params), apply=fn, **fields)  # type: ignore[attr-defined]
        return fn
    return register


def axis_index(value: Any) -> int:
    try:
        return AXIS[str(value)]
    except KeyError:
        raise ValueError(f"axis must be x, y or z, got {value!r}") from None


def number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} must be finite, got {v}")
    return v


def not_a_face(s: Shape, op: str, example: str = "a lot, or a face from comp(f)") -> str:
    """The message of a face operation given something else: a volume, or an open surface (a
    face a scope turn took out of its scope's xy plane, or an inserted open mesh)."""
    from ...geometry.surfaces import SurfaceMesh  # on the error path only: loading specs stays light

    if isinstance(s.solid, SurfaceMesh):
        return (f"{op}() needs a face ({example}), got an open surface: a face turned out of its "
                "scope's xy plane (rotateScope/r about an axis in its plane by other than a half "
                "turn; grammarkit's faces lie in that plane: turn it back, or align the scope "
                "with alignScopeToAxes/alignScopeToGeometry first) or an inserted open mesh")
    return f"{op}() needs a face ({example}), got a volume"


def face_only(s: Shape, op: str) -> None:
    if s.kind != FACE:
        raise ValueError(not_a_face(s, op, "e.g. from footprint() or comp(f)"))


def rect_or_poly(poly: Any, sx: float, sy: float) -> Any:
    """Keep `poly` only when it is not just the scope rectangle (the fast path)."""
    if poly is None:
        return None
    if len(poly) == 1 and fp.is_rectangle(poly[0], sx, sy, 1e-7):
        return None
    return poly


def piece(s: Shape, cs: Any, kind: str, extra_o: tuple[float, float] = (0.0, 0.0)) -> Shape | None:
    """A child shape from a CrossSection given in `s`'s scope coordinates (normalized bbox)."""
    contours = []
    for ring in cs.to_polygons():
        poly = tuple(map(tuple, ring.tolist()))
        if abs(fp.area(poly)) > 1e-9:
            contours.append(poly)
    if not contours:
        return None
    pts = [p for c in contours for p in c]
    x0 = min(p[0] for p in pts)
    y0 = min(p[1] for p in pts)
    x1 = max(p[0] for p in pts)
    y1 = max(p[1] for p in pts)
    shifted = tuple(tuple((x - x0, y - y0) for x, y in c) for c in contours)
    sx, sy = x1 - x0, y1 - y0
    o = s.world(x0 + extra_o[0], y0 + extra_o[1], 0.0)
    return s.derived(o, (sx, sy, s.sz[2] if kind == VOLUME else 0.0), rect_or_poly(shifted, sx, sy), kind)


def rect_section(x0: float, y0: float, x1: float, y1: float) -> Any:
    """The rectangle [x0, x1] x [y0, y1] as a manifold3d CrossSection."""
    return manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))


@lru_cache(maxsize=1024)
def hex_color(v: Any) -> str:
    color = parse_color(v)
    if color is None:
        raise ValueError(f"color must be '#rrggbb' or '#rgb', got {str(v).strip()!r}")
    return color


def rotation(rx: float, ry: float, rz: float) -> tuple:
    """Rotation matrix (rows) for XYZ Euler angles in degrees, applied x first."""
    cx, sx_ = math.cos(math.radians(rx)), math.sin(math.radians(rx))
    cy, sy_ = math.cos(math.radians(ry)), math.sin(math.radians(ry))
    cz, sz_ = math.cos(math.radians(rz)), math.sin(math.radians(rz))
    # R = Rz * Ry * Rx
    return (
        (cz * cy, cz * sy_ * sx_ - sz_ * cx, cz * sy_ * cx + sz_ * sx_),
        (sz_ * cy, sz_ * sy_ * sx_ + cz * cx, sz_ * sy_ * cx - cz * sx_),
        (-sy_, cy * sx_, cy * cx),
    )
