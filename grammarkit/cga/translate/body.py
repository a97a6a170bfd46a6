"""Rule bodies: items, case and stochastic tails, operation calls (dispatched to the handlers)."""
from __future__ import annotations

import dataclasses
from typing import Any

from lark import Token, Tree

from ...ir import (
    Arg,
    Branch,
    Case,
    CaseArm,
    Choice,
    ChoiceArm,
    Nil,
    Num,
    OpCall,
    Push,
    Ref,
    Rule,
    Seq,
    Successor,
    Terminal,
)
from ...ir.base import Span
from ..expressions import (
    Untranslatable,
    call_args,
    translate_expr,
)
from ..names import gk_name
from .context import BARE_OPS, HandlerContext, RuleCtx
from .handlers import HANDLERS
from .model import (
    METADATA,
    TEXTURING,
)


# operations that make a volume of a horizontal face, scoped y up in CGA (as a lot's volume)
_VOLUME_OPS = frozenset({"extrude", "roofGable", "roofHip", "roofPyramid", "roofShed"})

class BodyMixin:
    """Translates rule bodies."""

    # -- rules --------------------------------------------------------------------------------------
    def body_items(self, nodes: list, frame: str, rctx: RuleCtx) -> list:
        """The items of a rule body (for handlers whose blocks hold rule calls, as scatter's)."""
        return self._body(nodes, frame, rctx)

    def _rule(self, key: tuple[str, int], frame: str, counting: bool) -> Rule:
        r = self.rules[key]
        gk = self._rule_names[(key, frame)]
        params = {p: gk_name(p) for p in r.params}
        for a in r.annotations:
            if a.children[0].value != "@StartRule":
                if counting:
                    self.report.ignored[a.children[0].value] += 1
            else:
                self._record("annotation", "@StartRule", "translated", self._span(a),
                             counting=counting)
        self._record("rule", r.name, "translated", r.span, counting=counting)
        rctx = RuleCtx(key, gk, params, counting)
        items = self._body(r.body.children, frame, rctx)  # frame H: see RuleCtx.horizontal
        if not items:
            items = [Terminal(name=gk, span=r.span)]
        return Rule(name=gk, params=tuple(params.values()), body=Seq(items=tuple(items)), span=r.span)

    def _body(self, nodes: list, frame: str, rctx: RuleCtx) -> list:
        """A rule body / arm / entry (items, then maybe a case or stochastic tail)."""
        out: list = []
        if frame == "H":  # a horizontal face: frame Z for its own scope (see RuleCtx.horizontal)
            frame, rctx = "Z", dataclasses.replace(rctx, horizontal=True)
        i = 0
        while i < len(nodes):
            node = nodes[i]
            if node.data == "tail":
                out.extend(self._tail(node.children[0], frame, rctx))
                i += 1
                continue
            if node.data == "call" and node.children[0].value == "offset" and len(call_args(node)) == 2:
                consumed = self._offset_part(node, nodes[i + 1:], frame, rctx, out)
                if consumed:
                    return out
                i += 1
                continue
            if (node.data == "name" and node.children[0].value == "innerRect"
                    and "innerRect" not in self.rule_arities):
                # CGA's old `innerRect` (no parentheses): the shape becomes its largest inner
                # rectangle and the rest of the body goes on with it, which is
                # innerRectangle(scope) { shape: rest } (the remainder is dropped, as there)
                rest = self._body(nodes[i + 1:], frame, rctx) or [Terminal(name=rctx.gk, span=self._span(node))]
                self._record("op", "innerRect", "translated", self._span(node), counting=rctx.counting)
                out.append(OpCall(name="innerRectangle", args=(Arg(value=Ref(name="scope")),),
                                  block=(Branch(key=Ref(name="shape"), body=Seq(items=tuple(rest)),
                                                span=self._span(node)),), span=self._span(node)))
                return out
            items = self._item(node, frame, rctx, out)
            if self.frame_change is not None:  # alignScopeToGeometry(yUp | zUp, ...)
                frame, self.frame_change = self.frame_change, None
            if rctx.horizontal and frame == "Z" and any(isinstance(it, OpCall) and it.name in _VOLUME_OPS
                                                        for it in items):
                # CGA scopes a volume extruded from a horizontal face as a lot's: y up (frame Y);
                # so is a roof built on one (Esri's rules scale roofs with s('1, h, '1))
                frame, rctx = "Y", dataclasses.replace(rctx, horizontal=False)
            is_last = i == len(nodes) - 1
            for it in items:
                if isinstance(it, OpCall) and it.block is not None and not is_last:
                    it = Push(body=Seq(items=(it,)), span=it.span)
                out.append(it)
            i += 1
        return out

    def _successor_frame(self, frame: str, rctx: RuleCtx, key: tuple[str, int]) -> str:
        """The frame a called rule receives: H while the shape is still a horizontal face and
        the rule (or one it calls) extrudes it (else H and Z translate alike: no copy)."""
        return "H" if rctx.horizontal and frame == "Z" and self._may_extrude(key[0]) else frame

    def _may_extrude(self, name: str) -> bool:
        memo = self.__dict__.setdefault("_extrude_memo", {})
        if name not in memo:
            memo[name] = False  # a cycle of calls reads False while it is being decided
            names = {k[0] for k in self.rules}
            found = False
            for key, r in self.rules.items():
                if key[0] != name or not isinstance(r.body, Tree):
                    continue
                toks = [t.value for t in r.body.scan_values(lambda v: isinstance(v, Token))]
                if _VOLUME_OPS.intersection(toks) or any(t in names and t != name and self._may_extrude(t) for t in toks):
                    found = True
            memo[name] = found
        return memo[name]

    def _tail(self, block: Tree, frame: str, rctx: RuleCtx) -> list:
        span = self._span(block)
        arms = [c for c in block.children if c.data in ("case_arm", "stoch_arm")]
        else_arm = next(c for c in block.children if c.data == "else_arm")
        other = self._arm_body(else_arm.children[-1], frame, rctx, span)
        ctx = self._ctx(frame, rctx.params)
        if block.data == "case_block":
            out_arms = []
            for arm in arms:
                cond_tree = arm.children[1]
                try:
                    cond = translate_expr(cond_tree, ctx)
                except Untranslatable as exc:
                    self._record("case-arm", "case", "dropped", self._span(arm), feature=exc.feature,
                                 message=f"case arm: its condition uses {exc.message}; the arm is "
                                 "left out", counting=rctx.counting)
                    self._arm_body(arm.children[-1], frame, rctx, span)  # count its constructs
                    continue
                out_arms.append(CaseArm(cond=cond, body=self._arm_body(arm.children[-1], frame,
                                                                        rctx, span)))
            self._record("case", "case", "translated", span, counting=rctx.counting)
            if not out_arms:
                return list(other.items)
            return [Case(arms=tuple(out_arms), otherwise=other, span=span)]
        out_arms = []
        for arm in arms:
            pct_tok = arm.children[0]
            body = self._arm_body(arm.children[-1], frame, rctx, span)
            if pct_tok.type == "NUMBER":
                pct: Any = Num(value=float(pct_tok.value))
            elif pct_tok.value in self.value_names:
                pct = Ref(name=self.value_names[pct_tok.value])
            else:
                self._record("choice-arm", "%", "dropped", self._span(pct_tok), feature="expr:percent",
                             message=f"a percentage {pct_tok.value}% that is not a number or attr",
                             counting=rctx.counting)
                continue
            out_arms.append(ChoiceArm(percent=pct, body=body))
        self._record("choice", "%", "translated", span, counting=rctx.counting)
        if not out_arms:
            return list(other.items)
        return [Choice(arms=tuple(out_arms), otherwise=other, span=span)]

    def _arm_body(self, node: Tree, frame: str, rctx: RuleCtx, span: Span | None) -> Seq:
        items = self._body(node.children, frame, rctx)
        if not items:
            items = [Terminal(name=rctx.gk, span=span)]
        return Seq(items=tuple(items))

    # -- items --------------------------------------------------------------------------------------
    def _item(self, node: Tree, frame: str, rctx: RuleCtx, out: list) -> list:
        kind = node.data
        span = self._span(node)
        counting = rctx.counting
        if kind == "nil":
            self._record("nil", "NIL", "translated", span, counting=counting)
            return [Nil(span=span)]
        if kind == "noop":
            self._record("noop", ".", "translated", span, counting=counting)
            return []
        if kind == "terminal":
            name = node.children[0].value
            self._record("terminal", name, "translated", span, counting=counting)
            return [Terminal(name=gk_name(name), span=span)]
        if kind == "push":
            body = self._body(node.children[0].children, frame, rctx)
            self._record("push", "[]", "translated", span, counting=counting)
            return [Push(body=Seq(items=tuple(body)), span=span)] if body else []
        name = node.children[0].value
        args = call_args(node)
        if kind == "name":
            if (name, 0) in self.rules:
                self._record("successor", name, "translated", span, counting=counting)
                return [Successor(name=self._rule_name((name, 0), self._successor_frame(frame, rctx, (name, 0))), span=span)]
            if name in BARE_OPS:
                return self._op(name, [], None, False, node, frame, rctx, out)
            prefix = name.split(".", 1)[0]
            if "." in name and prefix in self.imports:
                self._record("successor", name, "dropped", span, feature="import",
                             message=f"{name} is a rule of the imported file {prefix!r}",
                             counting=counting)
                return [Terminal(name=gk_name(name), span=span)]
            self._record("leaf", name, "translated", span, counting=counting)
            return [Terminal(name=gk_name(name), span=span)]
        if kind == "call" and name in self.rule_arities:
            key = (name, len(args))
            if key not in self.rules:
                self._record("successor", name, "dropped", span, feature="rule-arity",
                             message=f"{name}() has no rule with {len(args)} argument(s)",
                             counting=counting)
                return []
            ctx = self._ctx(frame, rctx.params)
            try:
                values = tuple(translate_expr(a, ctx) for a in args)
            except Untranslatable as exc:
                self._record("successor", name, "dropped", span, feature=exc.feature,
                             message=f"{name}(...): an argument uses {exc.message}",
                             counting=counting)
                return []
            self._record("successor", name, "translated", span, counting=counting)
            return [Successor(name=self._rule_name(key, self._successor_frame(frame, rctx, key)), args=values, span=span)]
        if kind == "call" and "." in name and name.split(".", 1)[0] in self.imports:
            self._record("successor", name, "dropped", span, feature="import",
                         message=f"{name}(...) is a rule of an imported file", counting=counting)
            return []
        block = node.children[-2] if kind == "block_call" and isinstance(node.children[-1], Token) \
            else (node.children[-1] if kind == "block_call" else None)
        star = kind == "block_call" and isinstance(node.children[-1], Token)
        return self._op(name, args, block, star, node, frame, rctx, out)

    def _op(self, name: str, args: list, block: Tree | None, star: bool, node: Tree, frame: str,
            rctx: RuleCtx, out: list) -> list:
        span = self._span(node)
        handler = HANDLERS.get(name)
        ctx = self._ctx(frame, rctx.params)
        if handler is None and block is None and name[:1].isupper() and name not in TEXTURING \
                and name not in METADATA:
            # a call of a rule that no rule of this file defines (any arity): in CGA the shape
            # is a leaf, its arguments unused, as for a bare undefined name
            self._record("leaf", name, "translated", span, counting=rctx.counting)
            return [Terminal(name=gk_name(name), span=span)]
        if handler is None:
            if name in TEXTURING:
                why = ("grammarkit's texturing has no such operation (it has setupProjection, projectUV, "
                       "translateUV, scaleUV, rotateUV, deleteUV, tileUV, normalizeUV, texture)")
            elif name in METADATA:
                why = "prints are not collected (report() is)"
            elif name[:1].isupper():
                why = ("no rule of this name and arity in this file (a rule that an importing "
                       "file defines?)")
            else:
                why = "grammarkit has no such operation"
            # Still translate the block's bodies so that their constructs are counted.
            if block is not None and rctx.counting:
                self._count_block(block, frame, rctx)
            feature = "rule:undefined" if name[:1].isupper() else f"op:{name}"
            self._record("op", name, "dropped", span, feature=feature,
                         message=f"{name}(): {why}", counting=rctx.counting)
            return []
        try:
            # an array as an operation's argument itself (setback([1, 2, 3, 4]): per-edge values)
            # is the handler's to translate, not a value (ExprContext.operation_argument)
            op_ctx = dataclasses.replace(ctx, operation_argument=True)
            items, approx = handler(HandlerContext(self, name, args, block, star, frame, rctx, op_ctx, span, out))
        except Untranslatable as exc:
            if block is not None and rctx.counting:
                self._count_block(block, frame, rctx)
            self._record("op", name, "dropped", span, feature=exc.feature,
                         message=f"{name}(): {exc.message}", counting=rctx.counting)
            return []
        if approx is not None:
            feature, message = approx
            self._record("op", name, "approximated", span, feature=feature,
                         message=f"{name}(): {message}", counting=rctx.counting)
        else:
            self._record("op", name, "translated", span, counting=rctx.counting)
        return items

    def _count_block(self, block: Tree, frame: str, rctx: RuleCtx) -> None:
        for entry in block.children:
            if entry.data in ("entry", "merged_entry"):
                self._body(entry.children[-1].children, frame, rctx)
            elif entry.data in ("repeat_entry", "group_entry"):
                self._count_block(entry.children[0], frame, rctx)

    def _offset_part(self, node: Tree, rest: list, frame: str, rctx: RuleCtx, out: list) -> bool:
        """`offset(d, inside|border)`: keep one part; returns True if it consumed `rest`."""
        span = self._span(node)
        d_tree, sel_tree = call_args(node)
        ctx = self._ctx(frame, rctx.params)
        part = sel_tree.children[0].value if isinstance(sel_tree, Tree) and sel_tree.data == "ref" else None
        try:
            d = translate_expr(d_tree, ctx)
            if part not in ("inside", "border"):
                raise Untranslatable("op:offset", f"offset part {part!r} is not supported", span)
        except Untranslatable as exc:
            self._record("op", "offset", "dropped", span, feature=exc.feature,
                         message=f"offset(): {exc.message}", counting=rctx.counting)
            return False
        self._record("op", "offset", "translated", span, counting=rctx.counting)
        if part == "inside":
            out.append(OpCall(name="offset", args=(Arg(value=d),), span=span))
            return False
        body = self._body(rest, frame, rctx) or [Terminal(name=rctx.gk, span=span)]
        out.append(OpCall(name="offset", args=(Arg(value=d),), block=(
            Branch(key=Ref(name="border"), body=Seq(items=tuple(body))),), span=span))
        return True

