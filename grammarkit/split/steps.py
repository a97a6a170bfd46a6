"""The steps a compiled rule body is made of (grammarkit.split.compile builds them, the engine
runs them): a terminal, an operation call (its errors located at the call), a case and a
stochastic choice. Each is a closure `step(ctx, shape) -> shape | None`."""
from __future__ import annotations

import math
from typing import Any, Callable

from ..errors import GrammarkitError
from ..expr_eval import is_constant
from ..ir.base import Span
from .shape import Shape, fail
from .turned import TURNED_FACE_OPS, on_turned_faces


def block_is_fixed(items: tuple) -> bool:
    for it in items:
        if it.mode == "repeat":
            if not block_is_fixed(it.items):
                return False
        elif it.size is not None and not getattr(it.size, "_shape_free", False):
            return False
    return True


class Block(tuple):
    """The compiled slots of an operation block; `fixed` says whether every size is the same
    for all shapes of a derivation (then split layouts can be cached per length)."""

    fixed: bool = False


def make_block(slots: Any) -> Block:
    b = Block(slots)
    b.fixed = block_is_fixed(b)
    return b


def nil_step(ctx: Any, s: Any) -> None:
    return None


def terminal_step(name: str, last: bool) -> Callable:
    if last:
        def term_last(ctx: Any, s: Any) -> None:
            ctx.leaf(s, name)
            return None
        return term_last

    def term(ctx: Any, s: Any) -> Any:
        ctx.leaf(s.copy(), name)
        return s
    return term


def op_step(apply: Callable, fns: tuple, block: tuple | None, span: Span | None, name: str,
             plugin: str = "") -> Callable:
    const = [f(None) for f in fns] if all(is_constant(f) for f in fns) else None
    who = f"{name}() of plugin {plugin!r}" if plugin else f"{name}()"
    if name in TURNED_FACE_OPS and not plugin:
        apply = on_turned_faces(apply)  # also on a face a scope turn turned over (turned.py)

    def step(ctx: Any, s: Any) -> Any:
        try:
            # operations see the derivation's OperationContext only, never the Derivation
            r = apply(ctx.context, s, const if const is not None else [f(s) for f in fns], block)
        except GrammarkitError as exc:
            if exc.span is not None or span is None:
                raise
            # an error from a helper that knows no grammar location (a bad mesh file for i()):
            # same class, located at the operation
            raise type(exc)(f"in rule {s.rule.name!r} (shape #{s.node}): {who}: {exc}", span,
                            code=exc.diagnostics[0].code, hint=exc.diagnostics[0].hint) from None
        except (ValueError, TypeError, ArithmeticError, IndexError) as exc:
            msg = str(exc)
            raise fail(s, msg if msg.startswith(f"{name}(") and not plugin else f"{who}: {msg}",
                       span) from None
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - a plugin's operation crashed (or
            # called sys.exit): report it located, no traceback, no silent exit
            raise fail(s, f"{who} failed: {type(exc).__name__}: {exc}", span) from None
        if type(r) is list:
            # (shape, slot) pairs, or (shape, slot, index, total) when the operation numbers
            # its parts itself (comp: comp.index counts every face, not only the selected)
            if not all(type(c) is tuple and len(c) in (2, 4) and isinstance(c[0], Shape) for c in r):
                raise fail(s, f"{who} returned a list that is not of (shape, slot) pairs", span)
            ctx.spawn(s, r, name)
            return None
        if r is not None and not isinstance(r, Shape):
            raise fail(s, f"{who} returned {type(r).__name__} {_short(r)}, not a shape, a list of "
                       "(shape, slot) pairs or None", span)
        return r
    return step


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def case_step(arms: tuple, other: tuple | None) -> Callable:
    def case(ctx: Any, s: Any) -> Any:
        for cond, body in arms:
            if cond(s):
                return ctx.run_inline(s, body)
        if other is not None:
            return ctx.run_inline(s, other)
        return s
    return case


def choice_step(arms: tuple, other: tuple | None, span: Span | None) -> Callable:
    def choice(ctx: Any, s: Any) -> Any:
        u = s.rng().random() * 100.0
        acc = 0.0
        chosen = None
        for pct, body, aspan in arms:
            p = pct(s)
            if isinstance(p, bool) or not isinstance(p, (int, float)) or p < 0 or not math.isfinite(p):
                raise fail(s, f"a choice percentage must be a number >= 0, got {p!r}", aspan or span)
            acc += p
            if chosen is None and u < acc:
                chosen = body
        if acc > 100.0 + 1e-9:
            raise fail(s, f"choice percentages add up to {acc:g} > 100", span)
        if chosen is None:
            chosen = other
        if chosen is None:
            return s  # the remaining probability: no arm applies, the shape goes on unchanged
        return ctx.run_inline(s, chosen)
    return choice
