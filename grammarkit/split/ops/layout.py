"""Split's layout (sizes along an axis: absolute, relative, floating, repeat groups) and the cut
of a shape between two positions along a scope axis; used by split, repeat and splitArea."""
from __future__ import annotations

import math
from typing import Any

from ..shape import Shape
from .helpers import EPS, fp, piece, rect_section


def layout(ctx: Any, s: Shape, items: tuple, length: float) -> list[tuple[Any, float, float]]:
    """Positions of split parts along an axis of `length`: a list of (slot, start, size).

    Absolute sizes are fixed, relative ones are fractions of the whole length, floating ones
    share what is left in proportion to their nominal sizes. Each repeat group takes the
    repetition count that best fits (rounding when the group can stretch, as many as fit when
    it cannot). When fixed parts do not fit, the part crossing the end is clipped and later
    parts are dropped; parts of size <= 0 are skipped.
    """
    flat: list[tuple[Any, bool, float]] = []
    _expand(ctx, s, items, length, length, flat)
    fixed = 0.0
    weight = 0.0
    for _, floating, v in flat:
        if floating:
            weight += v
        else:
            fixed += v
    rest = length - fixed
    k = rest / weight if (weight > 0 and rest > 0) else 0.0
    out = []
    pos = 0.0
    end = length + 1e-9
    for slot, floating, v in flat:
        size = v * k if floating else v
        if size <= EPS:
            continue
        if pos + size > end:
            size = length - pos
            if size > EPS:
                out.append((slot, pos, size))
            break
        out.append((slot, pos, size))
        pos += size
    return out


def _sizes(ctx: Any, s: Shape, items: tuple, total: float) -> list[tuple[Any, str, float]]:
    out = []
    for it in items:
        if it.mode == "repeat":
            out.append((it, "repeat", 0.0))
            continue
        v = it.size(s)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"split size must be a number, got {v!r}")
        if not math.isfinite(v):
            raise ValueError(f"split size must be finite, got {v!r}")
        if v < 0:
            # CGA makes no part for a negative size and lays out the rest as if it were not
            # there; so do we, but say so (it is almost always a mistake in the rule)
            where = f"{it.span}: " if getattr(it, "span", None) is not None else ""
            ctx.warn(f"{where}split size {v:g} is negative in rule {s.rule_name!r}: that part "
                     "is skipped (as in CGA)")
            v = 0.0
        if it.mode == "rel":
            v *= total
        out.append((it, it.mode, float(v)))
    return out


def _nominal(ctx: Any, s: Shape, items: tuple, total: float) -> tuple[float, bool]:
    """Length of one instance of a repeat group at nominal sizes, and whether it can stretch."""
    n = 0.0
    stretch = False
    for it, mode, v in _sizes(ctx, s, items, total):
        if mode == "repeat":
            m, st = _nominal(ctx, s, it.items, total)
            n += m
            stretch = stretch or st
        else:
            n += v
            stretch = stretch or mode == "float"
    return n, stretch


def _expand(ctx: Any, s: Shape, items: tuple, avail: float, total: float, flat: list) -> None:
    sized = _sizes(ctx, s, items, total)
    fixed = sum(v for _, mode, v in sized if mode in ("abs", "rel"))
    floating = sum(v for _, mode, v in sized if mode == "float")
    reps = [(it, *_nominal(ctx, s, it.items, total)) for it, mode, _ in sized if mode == "repeat"]
    counts: dict[int, int] = {}
    if reps:
        room = avail - fixed - floating
        nominal = sum(n for _, n, _ in reps)
        stretch = any(st for _, _, st in reps)
        if nominal <= EPS:
            raise ValueError("a repeat group needs a positive total size")
        ratio = room / nominal if room > 0 else 0.0
        n = int(math.floor(ratio + 0.5)) if stretch else int(math.floor(ratio + 1e-9))
        # CGA repeats zero times when the other parts of the block already fill the space
        # (`{ ~w: W | d: Wall }* | ~w: W` on 1.5 w is one W); a block that is nothing but
        # repeat groups still makes one instance (clipped), as CGA's `{ 2: A }*` on 1 does.
        if n < 1 and len(reps) == len(sized):
            n = 1
        n = max(n, 0)
        if n > ctx.limits.max_repeat:
            from ...errors import LimitError
            raise LimitError(
                f"repeat limit exceeded: {n} repetitions > {ctx.limits.max_repeat} "
                f"(in rule {s.rule_name!r}, length {avail:g} / group size {nominal:g})",
                reps[0][0].span, code="limit-repeat")
        for it, nom, _ in reps:
            counts[id(it)] = n
        share = {id(it): (max(room, 0.0) * nom / nominal / n if n else 0.0) for it, nom, _ in reps}
    for it, mode, v in sized:
        if mode == "repeat":
            for _ in range(counts[id(it)]):
                _expand(ctx, s, it.items, share[id(it)], total, flat)
        else:
            flat.append((it, mode == "float", v))


def split_geometry(s: Shape, a: int, start: float, size: float) -> Shape | None:
    ax = s.ax[a]
    o = (s.o[0] + ax[0] * start, s.o[1] + ax[1] * start, s.o[2] + ax[2] * start)
    sz = list(s.sz)
    sz[a] = size
    if s.solid is not None:
        normal = [0.0, 0.0, 0.0]
        normal[a] = 1.0
        trimmed = s.solid.trim_by_plane(tuple(normal), start)
        normal[a] = -1.0
        trimmed = trimmed.trim_by_plane(tuple(normal), -(start + size))
        shift = [0.0, 0.0, 0.0]
        shift[a] = -start
        trimmed = trimmed.translate(tuple(shift))
        if trimmed.is_empty():
            return None
        return s.derived(o, tuple(sz), None, s.kind, solid=trimmed)
    if s.poly is None or a == 2:
        return s.derived(o, tuple(sz), s.poly)
    x0, y0, x1, y1 = (start, 0.0, start + size, s.sz[1]) if a == 0 else (0.0, start, s.sz[0], start + size)
    cs = fp.cross_section(s.poly) ^ rect_section(x0, y0, x1, y1)
    if cs.is_empty():
        return None
    return piece(s, cs, s.kind)
