"""The entries of split and comp blocks, and asset lookup."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from lark import Token, Tree

from ...ir import (
    Branch,
    Num,
    Ref,
    Repeat,
    Seq,
    Terminal,
)
from ...ir.base import Span
from .. import frames
from ..expressions import (
    ExprContext,
    Untranslatable,
    translate_expr,
)
from .context import RuleCtx
from .model import (
    hoist_size,
)


class EntriesMixin:
    """Translates split/comp block entries; records assets."""

    # -- blocks ---------------------------------------------------------------------------------------
    def split_entries(self, block: Tree, frame: str, rctx: RuleCtx, ctx: ExprContext) -> list:
        out: list = []
        for entry in block.children:
            span = self._span(entry)
            if entry.data == "repeat_entry":
                out.append(Repeat(items=tuple(self.split_entries(entry.children[0], frame, rctx, ctx)),
                                  span=span))
                continue
            if entry.data == "group_entry":
                self._record("split-group", "{}", "approximated", span, feature="split:group",
                             message="a nested { } without * is read as its entries, once",
                             counting=rctx.counting)
                out.extend(self.split_entries(entry.children[0], frame, rctx, ctx))
                continue
            if entry.data in ("bare_entry", "bare_name_entry", "merged_entry", "seq_entry"):
                raise Untranslatable("split:entry", "a split entry without a size", span)
            mode, key_tree = hoist_size(entry.children[0].children[0])
            key = translate_expr(key_tree, ctx)
            body = self._body(entry.children[-1].children, frame, rctx) or [
                Terminal(name=rctx.gk, span=span)]
            out.append(Branch(mode=mode, key=key, body=Seq(items=tuple(body)), span=span))
        return out

    def _static_index(self, key_tree: Any, frame: str, rctx: RuleCtx) -> tuple[Any, str | None]:
        """A comp selector given as an expression -> (a `number` tree of its value, the
        approximation said) where consts (exact) or attrs' defaults (approximated: a changed
        attr does not move the selector) make it a whole number; (None, None) otherwise."""
        try:
            expr = translate_expr(key_tree, self._ctx(frame, rctx.params))
        except Untranslatable:
            return None, None
        value = self.constant_value(expr)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not float(value).is_integer():
            return None, None
        names = {r.name for r in _refs(expr)}
        kinds = {v.kind for v in self.values if self.value_names.get(v.name) in names}
        note = (f"the comp index is computed from attrs' default values ({int(value)}): a changed "
                "attr does not move it") if "attr" in kinds else None
        return Tree("number", [Token("NUMBER", str(int(value)))]), note

    def _comp_mapping(self, sel: Any, key_tree: Any, frame: str, mode: str,
                      approx_sel: str | None) -> tuple[Any, str | None, str]:
        """CGA comp selector `sel` (in `mode`, on a shape in `frame`) -> (grammarkit
        selectors or None when there is none, the approximation note, the frame of the
        selected parts' bodies)."""
        if mode == "offset-parts":
            mapped = (sel,) if sel in ("inside", "border") else None
            body_frame = frame
        elif mode == "shape-parts":
            mapped = (sel,) if sel in ("shape", "remainder") else None
            body_frame = frame
        elif mode == "components":
            # edges and vertices: their scope is x along, y the normal, as CGA's faces (frame Z)
            body_frame = "Z"
            if sel is not None and key_tree.data == "number":
                mapped = (int(float(sel)),) if float(sel).is_integer() and float(sel) >= 0 else None
            elif sel in ("all", "border", "inside", "eave", "ridge", "hip", "valley"):
                mapped = (sel,)
            elif frame == "Y" and sel in ("front", "back", "left", "right", "top", "bottom", "side",
                                          "vertical", "horizontal", "aslant", "nutant"):
                mapped = (sel,)  # classified about the up axis: CGA's y is grammarkit's z here
            else:
                mapped = None
        elif mode == "edges":
            if sel is not None and key_tree.data == "number":
                mapped = (int(float(sel)),) if float(sel).is_integer() else None
            else:
                mapped, approx_sel = frames.edge_selectors(frame, sel) if sel else (None, None)
            body_frame = frame  # setback faces and the remainder lie in the face's plane
        elif sel is not None and key_tree.data == "number":
            # an index: CGA's and grammarkit's face orders agree (bottom 0, top 1, sides)
            mapped = (int(float(sel)),) if float(sel).is_integer() and float(sel) >= 0 else None
            # faces 0 and 1 of a lot-like volume are its bottom and top: horizontal
            body_frame = "H" if frame == "Y" and mode == "faces" and mapped in ((0,), (1,)) else "Z"
        else:
            mapped = frames.comp_selectors(frame, sel) if sel else None
            prefix, _, rest = (sel or "").rpartition(".")
            if mapped is None and frame == "Y" and prefix in ("object", "street"):
                # CGA's street.* fall back to object.* without street attributes, and a lot's
                # object frame is its scope's (as setback's selectors, frames.edge_selectors)
                mapped = frames.comp_selectors(frame, rest)
                if mapped is not None:
                    approx_sel = (f"{sel} is taken as the scope's {rest} (grammarkit lots have no "
                                  f"{prefix} frame)")
                    sel = rest
            # a lot-like volume's top and bottom are horizontal faces (RuleCtx.horizontal)
            body_frame = "H" if frame == "Y" and sel in ("top", "bottom", "horizontal") else "Z"
        return mapped, approx_sel, body_frame

    def comp_entries(self, block: Tree, frame: str, rctx: RuleCtx, mode: str) -> list:
        out: list = []
        for entry in block.children:
            span = self._span(entry)
            if entry.data not in ("entry", "merged_entry"):
                self._count_block(Tree("block", [entry]), frame, rctx) if entry.data not in (
                    "bare_entry", "bare_name_entry", "seq_entry") else None
                self._record("selector", "?", "dropped", span, feature="comp:entry",
                             message="a comp entry without a selector", counting=rctx.counting)
                continue
            key_tree = entry.children[0].children[0]
            sel = key_tree.children[0].value if isinstance(key_tree, Tree) and key_tree.data in (
                "ref", "number") else None
            approx_sel, computed = None, False
            if sel is None or (key_tree.data == "ref" and sel in self.value_names):
                # a computed index (`inxe1 + 0 = A`, a parameter): its value where it is static
                key_tree, approx_sel = self._static_index(key_tree, frame, rctx)
                computed = approx_sel is not None
                sel = key_tree.children[0].value if key_tree is not None else None
                key_tree = key_tree if key_tree is not None else entry.children[0].children[0]
            mapped, approx_sel, body_frame = self._comp_mapping(sel, key_tree, frame, mode, approx_sel)
            body = self._body(entry.children[-1].children, body_frame, rctx) or [
                Terminal(name=rctx.gk, span=span)]
            if mapped is None:
                self._record("selector", str(sel), "dropped", span, feature=f"comp-selector:{sel}",
                             message=f"comp selector {sel!r} is not supported", counting=rctx.counting)
                continue
            one_face = len(mapped) == 1 and isinstance(mapped[0], int)  # `2 = A` is `2: A`
            if entry.data == "merged_entry" and mode != "shape-parts" and not one_face:
                self._record("selector", f"{sel}=", "approximated", span, feature="comp:merge",
                             message=f"'{sel} =' (the selected faces as one shape) sends each face "
                             "on its own", counting=rctx.counting)
            elif approx_sel is not None:
                self._record("selector", sel, "approximated", span, feature="comp-selector:computed" if computed
                             else f"{'setback' if mode == 'edges' else 'comp'}-selector:{sel}",
                             message=approx_sel, counting=rctx.counting)
            else:
                self._record("selector", sel, "translated", span, counting=rctx.counting)
            if mode == "faces" and frame == "Y" and sel in ("all", "nutant") and mapped is not None:
                # horizontal and vertical faces alike: the horizontal ones first (first match
                # wins), translated as horizontal faces (RuleCtx.horizontal), so that a volume
                # extruded from either is scoped as CGA scopes it (no guess)
                quiet = dataclasses.replace(rctx, counting=False)  # counted once, above
                flat = self._body(entry.children[-1].children, "H", quiet) or [Terminal(name=rctx.gk, span=span)]
                if flat != body:
                    out.append(Branch(key=Ref(name="horizontal"), body=Seq(items=tuple(flat)), span=span))
            for gsel in mapped:
                key = Num(value=float(gsel)) if isinstance(gsel, int) else Ref(name=gsel)
                out.append(Branch(key=key, body=Seq(items=tuple(body)), span=span))
        return out

    # -- assets -----------------------------------------------------------------------------------------
    def asset(self, path: str, span: Span | None, computed: bool = False) -> bool:
        """Record an asset; True if it was found. `computed`: the name is the value of an
        expression with the attrs' default values (other values may name other files)."""
        found = None
        candidates = []
        rel = path.lstrip("/")
        base = Path(self.filename).parent if self.filename else Path(".")
        candidates.append(base / path)
        for d in (base, base.parent, *self.asset_dirs):
            candidates.extend([d / rel, d / "assets" / rel])
        if self.project is not None and self.project.root is not None:
            # CityEngine's lookup: the rule file's folder, the project and its assets/, the
            # imported projects (cga/project.py); then the extra folders
            found = self.project.resolve(path, relative_to=base)
            candidates = [d / rel for d in self.asset_dirs] + [d / "assets" / rel for d in self.asset_dirs]
        for c in candidates if found is None else ():
            if c.is_file():
                found = c
                break
        if path not in self._seen_assets:
            self._seen_assets.add(path)
            entry = {"path": path, "found": found is not None, "resolved": str(found) if found else None,
                     "line": span.line if span else None}
            if computed:
                entry["computed"] = True
            self.report.assets.append(entry)
        return found is not None

    def computed_asset(self, text: str, span: Span | None) -> None:
        """Record an asset name that is computed at derive time (not known statically): the
        report says so (found: null) instead of claiming it was found."""
        key = "<computed> " + text
        if key in self._seen_assets:
            return
        self._seen_assets.add(key)
        self.report.assets.append({"path": text, "found": None, "computed": True, "resolved": None,
                                   "line": span.line if span else None})


def _refs(node: Any) -> list:
    """The Ref nodes of an IR expression."""
    if isinstance(node, Ref):
        return [node]
    if isinstance(node, (list, tuple)):
        return [r for n in node for r in _refs(n)]
    fields = getattr(node, "__dict__", None) or {}
    return [r for k, v in fields.items() if k != "span" for r in _refs(v)]
