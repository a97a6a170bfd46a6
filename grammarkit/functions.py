"""Built-in expression functions, registered through the plugin hook like any plugin's.

Functions are pure, except `rand`, which draws from the random generator that the
evaluator passes as `rng` (the shape's own seeded generator, so results are reproducible).
Footprint constructors (`rect`, `polygon`, `lshape`, `ushape`) return plain tuples of 2D
points: the DSL and the evaluator stay free of geometry; the split engine builds solids.
"""
from __future__ import annotations

import math
from typing import Any, Iterable

from .hookspecs import hookimpl
from .registry import FunctionSpec

Point = tuple[float, float]


def _rand(rng: Any, lo: float = 0.0, hi: float = 1.0) -> float:
    return float(lo + (hi - lo) * rng.random())


def _clamp(x: float, lo: float, hi: float) -> float:
    return max(lo, min(hi, x))


def rect(width: float, depth: float) -> tuple[Point, ...]:
    """Axis-aligned rectangle with a corner at the origin, counter-clockwise."""
    return ((0.0, 0.0), (width, 0.0), (width, depth), (0.0, depth))


def lshape(width: float, depth: float, wing_width: float, wing_depth: float) -> tuple[Point, ...]:
    """An L: a `width` x `wing_depth` bar along x plus a `wing_width` x `depth` bar along y."""
    return ((0.0, 0.0), (width, 0.0), (width, wing_depth), (wing_width, wing_depth),
            (wing_width, depth), (0.0, depth))


def ushape(width: float, depth: float, wing_width: float, base_depth: float) -> tuple[Point, ...]:
    """A U open towards +y: a base bar and two wings of `wing_width`."""
    return ((0.0, 0.0), (width, 0.0), (width, depth), (width - wing_width, depth),
            (width - wing_width, base_depth), (wing_width, base_depth), (wing_width, depth),
            (0.0, depth))


def polygon(*coords: float) -> tuple[Point, ...]:
    """`polygon(x1, y1, x2, y2, ...)`: a simple polygon from flat coordinates."""
    if len(coords) % 2 or len(coords) < 6:
        raise ValueError("polygon() needs an even number of coordinates, at least 3 points")
    return tuple((float(coords[i]), float(coords[i + 1])) for i in range(0, len(coords), 2))


BUILTIN_FUNCTIONS: tuple[FunctionSpec, ...] = (
    FunctionSpec("rand", 0, 2, "rand() in [0,1), rand(hi) in [0,hi), rand(lo, hi) in [lo,hi)", None),
    FunctionSpec("min", 1, None, "smallest argument", min),
    FunctionSpec("max", 1, None, "largest argument", max),
    FunctionSpec("floor", 1, 1, "round down", math.floor),
    FunctionSpec("ceil", 1, 1, "round up", math.ceil),
    FunctionSpec("round", 1, 1, "round half away from zero",
                 lambda x: math.floor(x + 0.5) if x >= 0 else -math.floor(-x + 0.5)),
    FunctionSpec("abs", 1, 1, "absolute value", abs),
    FunctionSpec("sqrt", 1, 1, "square root", math.sqrt),
    FunctionSpec("sin", 1, 1, "sine of degrees", lambda d: math.sin(math.radians(d))),
    FunctionSpec("cos", 1, 1, "cosine of degrees", lambda d: math.cos(math.radians(d))),
    FunctionSpec("tan", 1, 1, "tangent of degrees", lambda d: math.tan(math.radians(d))),
    FunctionSpec("clamp", 3, 3, "clamp(x, lo, hi)", _clamp),
    # conditional values (CGA's case and stochastic expressions); the evaluator evaluates only
    # the chosen argument (see expr_eval: LAZY_FUNCTIONS), so `select(x == 0, 0, 1 / x)` is safe
    FunctionSpec("select", 3, 3, "select(cond, a, b): a if cond holds, else b", None),
    FunctionSpec("pick", 2, None, "pick(u, p1, v1, p2, v2, ..., other): v_k for the first k with "
                 "u < p1 + ... + pk (percentages), else other; pick(rand(0, 100), 30, a, b)", None),
    FunctionSpec("rect", 2, 2, "rect(width, depth): rectangular footprint", rect),
    FunctionSpec("lshape", 4, 4, "lshape(width, depth, wing_width, wing_depth): L footprint", lshape),
    FunctionSpec("ushape", 4, 4, "ushape(width, depth, wing_width, base_depth): U footprint", ushape),
    FunctionSpec("polygon", 6, None, "polygon(x1, y1, x2, y2, ...): simple polygon footprint", polygon),
)

# `rand` needs the shape's generator; the evaluator binds it (see expr_eval).
RANDOM_FUNCTIONS = {"rand": _rand}


@hookimpl
def grammarkit_functions() -> Iterable[FunctionSpec]:
    return BUILTIN_FUNCTIONS
