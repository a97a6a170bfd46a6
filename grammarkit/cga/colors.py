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
    return int(math.floor(min(1.0, max(0.0, c)) * 255.0 + 0.5))


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
        k = _bin("%", _bin("+", Num(value=n), _bin("/", h, Num(value=60.0), span), span), Num(value=6.0), span)
        w = Call(func="max", args=(zero, Call(func="min", args=(k, _bin("-", Num(value=4.0), k, span), one),
                                              span=span)), span=span)
        out.append(_bin("-", v, _bin("*", _bin("*", v, s, span), w, span), span))
    return tuple(out)
