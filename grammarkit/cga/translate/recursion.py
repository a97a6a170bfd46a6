"""Recursive CGA functions, emitted as grammarkit functions (the others are inlined)."""
from __future__ import annotations

from typing import Any

from lark import Token, Tree

from ...functions import BUILTIN_FUNCTIONS
from ...ir import (
    Function as GkFunction,
)
from ...ir import (
    Ref,
)
from ..expressions import (
    _FUNCTIONS,
    Untranslatable,
    call_args,
    is_text,
    translate_expr,
)
from ..names import gk_name


class FunctionsMixin:
    """Emits the recursive functions and reports on every function."""

    # -- recursive functions --------------------------------------------------------------------
    def _recursive_functions(self) -> list[tuple[str, int]]:
        """The functions that call themselves, directly or through others (in source order)."""
        calls: dict[tuple[str, int], set[tuple[str, int]]] = {}
        for key, fn in self.functions.items():
            out: set[tuple[str, int]] = set()
            if isinstance(fn.body, Tree):
                for t in fn.body.iter_subtrees():
                    if t.data == "func_call" and t.children and isinstance(t.children[0], Token):
                        out.add((t.children[0].value, len(call_args(t))))
                    elif t.data == "ref" and t.children and isinstance(t.children[0], Token) \
                            and t.children[0].value not in fn.params:
                        out.add((t.children[0].value, 0))
            calls[key] = {k for k in out if k in self.functions}

        def reaches_itself(key: tuple[str, int]) -> bool:
            seen: set[tuple[str, int]] = set()
            todo = list(calls[key])
            while todo:
                k = todo.pop()
                if k == key:
                    return True
                if k not in seen:
                    seen.add(k)
                    todo.extend(calls.get(k, ()))
            return False
        return [k for k in self.functions if reaches_itself(k)]

    def _emit_functions(self) -> list[GkFunction]:
        """Recursive CGA functions cannot be inlined: each becomes a grammarkit function (its
        overloads by arity share the grammarkit name), translated once per frame of the scope
        axes when its body reads the scope (else one function serves both). A function whose
        body does not translate is not emitted: its calls raise the body's Untranslatable.
        Non-recursive functions stay inlined (so translations without recursion do not change)."""
        keys = self._recursive_functions()
        if not keys:
            return []
        taken = {spec.name for spec in BUILTIN_FUNCTIONS} | {gk for gk, _, _ in _FUNCTIONS.values()}
        names: dict[str, str] = {}
        for name, _ in keys:
            if name not in names:
                base = gk_name(name)
                names[name] = self._claim(base + "_" if base in taken else base)
        for key in keys:
            self.emitted[key] = {"Y": names[key[0]], "Z": names[key[0]]}
        bodies: dict[tuple[tuple[str, int], str], Any] = {}
        while True:  # until stable: a body that calls a function that failed fails too, and a
            # function whose body is text makes `+` with its calls concatenate
            changed = False
            bodies.clear()
            for key in keys:
                if isinstance(self.emitted[key]["Y"], Untranslatable):
                    continue
                fn = self.functions[key]
                params = {p: gk_name(p) for p in fn.params}
                try:
                    for frame in ("Y", "Z"):
                        bodies[(key, frame)] = translate_expr(fn.body, self._ctx(frame, params))
                except Untranslatable as exc:
                    self.emitted[key] = {"Y": exc, "Z": exc}
                    changed = True
            text = {self.emitted[k]["Y"] for k in keys if (k, "Y") in bodies
                    and is_text(bodies[(k, "Y")], self.text_functions)}
            if text - self.text_functions:
                self.text_functions |= text
                changed = True
            if not changed:
                break
        done = [k for k in keys if (k, "Y") in bodies]
        if any(bodies[(k, "Y")] != bodies[(k, "Z")] for k in done):
            # a body reads the scope: the face frame (Z) gets copies calling each other
            znames = {name: self._claim(f"{names[name]}_z") for name in {k[0] for k in done}}
            for k in done:
                self.emitted[k]["Z"] = znames[k[0]]
            for k in done:
                fn = self.functions[k]
                bodies[(k, "Z")] = translate_expr(fn.body, self._ctx("Z", {p: gk_name(p) for p in fn.params}))
        out: list[GkFunction] = []
        for frame in ("Y", "Z"):
            for k in done:
                name = self.emitted[k][frame]
                if frame == "Z" and name == self.emitted[k]["Y"]:
                    continue
                out.append(GkFunction(name=name, params=tuple(gk_name(p) for p in self.functions[k].params),
                                      value=bodies[(k, frame)], span=self.function_spans.get(k)))
        return out

    def _functions_report(self) -> None:
        for key, fn in self.functions.items():
            if fn.name in self.imported_functions:
                continue  # reported when its file is imported on its own
            span = self.function_spans.get(key)
            target = self.emitted.get(key, {}).get("Y")
            if isinstance(target, Untranslatable):
                self._record("function", fn.name, "dropped", span, feature=target.feature,
                             message=f"function {fn.name}(): {target.message}")
                continue
            if target is not None:
                self._record("function", fn.name, "translated", span)
                continue
            if fn.name in self.inlined:
                self._record("function", fn.name, "translated", span)
                continue
            ctx = self._ctx("Y", {})
            ctx.bound = {p: Ref(name="x") for p in fn.params}
            try:
                translate_expr(fn.body, ctx)
                self._record("function", fn.name, "translated", span)
            except Untranslatable as exc:
                self._record("function", fn.name, "dropped", span, feature=exc.feature,
                             message=f"function {fn.name}(): {exc.message}")

