"""How operation calls are written: the one argument binder of `check` and the split compiler.

Everything here looks at the text only (the IR and the operation specs), never at geometry,
so `grammarkit check` reports exactly what the compiler would refuse, with the same codes:

- `bind_operation(call, spec)`: positional and named arguments to the spec's parameters
  (`operation-arity`, `unknown-argument`, `bad-argument` for an argument given twice,
  `bad-argument-type`, `bad-argument-value` for an invalid colour);
- `check_block(call, spec)`: the `{ }` block the spec asks for (`block-kind`, `unknown-selector`);
- `check_sequence(seq)`: the shape of a rule body (`item-after-block`: a `{ ... }` block
  consumes the shape; `repeat-without-pattern`, `pattern-without-repeat`, `item-after-pattern`).

Each returns `Diagnostic`s: the checker reports all of them, the compiler raises the first.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import Diagnostic
from ..expr_eval import value_kind
from ..ir import Binary, Bool, Branch, Num, OpCall, Pattern, Ref, Repeat, Seq, Str, Unary, Vector
from ..registry import OperationSpec, Param
from .suggest import known_hint

__all__ = ["Binding", "BoundArgument", "bind_operation", "check_block", "check_sequence", "literal_kind",
           "parse_color", "signature"]

Fold = Callable[[Any], Any]  # expression -> constant value, or None when not constant

_HEX = frozenset("0123456789abcdefABCDEF")
# name parameters may be these dotted names (CGA's material shape attributes, for set())
DOTTED_NAMES = ("material.",)


def parse_color(value: Any) -> str | None:
    """`#rrggbb` (lower case) for a colour literal `#rrggbb` or `#rgb`, None if it is not one."""
    if not isinstance(value, str):
        return None
    text = value.strip()
    h = text[1:] if text.startswith("#") else ""
    if len(h) == 3:
        h = "".join(ch * 2 for ch in h)
    if len(h) != 6 or any(ch not in _HEX for ch in h):
        return None
    return "#" + h.lower()


def literal_kind(v: Any) -> str | None:
    """What an expression is by its syntax alone ("a number", "a string", ...), or None."""
    if isinstance(v, Num):
        return "a number"
    if isinstance(v, Str):
        return "a string"
    if isinstance(v, Bool):
        return "a boolean"
    if isinstance(v, Vector):
        return "a tuple"
    if isinstance(v, Binary) and v.op in ("==", "!=", "<", "<=", ">", ">=", "&&", "||"):
        return "a boolean"
    if isinstance(v, Unary) and v.op == "!":
        return "a boolean"
    return None


def signature(spec: OperationSpec) -> str:
    parts = []
    for p in spec.params:
        t = "|".join(p.choices) if p.choices else p.type
        parts.append(f"{p.name}: {t}" + ("" if p.required else f" = {p.default!r}"))
    return f"{spec.name}({', '.join(parts)})"


@dataclass(frozen=True)
class BoundArgument:
    """A parameter with the expression given for it (None: not given, the default applies)."""

    param: Param
    value: Any = None
    span: Any = None


@dataclass
class Binding:
    spec: OperationSpec
    arguments: list[BoundArgument] = field(default_factory=list)  # one per parameter, in order
    extra: list[Any] = field(default_factory=list)  # variadic extras (expressions)
    problems: list[Diagnostic] = field(default_factory=list)


def _error(message: str, span: Any, code: str, hint: str | None = None) -> Diagnostic:
    return Diagnostic("error", message, span, hint, code)


def bind_operation(call: Any, spec: Any, fold: Fold | None = None, *, label: str | None = None,
                   registries: Any = None, fold_fixed: Fold | None = None) -> Binding:
    """Bind the call's arguments to `spec.params` and check what the text shows of them.

    `call` is an `OpCall` (or a tiling `ConstraintDef`: anything with `name`, `args`, `span`),
    `spec` its OperationSpec (or ConstraintSpec); `label` names the call in messages (default:
    its name). `fold` (the checker's constant folding) lets the types of constant arguments be
    checked too (`extrude(s)` with `attr s = "x"`); without it only literals are.
    `fold_fixed` folds only what no attr override can change: values (a colour) are checked
    on those, since an attr's default may be a placeholder (`attr c = ""` behind a guard). With
    `registries`, arguments of type `name` must name an entry of the registry kind they ask
    for (`i("a.glb", fit=retarget)`: a fit)."""
    label = label or call.name
    params = spec.params
    by_name = {p.name: p for p in params}
    variadic = getattr(spec, "variadic", False)
    given: dict[str, Any] = {}  # parameter name -> Arg
    out = Binding(spec)
    problems = out.problems
    positional = 0
    for a in call.args:
        if a.name is None:
            if positional < len(params):
                p = params[positional]
                if p.name in given:
                    problems.append(_error(f"argument '{p.name}' of {label} given twice",
                                           a.span or call.span, "bad-argument"))
                given[p.name] = a
            elif variadic:
                out.extra.append(a.value)
            else:
                problems.append(_error(f"too many arguments: {label} takes at most {len(params)} "
                                       f"({signature(spec)})", a.span or call.span, "operation-arity"))
            positional += 1
            continue
        p = by_name.get(a.name)
        if p is None:
            problems.append(_error(
                f"{label} has no argument named '{a.name}'", a.span or call.span, "unknown-argument",
                known_hint("arguments", a.name, by_name) if by_name else f"{label} takes no named arguments"))
            continue
        if p.name in given:
            problems.append(_error(f"argument '{p.name}' of {label} given twice", a.span or call.span,
                                   "bad-argument"))
        given[p.name] = a
    missing = [p.name for p in params if p.required and p.name not in given]
    if missing:
        problems.append(_error(f"{label} is missing argument(s): {', '.join(missing)} "
                               f"({signature(spec)})", call.span, "operation-arity"))
    for p in params:
        a = given.get(p.name)
        if a is None:
            out.arguments.append(BoundArgument(p))
            continue
        problem = _argument_problem(label, p, a.value, a.span or call.span, fold, registries, fold_fixed)
        if problem is not None:
            problems.append(problem)
        out.arguments.append(BoundArgument(p, a.value, a.span or call.span))
    return out


def _argument_problem(label: str, p: Param, v: Any, where: Any, fold: Fold | None,
                      registries: Any = None, fold_fixed: Fold | None = None) -> Diagnostic | None:
    if p.type in ("axis", "selector"):
        # a dotted name only where the parameter lists it (setupProjection's `scope.xy`)
        if not isinstance(v, Ref) or (p.choices and v.name not in p.choices) or ("." in v.name and not p.choices):
            shown = "|".join(p.choices) if p.choices else "a name"
            return _error(f"argument '{p.name}' of {label} must be {shown}", where, "bad-argument-type")
        return None
    if p.type == "name":
        what = p.names[:-1] if p.names.endswith("s") else (p.names or "name")
        # CGA's material attributes are the one dotted name set() takes (`set(material.opacity, 0.5)`)
        if not isinstance(v, Ref) or ("." in v.name and not v.name.startswith(DOTTED_NAMES)):
            return _error(f"argument '{p.name}' of {label} must be the name of a {what}", where,
                          "bad-argument-type")
        known = getattr(registries, p.names, None) if registries is not None and p.names else None
        if known is not None and v.name not in known:
            return _error(f"unknown {what} '{v.name}' (argument '{p.name}' of {label})", where,
                          "bad-argument-value", known_hint(p.names, v.name, known))
        return None
    want = {"number": "a number", "string": "a string", "color": "a string"}.get(p.type)
    if want is None:  # "any", "expr": whatever the operation makes of it
        return None
    kind = literal_kind(v)
    value = fold(v) if fold is not None and kind is None else None
    if value is not None:
        kind = value_kind(value)
    if isinstance(v, Str):
        value = v.value
    elif kind is None or value is not None:
        value = fold_fixed(v) if fold_fixed is not None else None
    if kind is not None and kind != want:
        return _error(f"argument '{p.name}' of {label} must be {want}, not {kind}", where,
                      "bad-argument-type")
    if p.type == "color" and isinstance(value, str) and parse_color(value) is None:
        return _error(f"argument '{p.name}' of {label} must be a colour '#rrggbb' or '#rgb', "
                      f"got {value!r}", where, "bad-argument-value")
    return None


def check_block(call: OpCall, spec: OperationSpec) -> list[Diagnostic]:
    """Problems of the call's `{ }` block against the kind of block the spec takes (the
    entries' keys only: their bodies are sequences, checked like any other)."""
    kind = spec.block
    block = call.block
    problems: list[Diagnostic] = []
    if kind == "none":
        if block is not None:
            problems.append(_error(f"{call.name} takes no {{ }} block", call.span, "block-kind"))
        return problems
    if block is None:
        if kind == "sizes":
            problems.append(_error(f"{call.name} needs a block of sizes, like {call.name}(...) "
                                   "{ 1: A | ~1: B }", call.span, "block-kind"))
        elif kind == "selectors":
            sel = spec.selectors[0] if spec.selectors else "name"
            problems.append(_error(f"{call.name} needs a block of selectors, like {call.name}(...) "
                                   f"{{ {sel}: A }}", call.span, "block-kind"))
        return problems
    selectors = kind in ("selectors", "optional-selectors")
    stack = list(reversed(block))
    while stack:
        it = stack.pop()
        if isinstance(it, Repeat):
            if selectors:
                problems.append(_error(f"a repeat group {{ ... }}* belongs in a split block, not in "
                                       f"{call.name}'s selector block", it.span, "block-kind"))
            stack.extend(reversed(it.items))
            continue
        if not isinstance(it, Branch):
            continue
        if selectors:
            key = it.key
            if isinstance(key, Num) and it.mode == "abs" and "<index>" in spec.selectors:
                # an index selector (comp(f) { 0: A | 2: B }): a whole number >= 0
                if key.value < 0 or not float(key.value).is_integer():
                    problems.append(_error(f"an index selector of {call.name} must be a whole number "
                                           f">= 0, got {key.value:g}", key.span or it.span,
                                           "unknown-selector"))
                continue
            if it.mode != "abs" or not isinstance(key, Ref) or "." in key.name:
                problems.append(_error(f"{call.name} takes selectors ({', '.join(spec.selectors)}), "
                                       "not sizes", it.span, "block-kind"))
            elif spec.selectors and key.name not in spec.selectors:
                problems.append(_error(f"'{key.name}' is not a selector of {call.name}", key.span or it.span,
                                       "unknown-selector", known_hint("selectors", key.name, spec.selectors)))
        else:
            k = literal_kind(it.key)
            if k is not None and k != "a number":
                problems.append(_error(f"a split size must be a number, not {k}", it.key.span or it.span,
                                       "bad-argument-type"))
    return problems


def check_sequence(seq: Seq) -> list[Diagnostic]:
    """Problems of the order of a rule body's items (not of its nested sequences)."""
    items = list(seq.items)
    problems: list[Diagnostic] = []
    n = len(items)
    i = 0
    while i < n:
        item = items[i]
        if isinstance(item, OpCall) and item.name == "repeat":
            if i + 1 >= n or not isinstance(items[i + 1], Pattern):
                problems.append(_error("repeat(...) must be followed by a pattern such as (A)* or (A B)* A",
                                       item.span, "repeat-without-pattern"))
                i += 1
                continue
            if i + 2 < n:
                problems.append(_error("nothing may follow a repeat pattern: the pattern consumes the shape",
                                       items[i + 2].span, "item-after-pattern"))
            return problems
        if isinstance(item, Pattern):
            problems.append(_error("a pattern (A)* needs a repeat(axis, size) before it", item.span,
                                   "pattern-without-repeat"))
        elif isinstance(item, OpCall) and item.block is not None and i + 1 < n:
            problems.append(_error(f"nothing may follow {item.name}(...) {{ ... }}: its block consumes "
                                   "the shape", items[i + 1].span, "item-after-block",
                                   "put what follows inside the block's branches, or before the operation"))
            return problems
        i += 1
    return problems
