"""Attrs and consts: their values, fallbacks for CGA values grammarkit cannot express, @Range/@Enum."""
from __future__ import annotations

from typing import Any

from lark import Token, Tree

from ...expr_eval import NOT_CONSTANT, fold_constant
from ...functions import BUILTIN_FUNCTIONS
from ...ir import (
    Attr,
    Bool,
    Call,
    Const,
    Num,
    Str,
)
from ..expressions import (
    ExprContext,
    Untranslatable,
    children,
    translate_expr,
)
from .model import (
    ValueDef,
    literal,
    looks_like_string,
)

# the built-in functions by name, as fold_constant takes them (pure ones are folded)
_FOLD_FUNCTIONS = {spec.name: spec for spec in BUILTIN_FUNCTIONS}


def _fold_functions() -> dict:
    """The built-ins and the split engine's text, list and array functions (str(), listItem,
    cgaIndex: `Folder + "/trees.csv"` is folded with CGA's str() of the const). Imported
    lazily: grammarkit.split is not needed to read a .cga."""
    if "str" not in _FOLD_FUNCTIONS:
        from ...split.strings import STRING_FUNCTIONS

        _FOLD_FUNCTIONS.update({spec.name: spec for spec in STRING_FUNCTIONS})
    return _FOLD_FUNCTIONS


class ValuesMixin:
    """Translates attr and const declarations."""

    # -- attrs and consts -------------------------------------------------------------------------
    def _value(self, v: ValueDef) -> Any:
        gk = self.value_names[v.name]
        ctx = self._ctx("Y", {})
        status, feature, message = "translated", None, None
        try:
            value = translate_expr(v.value, ctx)
        except Untranslatable as exc:
            value, how = self._fallback_value(v.value, ctx)
            feature = exc.feature
            if how is not None:
                status, message = "approximated", f"{v.kind} {v.name}: {exc.message}; {how}"
            else:
                status = "dropped"
                value = Num(value=0) if not self._looks_text(v.value) else Str(value="")
                if any(a.children[0].value == "@Color" for a in v.annotations):
                    value = Str(value="#ffffff")  # a colour attr: CityEngine's default white
                shown = "0" if isinstance(value, Num) else f'"{value.value}"'
                message = f"{v.kind} {v.name}: {exc.message}; defined as {shown} instead"
        # a value that reads the shape (geometry.area, scope.sx) is exact: CGA evaluates attrs
        # and consts on the initial shape, and so does the engine (grammarkit/split/attrs.py)
        self._record(v.kind, v.name, status, v.span, feature=feature, message=message,
                     counting=not v.imported)
        if v.kind == "const":
            for a in v.annotations:
                self.report.ignored[a.children[0].value] += 1
            return Const(name=gk, value=value, span=v.span)
        rng, enum = self._annotations(v, value)
        return Attr(name=gk, value=value, range=rng, enum=enum, span=v.span)

    def _looks_text(self, tree: Any, depth: int = 0) -> bool:
        """Whether a CGA value is text: a string literal in it, or in the body of a function or
        the value of an attr/const it names (`attr PrimaryColor = _getInitialPrimaryColor`,
        whose case arms are colours): the stand-in for an untranslatable value keeps the type,
        so `color(PrimaryColor)` still checks."""
        if looks_like_string(tree):
            return True
        if not isinstance(tree, Tree) or depth > 8:
            return False
        values = {v.name: v.value for v in self.values}
        for sub in tree.iter_subtrees():
            if sub.data not in ("ref", "func_call") or not sub.children:
                continue
            name = sub.children[0].value if isinstance(sub.children[0], Token) else None
            arity = len(sub.children[1].children) if sub.data == "func_call" and len(sub.children) > 1 \
                and isinstance(sub.children[1], Tree) else 0
            fn = self.functions.get((name, arity))
            target = fn.body if fn is not None else values.get(name) if sub.data == "ref" else None
            if target is not None and target is not tree and self._looks_text(target, depth + 1):
                return True
        return False

    def _fallback_value(self, tree: Any, ctx: ExprContext) -> tuple[Any, str | None]:
        """A value for an attr/const whose CGA value grammarkit cannot express."""
        if not isinstance(tree, Tree):
            return None, None
        kids = children(tree)
        if tree.data == "func_call" and kids and getattr(kids[0], "value", None) in (
                "readStringTable", "readFloatTable"):
            # a table the import cannot read: CityEngine reads a missing file as an empty array
            return (Call(func="cgaArray", args=(Num(value=0.0), Num(value=0.0))),
                    "an empty array instead (CityEngine's value for a table it cannot read)")
        if tree.data == "case_expr":
            conds, vals, other = kids[0:-1:2], kids[1:-1:2], kids[-1]
            for cond, val in zip(conds, vals):
                try:
                    c = self.constant_value(translate_expr(cond, ctx))
                except Untranslatable:
                    c = None
                if c is None:
                    break
                if c is True:
                    try:
                        return translate_expr(val, ctx), "the arm that holds for the default attr values is used"
                    except Untranslatable:
                        return None, None
            else:
                try:
                    return translate_expr(other, ctx), "the else arm (the value for the default attrs) is used"
                except Untranslatable:
                    return None, None
            try:
                return translate_expr(other, ctx), "the else arm is used"
            except Untranslatable:
                return None, None
        if tree.data == "stoch_expr":
            pcts, vals = kids[0:-1:2], kids[1:-1:2]
            best, best_p = kids[-1], None
            for p, val in zip(pcts, vals):
                try:
                    pv = self.constant_value(translate_expr(p, ctx))
                except Untranslatable:
                    pv = None
                if isinstance(pv, (int, float)) and (best_p is None or pv > best_p):
                    best, best_p = val, pv
            try:
                return translate_expr(best, ctx), "its most likely value is used"
            except Untranslatable:
                return None, None
        return None, None

    def _static_env(self) -> dict[str, Any]:
        """grammarkit name -> translated value of every attr and const that translates (the
        values list only grows while declarations are collected; cached by its length)."""
        cached = getattr(self, "_static_env_cache", None)
        if cached is not None and cached[0] == len(self.values):
            return cached[1]
        env: dict[str, Any] = {}
        ctx = self._ctx("Y", {})
        for v in self.values:
            try:
                env[self.value_names[v.name]] = translate_expr(v.value, ctx)
            except Untranslatable:
                pass
        self._static_env_cache = (len(self.values), env)
        return env

    def constant_value(self, expr: Any) -> Any:
        """The value of a translated expression with the attrs' and consts' default values,
        folded by the language's one evaluator (`grammarkit.expr_eval.fold_constant`), or None
        when it depends on the derivation (scope, random numbers, files, parameters)."""
        env = self._static_env()
        visiting: set[str] = set()

        def lookup(name: str) -> Any:
            value = env.get(name)
            if value is None or name in visiting:  # unknown, or a value defined by itself
                return NOT_CONSTANT
            visiting.add(name)
            try:
                return fold_constant(value, lookup, _fold_functions())
            finally:
                visiting.discard(name)
        value = fold_constant(expr, lookup, _fold_functions())
        return None if value is NOT_CONSTANT else value

    def _annotations(self, v: ValueDef, value: Any) -> tuple[Any, Any]:
        rng = enum = None
        default = self.constant_value(value)
        for a in v.annotations:
            aname = a.children[0].value
            span = self._span(a)
            args = a.children[1].children if len(a.children) > 1 else []
            named = {c.children[0].value: c.children[1] for c in args if c.data == "ann_named"}
            positional = [c.children[0] for c in args if c.data == "ann_positional"]
            if aname == "@StartRule":
                continue
            if aname not in ("@Range", "@Enum"):
                self.report.ignored[aname] += 1
                continue
            try:
                ctx = self._ctx("Y", {})
                if aname == "@Range" and "min" in named and "max" in named:
                    rng = (translate_expr(named["min"], ctx), translate_expr(named["max"], ctx))
                elif aname == "@Range" and len(positional) == 2 and all(
                        isinstance(translate_expr(p, ctx), Num) for p in positional):
                    rng = tuple(translate_expr(p, ctx) for p in positional)
                elif positional:
                    enum = tuple(translate_expr(p, ctx) for p in positional)
                else:
                    raise Untranslatable(f"annotation:{aname}", f"{aname} without values "
                                         f"({', '.join(named) or 'no arguments'})", span)
                for e in (rng or ()) + (enum or ()):
                    if not isinstance(e, (Num, Str, Bool)):
                        raise Untranslatable(f"annotation:{aname}", f"{aname} with non-constant values",
                                             span)
            except Untranslatable as exc:
                rng = enum = None
                self._record("annotation", aname, "dropped", span, feature=exc.feature,
                             message=exc.message)
                continue
            status, message = "translated", None
            if rng is not None and isinstance(default, (int, float)) and not isinstance(default, bool):
                lo, hi = rng[0].value, rng[1].value
                if lo > hi:
                    lo, hi = hi, lo
                if not lo <= default <= hi:
                    status = "approximated"
                    message = (f"@Range of attr {v.name} does not contain its default {default:g} "
                               "(CGA allows it with restricted=false); the range is widened")
                    lo, hi = min(lo, default), max(hi, default)
                rng = (Num(value=lo), Num(value=hi))
            if enum is not None and default is not None and default not in [e.value for e in enum]:
                status = "approximated"
                message = f"the default of attr {v.name} is not among its values; it is added"
                enum = enum + (literal(default),)
            self._record("annotation", aname, status, span, feature="annotation:default-outside"
                         if status != "translated" else None, message=message)
        return rng, enum

