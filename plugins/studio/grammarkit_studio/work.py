"""What the studio computes, in a worker process: check, derive, export, pick, tree, gallery.

`Work` holds one grammar text's analysis (the parsed IR with imports inlined, its diagnostics
and its sliders) and the last model derived from it. It runs inside a `worker.Worker` child
process, so that a runaway grammar can be stopped by ending the process (Python threads cannot
be stopped) and so that the server's event loop never waits on the engine.

Every operation runs confined to the grammar's folder (`grammarkit.confine`): each file the
engine, the DSL or an exporter opens for it (imports, meshes, textures, file searches) is
checked there by its resolved path, after escapes, evaluation and symbolic links.

Everything here uses grammarkit's public API only.
"""
from __future__ import annotations

import contextlib
import functools
import math
import time
from pathlib import Path
from typing import Any, Callable, Iterator

from grammarkit import confine
from grammarkit.errors import GrammarkitError

# How many text analyses to keep (the undo/redo of a few edits hits the cache).
_CACHE = 8
# The formats the Export buttons offer (grammarkit's exporter registry encodes them).
EXPORT_FORMATS = ("glb", "obj", "stl")
WHO = "the studio"  # named in every refusal of a file outside the folder


class StudioError(GrammarkitError):
    """A request the studio refuses (bad arguments, a file outside the grammar's folder)."""


def _number(expr: Any) -> float | None:
    """The value of a constant numeric expression of the IR (`12`, `-3`, `2 * 1.5`), else None.

    Range bounds are almost always literals; anything that needs a name's value (a const, an
    attr) gets no slider rather than a guessed one."""
    kind = getattr(expr, "kind", None)
    if kind == "num":
        return float(expr.value)
    if kind == "unary" and getattr(expr, "op", None) in ("-", "+"):
        v = _number(expr.operand)
        return None if v is None else (-v if expr.op == "-" else v)
    if kind == "binary" and expr.op in ("+", "-", "*", "/"):
        a, b = _number(expr.left), _number(expr.right)
        if a is None or b is None or (expr.op == "/" and b == 0):
            return None
        return {"+": a + b, "-": a - b, "*": a * b, "/": a / b if b else 0.0}[expr.op]
    return None


def _literal(expr: Any) -> Any:
    kind = getattr(expr, "kind", None)
    if kind in ("str", "bool"):
        return expr.value
    return _number(expr)


def sliders(grammar: Any, values: dict[str, Any]) -> list[dict]:
    """One control per top-level `@range` attr (a slider) or `@enum` attr (a choice)."""
    out = []
    for attr in grammar.attrs:
        value = values.get(attr.name)
        line = attr.span.line if getattr(attr, "span", None) else None
        if attr.range is not None:
            lo, hi = _number(attr.range[0]), _number(attr.range[1])
            if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
                continue
            integer = isinstance(value, int) and not isinstance(value, bool) and float(lo).is_integer() \
                and float(hi).is_integer()
            out.append({"name": attr.name, "kind": "range", "min": lo, "max": hi, "value": value,
                        "step": 1 if integer else _step(lo, hi), "line": line})
        elif attr.enum is not None:
            choices = [_literal(e) for e in attr.enum]
            if any(c is None for c in choices):
                continue
            out.append({"name": attr.name, "kind": "enum", "choices": choices, "value": value,
                        "line": line})
    return out


def _step(lo: float, hi: float) -> float:
    """A round slider step giving at least 200 positions over the range."""
    span = hi - lo
    if span <= 0:
        return 1.0
    return 10.0 ** math.floor(math.log10(span / 200.0))


# Calls whose first string argument names a file the engine reads: split inserts `i("a.glb")`,
# tiling part meshes `mesh("a.glb", ...)` and example assemblies `assembly("a.glb")`.
_FILE_CALLS = {"op": {"i"}, "call": {"mesh", "assembly"}}


def confined_files(grammar: Any, root: Path) -> list[dict]:
    """Diagnostics, at check time, for the literal file names of the grammar (inserted assets,
    part meshes, examples, asset folders) that lie outside the grammar's folder, so the editor
    underlines them before anything is derived. Only a convenience: names computed at derive
    time (consts, attrs, concatenations, fileRandom) are refused where the file is opened, by
    `grammarkit.confine`, whatever this finds."""
    from grammarkit.ir import Node

    problems = []

    def check(value: str, node: Any, what: str) -> None:
        span = getattr(node, "span", None)
        base = Path(span.file).parent if span is not None and span.file else root
        with confine.confined(root, who=WHO):
            refused = confine.refusal(value, base=base, what=what, span=span)
        if refused is not None:
            problems.append(refused.to_json())

    for folder in getattr(grammar, "asset_dirs", ()) or ():
        check(folder, grammar, "asset folder")

    stack = [grammar]
    while stack:
        node = stack.pop()
        if isinstance(node, (tuple, list)):
            stack.extend(node)
            continue
        if not isinstance(node, Node):
            continue
        kind = getattr(node, "kind", None)
        name = getattr(node, "name", None) if kind == "op" else getattr(node, "func", None)
        if kind in _FILE_CALLS and name in _FILE_CALLS[kind] and node.args:
            first = node.args[0]
            if kind == "op":
                first = first.value  # an operation's Arg wraps its expression
            if getattr(first, "kind", None) == "str" and not first.value.startswith("builtin:"):
                check(first.value, node, "mesh file")
        if kind == "example" and node.source:
            check(node.source, node, "example file")
        stack.extend(getattr(node, f) for f in type(node).model_fields if f != "span")
    return problems


class Analysis:
    """One grammar text, checked: diagnostics, the IR (imports inlined) when it has no error."""

    def __init__(self, text: str, path: Path, root: Path, registries: Any = None):
        from grammarkit.dsl import check_text

        t0 = time.perf_counter()
        self.text = text
        self.grammar = None
        # imports outside the folder are refused by the import resolver itself (confined by
        # the Work operation that asked for this analysis), before it looks at the file
        grammar, diags = check_text(text, filename=str(path), registries=registries)
        self.diagnostics = [d.to_json() for d in diags]
        if grammar is not None:
            self.diagnostics += confined_files(grammar, root)
        if not any(d["severity"] == "error" for d in self.diagnostics):
            self.grammar = grammar
        self.seconds = time.perf_counter() - t0
        self.values: dict[str, Any] = {}
        if self.grammar is not None and self.grammar.family == "split":
            from grammarkit.split import check_attrs

            try:
                self.values = check_attrs(self.grammar, {}, registries=registries)
            except GrammarkitError as exc:
                self.diagnostics += [d.to_json() for d in _diagnostics_of(exc)]
                self.grammar = None

    @property
    def ok(self) -> bool:
        return self.grammar is not None

    def summary(self) -> dict:
        g = self.grammar
        return {"ok": self.ok, "diagnostics": self.diagnostics,
                "family": g.family if g is not None else None,
                "name": g.name if g is not None else None,
                "sliders": sliders(g, self.values) if g is not None and g.family == "split" else [],
                "object_types": sorted({s.object_type for s in g.snippets}) if g is not None else [],
                "check_ms": round(1000 * self.seconds, 1)}


def _diagnostics_of(exc: GrammarkitError) -> list[Any]:
    diags = list(getattr(exc, "diagnostics", None) or [])
    if not diags:
        from grammarkit.errors import Diagnostic

        diags = [Diagnostic("error", str(getattr(exc, "message", None) or exc), getattr(exc, "span", None),
                            code=getattr(exc, "code", None))]
    return diags


def error_json(exc: BaseException) -> dict:
    """A grammarkit error as the page shows it: the formatted message plus located diagnostics."""
    if isinstance(exc, GrammarkitError):
        return {"message": exc.format() if hasattr(exc, "format") else str(exc),
                "diagnostics": [d.to_json() for d in _diagnostics_of(exc)]}
    return {"message": f"{type(exc).__name__}: {exc}", "diagnostics": []}


def _confined(method: Callable) -> Callable:
    """Run a Work operation confined to the grammar's folder (every file it opens is checked)."""

    @functools.wraps(method)
    def run(self: "Work", *args: Any, **kwargs: Any) -> Any:
        with confine.confined(self.root, who=WHO):
            return method(self, *args, **kwargs)

    return run


def _confined_steps(method: Callable) -> Callable:
    """`_confined` for a generator: each step runs confined, and the policy is never left set
    between steps (the consumer's code runs unconfined, and closing the generator elsewhere
    cannot reset a context variable of another context)."""

    @functools.wraps(method)
    def run(self: "Work", *args: Any, **kwargs: Any) -> Iterator[Any]:
        steps = method(self, *args, **kwargs)
        try:
            while True:
                with confine.confined(self.root, who=WHO):
                    try:
                        item = next(steps)
                    except StopIteration:
                        return
                yield item
        finally:
            with confine.confined(self.root, who=WHO), contextlib.suppress(Exception):
                steps.close()

    return run


class Work:
    """The worker process's state: text analyses (LRU), the current model, the registries."""

    def __init__(self, path: str, root: str):
        self.path = Path(path)
        self.root = Path(root)
        self._analyses: dict[str, Analysis] = {}
        self.model: Any = None  # the last model shown (split Model or tiling Assembly)
        self.model_kind: str | None = None
        self._parents: dict[int, int] | None = None  # shape id -> parent id, of self.model
        self._tree: dict | None = None  # the compact tree of self.model
        self._registries = None
        self.gallery_models: list[Any] = []  # the last gallery's models, by index (for export)

    # -- plumbing ------------------------------------------------------------------------------
    @property
    def registries(self) -> Any:
        if self._registries is None:
            from grammarkit.plugins import get_plugin_manager

            self._registries = get_plugin_manager().registries()
        return self._registries

    def analysis(self, text: str) -> Analysis:
        hit = self._analyses.pop(text, None)
        if hit is None:
            hit = Analysis(text, self.path, self.root, self.registries)
        self._analyses[text] = hit  # most recent last
        while len(self._analyses) > _CACHE:
            self._analyses.pop(next(iter(self._analyses)))
        return hit

    def encode(self, model: Any, fmt: str) -> bytes:
        from grammarkit.run import Result, encode_result

        return encode_result(Result(id="studio", index=0, model=model), fmt, self.registries)

    # -- operations (called by name from worker.py) ----------------------------------------------
    @_confined
    def warm(self, text: str) -> dict:
        """Import the engine, read the plugins and analyse the text before the page asks."""
        out = self.check(text)
        if out["ok"] and out["family"] == "split":
            self.derive(text, {}, 0)
        return out

    @_confined
    def check(self, text: str) -> dict:
        return self.analysis(text).summary()

    @_confined
    def derive(self, text: str, attrs: dict, seed: int, example: int = 0,
               variation: int | None = None) -> dict:
        """The model of the text (split: derived with attrs and seed, or variation `variation`
        of the seed; tiling: example `example`) as GLB bytes plus facts about it."""
        t_in = time.perf_counter()
        a = self.analysis(text)
        if not a.ok:
            return {"ok": False, "check": a.summary()}
        t0 = time.perf_counter()
        facts: dict[str, Any] = {}
        if a.grammar.family == "empty":
            return {"ok": False, "check": a.summary(),
                    "error": {"message": "the grammar has no rules, parts or examples yet: nothing to show",
                              "diagnostics": []}}
        if a.grammar.family == "split":
            from grammarkit.split import Limits, derive, variations

            # the engine's limits guard depth, shapes, repeats, triangles and solids; the
            # worker's time budget (worker.py) guards the time
            limits = Limits()
            if variation is not None:
                (var, model), = variations(a.grammar, 1, seed=seed, attrs=attrs, start=int(variation),
                                           limits=limits, registries=self.registries)
                facts["variation"] = var.to_dict()
            else:
                model = derive(a.grammar, seed=seed, attrs=attrs, limits=limits, registries=self.registries)
            # (no part count here: building Model.parts costs ~5 ms an edit; the tree has them)
            facts.update(seed=model.seed, triangles=model.triangle_count, shapes=model.shape_count,
                         warnings=list(model.warnings), attrs=model.attrs, bindings=model.bindings)
            kind = "split"
        else:
            from grammarkit.tiling import load_examples

            examples = load_examples(a.grammar)
            if not examples:
                return {"ok": False, "check": a.summary(),
                        "error": {"message": "this tiling grammar has no `example` to show; use the "
                                             "gallery to sample variants", "diagnostics": []}}
            model = examples[max(0, min(int(example), len(examples) - 1))]
            facts.update(parts=len(model.parts), examples=len(examples), example=model.name)
            kind = "tiling"
        t1 = time.perf_counter()
        glb = self.encode(model, "glb")
        t2 = time.perf_counter()
        self.model, self.model_kind, self._parents, self._tree = model, kind, None, None
        facts.update(kind=kind, derive_ms=round(1000 * (t1 - t0), 1), export_ms=round(1000 * (t2 - t1), 1))
        out = {"ok": True, "glb": glb, "facts": _jsonable(facts), "check": a.summary()}
        out["facts"]["work_ms"] = round(1000 * (time.perf_counter() - t_in), 1)
        return out

    @_confined
    def export(self, fmt: str, gallery: int | None = None) -> dict:
        """The model in the view (or the gallery's variant `gallery`) in format `fmt`."""
        fmt = str(fmt).lower()
        if fmt not in EXPORT_FORMATS:
            raise StudioError(f"unknown export format {fmt!r}; the studio exports {', '.join(EXPORT_FORMATS)}")
        if gallery is not None:
            if not 0 <= gallery < len(self.gallery_models):
                raise StudioError(f"the gallery has no variant {gallery} (sample again)")
            model = self.gallery_models[gallery]
        elif self.model is None:
            raise StudioError("there is no model to export yet (the grammar has errors?)")
        else:
            model = self.model
        name = getattr(model, "name", None) or self.path.stem
        return {"data": self.encode(model, fmt), "filename": f"{name}.{fmt}"}

    @_confined
    def tree(self) -> dict:
        """The derivation tree of the current split model, compact: one row per shape
        [id, parent, rule, via, file index, line, terminal], the files listed once."""
        if self.model_kind != "split":
            return {"nodes": [], "files": []}
        if self._tree is not None:
            return self._tree
        files: list[str] = []
        file_index: dict[str | None, int] = {}
        rows = []
        stack = [self.model.tree]
        while stack:
            n = stack.pop()
            fi = file_index.get(n.file)
            if fi is None:
                fi = file_index[n.file] = len(files)
                files.append(n.file or "")
            rows.append([n.id, n.parent, n.rule, n.via, fi, n.line or 0, n.terminal])
            stack.extend(reversed(n.children))
        rows.sort(key=lambda r: r[0])
        self._tree = {"nodes": rows, "files": files}
        return self._tree

    @_confined
    def pick(self, point: list[float], terminal: str | None = None) -> dict:
        """The terminal part under a clicked point (model frame, Z up): among the parts named
        `terminal` (all parts if None), the one whose scope box is nearest the point, ties to
        the smaller box. Returns the part and its path of shapes from the axiom."""
        if self.model_kind != "split":
            raise StudioError("picking parts needs a split model")
        import numpy as np

        p = np.asarray(point, dtype=np.float64).reshape(3)
        parts = [q for q in self.model.parts if terminal is None or q.name == terminal] or list(self.model.parts)
        best, best_key = None, None
        for q in parts:
            o = np.asarray(q.origin)
            axes = np.asarray(q.axes, dtype=np.float64)
            size = np.asarray(q.size, dtype=np.float64)
            local = axes @ (p - o)
            outside = np.maximum(0.0, np.maximum(-local, local - size))
            key = (round(float(np.linalg.norm(outside)), 4), float(np.prod(np.where(size > 0, size, 1.0))))
            if best_key is None or key < best_key:
                best, best_key = q, key
        if best is None:
            raise StudioError("the model has no parts")
        tree = self.tree()
        row = tree["nodes"][best.node] if 0 <= best.node < len(tree["nodes"]) else None
        source = {"file": tree["files"][row[4]], "line": row[5]} if row is not None and row[5] else None
        return {"part": best.to_dict(), "distance": best_key[0], "path": self.path_of(best.node),
                "source": source}

    def _parent_table(self) -> dict[int, int]:
        if self._parents is None:
            self._parents = {r[0]: r[1] for r in self.tree()["nodes"]}
        return self._parents

    def path_of(self, node: int) -> list[int]:
        """Shape ids from the axiom down to `node`."""
        parents = self._parent_table()
        out = []
        while node >= 0 and len(out) < 100_000:
            out.append(node)
            node = parents.get(node, -1)
        return out[::-1]

    @_confined
    def node_box(self, nodes: list[int]) -> dict:
        """The terminal parts below the shapes `nodes` (their scopes: origin, axes, size)."""
        if self.model_kind != "split":
            raise StudioError("shapes exist for split models only")
        children: dict[int, list[int]] = {}
        for c, p in self._parent_table().items():
            children.setdefault(p, []).append(c)
        below, stack = set(), [int(n) for n in nodes]
        while stack:
            n = stack.pop()
            if n not in below:
                below.add(n)
                stack.extend(children.get(n, ()))
        parts = [q.to_dict() for q in self.model.parts if q.node in below]
        return {"parts": parts[:5000], "count": len(parts)}

    @_confined
    def format_text(self, text: str) -> dict:
        """The canonical text of the grammar (grammarkit's printer), imports kept as written."""
        from grammarkit.dsl import parse
        from grammarkit.printer import format_grammar

        return {"text": format_grammar(parse(text, filename=str(self.path)))}

    @_confined_steps
    def gallery(self, text: str, n: int, seed: int, backend: str | None = None,
                iterations: int = 1, options: dict | None = None, attrs: dict | None = None,
                timeout: float | None = None) -> Iterator[dict]:
        """Sampled variants, one dict at a time (GLB, PNG thumbnail, facts, validation report):
        split grammars through the split back end's variations, tiling grammars through any
        tiling back end (`backend`, default: the grammar's default one)."""
        from grammarkit.run import iter_results, preview_png

        a = self.analysis(text)
        if not a.ok:
            raise StudioError("the grammar has errors: fix them before sampling")
        g = a.grammar
        opts = dict(options or {})
        if g.family == "split":
            backend = backend or "split"
            opts.setdefault("variations", True)
        t0 = time.perf_counter()
        count = 0
        self.gallery_models = []
        # workers=1: the confinement is this process's (a worker process would not inherit it)
        for result in iter_results(g, backend=backend, n=n, seed=seed, iterations=iterations,
                                   options=opts, attrs=attrs if g.family == "split" else None,
                                   timeout=timeout, workers=1, registries=self.registries):
            model = result.model
            item: dict[str, Any] = {"id": result.id, "index": result.index, "seed": result.seed,
                                    "parents": list(result.parents),
                                    "metrics": _jsonable(result.metrics)}
            if g.family == "tiling":
                from grammarkit.tiling import validate

                report = validate(g, model)
                item["report"] = _jsonable(report.to_json())
                item["report_text"] = report.format()
            else:
                item["variation"] = _jsonable({k: result.extra.get(k) for k in ("attrs", "bindings")})
                item["seed"] = result.seed
            item["glb"] = self.encode(model, "glb")
            item["png"] = preview_png(model, (192, 192))
            self.gallery_models.append(model)
            count += 1
            yield item
        yield {"done": True, "count": count, "requested": n,
               "seconds": round(time.perf_counter() - t0, 2),
               "shortfall": None if count >= n else f"the back end made {count} of {n} variants "
                                                     "(it found no more distinct valid ones)"}

    @_confined
    def backends(self, text: str) -> dict:
        a = self.analysis(text)
        family = a.grammar.family if a.ok else None
        return {"family": family,
                "backends": sorted(name for name, spec in self.registries.backends.items()
                                   if family in spec.families)}

    @_confined
    def sketch(self, strokes: list, width: int, height: int, object_type: str, text: str) -> dict:
        """The sketch recognizer's top candidates for a drawing (see sketching.py)."""
        from .sketching import recognize_sketch

        a = self.analysis(text)
        if not a.ok or a.grammar.family != "split":
            raise StudioError("sketching needs a split grammar without errors")
        return recognize_sketch(strokes, width, height, object_type, text, self.path, a.grammar)

    @_confined
    def sketch_canvas(self, object_type: str, text: str) -> dict:
        """The canvas an object type is drawn on (size and anchor outline; see sketching.py)."""
        from .sketching import sketch_canvas

        a = self.analysis(text)
        if not a.ok or a.grammar.family != "split":
            raise StudioError("sketching needs a split grammar without errors")
        return sketch_canvas(object_type, a.grammar)


def _jsonable(value: Any) -> Any:
    from grammarkit.jsonable import to_jsonable

    return to_jsonable(value)
