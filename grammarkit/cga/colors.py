"""CGA's colour functions `colorRGBToHex(r, g, b)` and `colorHSVToHex(h, s, v)` as grammarkit
expressions: folded to a "#rrggbb" literal when the arguments are numbers, otherwise built from
grammarkit's own functions (min, max, floor, clamp, substring), so that `attr c =
colorHSVToHex(rand(20, 45), 0.5, 0.8)` still draws its colour at derive time.

CGA's definitions: r, g, b, s, v in [0, 1] (clamped), h in degrees; each channel becomes
round(255 * c) in two lower-case hex digits. HSV to RGB is the closed form
c(n) = v - v * s * max(0, min(k, 4 - k, 1)), k = (n + h / 60) mod 6, n = 5, 3, 1 for r, g, b
(the same values as the sector-by-sector definition, without a case per sector).
"""
from __future__ import annotations

import math

from ..ir import Binary, Call, Num, Str

HEX = "0123456789abcdef"
_HSV_N = (5.0, 3.0, 1.0)  # r, g, b


def _channel(c: float) -> int:
    return math.floor(min(1.0, max(0.0, c)) * 255.0 + 0.5)


def rgb_to_hex(r: float, g: float, b: float) -> str:
    return "#" + "".join(f"{_channel(c):02x}" for c in (r, g, b))


def hsv_to_rgb(h: float, s: float, v: float) -> tuple[float, float, float]:
    s, v = min(1.0, max(0.0, s)), min(1.0, max(0.0, v))
    out = []
    for n in _HSV_N:
        k = (n + h / 60.0) % 6.0
        out.append(v - v * s * max(0.0, min(k, 4.0 - k, 1.0)))
    return out[0], out[1], out[2]


def _bin(op: str, a, b, span):
    return Binary(op=op, left=a, right=b, span=span)


def _hex_digits(c, span):
    """Two hex digits of round(255 * clamp(c, 0, 1)), as a text expression."""
    n = Call(func="floor", args=(_bin("+", _bin("*", Call(func="clamp", args=(c, Num(value=0.0), Num(value=1.0)),
                                                         span=span), Num(value=255.0), span),
                                      Num(value=0.5), span),), span=span)
    hi = Call(func="floor", args=(_bin("/", n, Num(value=16.0), span),), span=span)
    lo = _bin("-", n, _bin("*", hi, Num(value=16.0), span), span)

    def digit(d):
        return Call(func="substring", args=(Str(value=HEX), d, _bin("+", d, Num(value=1.0), span)), span=span)
    return _bin("+", digit(hi), digit(lo), span)


def rgb_hex_expr(rgb: tuple, span=None):
    """The "#rrggbb" of three channel expressions (IR)."""
    if all(isinstance(c, Num) for c in rgb):
        return Str(value=rgb_to_hex(*(c.value for c in rgb)), span=span)
    out = Str(value="#", span=span)
    for c in rgb:
        out = _bin("+", out, _hex_digits(c, span), span)
    return out


def hsv_rgb_exprs(h, s, v, span=None) -> tuple:
    """The r, g, b expressions of h, s, v expressions (IR; numbers when all are numbers)."""
    if all(isinstance(x, Num) for x in (h, s, v)):
        return tuple(Num(value=c) for c in hsv_to_rgb(h.value, s.value, v.value))
    one, zero = Num(value=1.0), Num(value=0.0)
    s = Call(func="clamp", args=(s, zero, one), span=span)
    v = Call(func="clamp", args=(v, zero, one), span=span)
    out = []
    for n in _HSV_N:
        # grammarkit's % keeps the dividend's sign (fmod): ((x % 6) + 6) % 6 wraps a negative hue
        k = _bin("+", Num(value=n), _bin("/", h, Num(value=60.0), span), span)
        k = _bin("%", _bin("+", _bin("%", k, Num(value=6.0), span), Num(value=6.0), span), Num(value=6.0), span)
        w = Call(func="max", args=(zero, Call(func="min", args=(k, _bin("-", Num(value=4.0), k, span), one),
                                              span=span)), span=span)
        out.append(_bin("-", v, _bin("*", _bin("*", v, s, span), w, span), span))
    return tuple(out)


# -- colorHexToH / S / V: the hue (degrees), saturation and value of a "#rrggbb" text ----------

def hex_to_hsv(text: str) -> tuple[float, float, float] | None:
    t = text.strip().lstrip("#")
    if len(t) == 3:
        t = "".join(c * 2 for c in t)
    try:
        r, g, b = (int(t[i:i + 2], 16) / 255.0 for i in (0, 2, 4)) if len(t) == 6 else (None,) * 3
    except ValueError:
        return None
    if r is None:
        return None
    mx, mn = max(r, g, b), min(r, g, b)
    d = mx - mn
    if d == 0:
        h = 0.0
    elif mx == r:
        h = 60.0 * (((g - b) / d) % 6.0)
    elif mx == g:
        h = 60.0 * ((b - r) / d + 2.0)
    else:
        h = 60.0 * ((r - g) / d + 4.0)
    return h, (d / mx if mx > 0 else 0.0), mx


_DIGITS = HEX + HEX.upper()


def _hex_channel(c, i: int, span):
    """Channel i (0 r, 1 g, 2 b) of a "#rrggbb" text expression, in [0, 1]."""
    def digit(k):
        ch = Call(func="substring", args=(c, Num(value=float(k)), Num(value=float(k + 1))), span=span)
        return _bin("%", Call(func="findFirst", args=(Str(value=_DIGITS), ch), span=span), Num(value=16.0), span)
    hi, lo = digit(1 + 2 * i), digit(2 + 2 * i)
    return _bin("/", _bin("+", _bin("*", hi, Num(value=16.0), span), lo, span), Num(value=255.0), span)


def hex_hsv_expr(which: str, c, span=None):
    """colorHexToH/S/V of a text expression (IR): the channels parsed with substring and
    findFirst, the hue by the max channel (select)."""
    if isinstance(c, Str):
        hsv = hex_to_hsv(c.value)
        if hsv is not None:
            return Num(value=round(hsv["HSV".index(which)], 12))
    r, g, b = (_hex_channel(c, i, span) for i in range(3))
    mx = Call(func="max", args=(r, g, b), span=span)
    mn = Call(func="min", args=(r, g, b), span=span)
    d = _bin("-", mx, mn, span)
    if which == "V":
        return mx
    tiny = Num(value=1e-12)
    if which == "S":
        return _bin("/", d, Call(func="max", args=(mx, tiny), span=span), span)
    dd = Call(func="max", args=(d, tiny), span=span)

    def sel(cond, a, b_):
        return Call(func="select", args=(cond, a, b_), span=span)

    six = Num(value=6.0)
    h_r = _bin("%", _bin("+", _bin("%", _bin("/", _bin("-", g, b, span), dd, span), six, span), six, span), six, span)
    h_g = _bin("+", _bin("/", _bin("-", b, r, span), dd, span), Num(value=2.0), span)
    h_b = _bin("+", _bin("/", _bin("-", r, g, span), dd, span), Num(value=4.0), span)
    sector = sel(_bin("==", mx, r, span), h_r, sel(_bin("==", mx, g, span), h_g, h_b))
    return sel(_bin("<=", d, tiny, span), Num(value=0.0), _bin("*", Num(value=60.0), sector, span))


# The expressions above use each argument several times (a channel four times in its two hex
# digits, the hue six times): nested colour functions of computed values multiply. A result
# whose printed tree would exceed this many nodes is refused (a located warning) instead of
# being written out (one real rule nested colorHSVToHex(colorHexToH(c) - 190, ...): millions).
MAX_COLOR_NODES = 2000


def tree_size(node, memo=None) -> int:
    """Nodes of the expression as printed (shared sub-expressions counted each time they
    occur), computed on the shared graph in time linear in its distinct nodes."""
    memo = {} if memo is None else memo
    key = id(node)
    if key in memo:
        return memo[key]
    if isinstance(node, (list, tuple)):
        n = sum(tree_size(x, memo) for x in node)
    else:
        fields = getattr(node, "__dict__", None) or {}
        n = 1 + sum(tree_size(v, memo) for k, v in fields.items() if k != "span"
                    and not isinstance(v, (str, int, float, bool, type(None))))
    memo[key] = n
    return n
