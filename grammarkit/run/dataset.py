"""Datasets for learning from a batch folder: attr vectors normalised by their ranges, and an
index (JSON lines always, Parquet on request) that pandas and torch read directly.

The index is derived from `manifest.jsonl` (the source of truth of a folder run), so it can be
rebuilt at any time: `write_index(folder)` (the batch does it when every item is done).

Attr vectors. Each column of `attr_vector` is one parameter that variations sample:

- a ranged attr (`@range(lo, hi)`): `(value - lo) / (hi - lo)`, in [0, 1];
- an enum attr (`@enum(a, b, c)`): one column per value, 1.0 for the value taken (one-hot).

A snippet attr is a column per snippet that may fill its anchor (`Roof.roof_deg@roof_hip` and
`Roof.roof_deg@roof_gable` have different ranges and meanings), found by compiling the grammar
with every snippet its `variants` tables may swap in. Columns of snippets not bound in an item
are 0 with `attr_mask` 0; `attr_mask` is 1 where the column applies. Attrs without a range or
enum are fixed values and not part of the vector (they are in the `attr.<key>` columns). The
layout (names, kinds, ranges) is written to `dataset.json` beside the index.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ..errors import GrammarkitError

__all__ = ["AttrColumn", "attr_layout", "attr_vector", "index_rows", "write_index",
           "INDEX_JSONL", "INDEX_PARQUET", "DATASET_JSON"]

INDEX_JSONL = "index.jsonl"
INDEX_PARQUET = "index.parquet"
DATASET_JSON = "dataset.json"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class AttrColumn:
    """One column of the attr vector."""

    name: str  # "mass_h", "Roof.roof_deg@roof_hip", "Mass.party_col@mass_rowhouse=#cfc4b0"
    key: str  # the attr's key in Model.attrs ("Roof.roof_deg")
    anchor: str | None  # the snippet copy's anchor (None: a grammar attr)
    snippet: str | None  # the snippet that must fill the anchor for the column to apply
    kind: str  # "range" or "enum"
    lo: float | None = None
    hi: float | None = None
    value: Any = None  # the enum value this one-hot column stands for


def _bound(fn: Any) -> Any:
    """An attr bound's value (they are constant expressions of the grammar)."""
    from ..expr_eval import SimpleEnv

    return fn(SimpleEnv())


def attr_layout(grammar: Any, bindings: Iterable[tuple[str, str]] = (), *,
                registries: Any = None) -> tuple[list[AttrColumn], list[dict]]:
    """The attr-vector columns of a split grammar, and the attrs left out (with why).

    Columns cover the grammar's own bindings, every snippet its `variants` tables may swap in,
    and the (anchor, snippet) pairs in `bindings` (e.g. lots' own `choices`)."""
    from ..split import compile as compile_split
    from ..split import load_grammar

    g = load_grammar(grammar, registries)
    base = compile_split(g, registries=registries)
    otype = {s.name: s.object_type for s in g.snippets}
    tables = {v.object_type: [o.snippet for o in v.options] for v in g.variants}
    pairs: set[tuple[str, str]] = set()
    for anchor, snip in sorted(base.bindings.items()):
        for option in tables.get(otype.get(snip, ""), []):
            if option != snip:
                pairs.add((anchor, option))
    pairs.update((a, s) for a, s in bindings if base.bindings.get(a) != s)
    compiled = [base]
    for anchor, option in sorted(pairs):
        try:
            compiled.append(compile_split(g, {anchor: option}, registries=registries))
        except Exception:  # noqa: BLE001 - a binding the items could not use either
            continue
    columns: dict[str, AttrColumn] = {}
    skipped: dict[str, dict] = {}
    for c in compiled:
        for key, info in c.attrs.items():
            suffix = f"@{info.snippet}" if info.scope is not None else ""
            name = key + suffix
            try:
                if info.lo is not None and info.hi is not None:
                    lo, hi = float(_bound(info.lo)), float(_bound(info.hi))
                    if name not in columns:
                        columns[name] = AttrColumn(name, key, info.scope,
                                                   info.snippet if info.scope else None, "range", lo, hi)
                elif info.choices is not None:
                    for choice in info.choices:
                        value = _bound(choice)
                        col = f"{name}={value}"
                        if col not in columns:
                            columns[col] = AttrColumn(col, key, info.scope,
                                                      info.snippet if info.scope else None, "enum",
                                                      value=value)
            except Exception as exc:  # noqa: BLE001 - a bound that is not a constant expression
                skipped[name] = {"name": name, "why": f"its range is not constant ({exc})"}
    return list(columns.values()), list(skipped.values())


def attr_vector(columns: Sequence[AttrColumn], attrs: Mapping[str, Any],
                bindings: Mapping[str, str]) -> tuple[list[float], list[int]]:
    """(vector, mask) of one item's attr values (see the module docstring)."""
    vec: list[float] = []
    mask: list[int] = []
    for col in columns:
        applies = col.key in attrs and (col.anchor is None or bindings.get(col.anchor) == col.snippet)
        if not applies:
            vec.append(0.0)
            mask.append(0)
            continue
        value = attrs[col.key]
        if col.kind == "range":
            span = (col.hi or 0.0) - (col.lo or 0.0)
            try:
                x = 0.0 if span == 0 else (float(value) - float(col.lo or 0.0)) / span
            except (TypeError, ValueError):
                x = float("nan")
            vec.append(x if math.isfinite(x) else 0.0)
        else:
            vec.append(1.0 if value == col.value else 0.0)
        mask.append(1)
    return vec, mask


def index_rows(entries: Iterable[Mapping[str, Any]], columns: Sequence[AttrColumn]) -> list[dict]:
    """Flat rows (one per manifest entry) for pandas/torch: see docs/batch.md for the columns."""
    rows = []
    for e in entries:
        metrics = e.get("metrics") or {}
        attrs = e.get("attrs") or {}
        bindings = e.get("bindings") or {}
        row: dict[str, Any] = {
            "id": e.get("id"), "index": e.get("index"), "status": e.get("status", "ok"),
            "error": e.get("error"), "seed": e.get("seed"), "file": e.get("file"),
            "triangles": metrics.get("triangles"), "seconds": metrics.get("seconds"),
        }
        for suffix, name in sorted((e.get("attachments") or {}).items()):
            style = suffix[:-4] if suffix.endswith(".png") else suffix
            row[f"render_{style}"] = name
        for key in ("lot", "feature", "part", "area_m2", "note"):
            if key in e:
                row[key] = e[key]
        for anchor, snip in sorted(bindings.items()):
            row[f"binding.{anchor}"] = snip
        for key, value in sorted(attrs.items()):
            row[f"attr.{key}"] = value
        vec, mask = attr_vector(columns, attrs, bindings) if e.get("status", "ok") == "ok" else (
            [0.0] * len(columns), [0] * len(columns))
        row["attr_vector"] = vec
        row["attr_mask"] = mask
        rows.append(row)
    return rows


def _parquet_bytes(rows: list[dict]) -> bytes:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise GrammarkitError('--index parquet needs pyarrow: pip install "grammarkit[parquet]" '
                              "(the JSON-lines index is written either way)") from None
    import io

    names: list[str] = []
    for r in rows:
        names.extend(k for k in r if k not in names)
    data = {k: [r.get(k) for r in rows] for k in names}
    arrays = {}
    for k, values in data.items():
        try:
            arrays[k] = pa.array(values)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            # a column whose values differ in type (an attr that is a number in one snippet and
            # text in another): keep it as text rather than lose it
            arrays[k] = pa.array([None if v is None else json.dumps(v) for v in values], pa.string())
    buf = io.BytesIO()
    pq.write_table(pa.table(arrays), buf)
    return buf.getvalue()


def write_index(folder: str | Path, *, grammar: Any, entries: Sequence[Mapping[str, Any]] | None = None,
                parquet: bool = False, info: Mapping[str, Any] | None = None,
                registries: Any = None) -> list[Path]:
    """Write `index.jsonl` (and `index.parquet` with parquet=True) and `dataset.json` for a batch
    folder, from its manifest (or the given entries); returns the paths written."""
    from .writer import MANIFEST, write_files

    folder = Path(folder)
    if entries is None:
        entries = [json.loads(line) for line in (folder / MANIFEST).read_text(encoding="utf-8").splitlines()
                   if line.strip()]
    seen = {(a, sn) for e in entries for a, sn in (e.get("bindings") or {}).items()}
    columns, skipped = attr_layout(grammar, seen, registries=registries)
    rows = index_rows(entries, columns)
    files: dict[Path, bytes | str] = {
        folder / INDEX_JSONL: "".join(json.dumps(r, allow_nan=False) + "\n" for r in rows)}
    if parquet:
        files[folder / INDEX_PARQUET] = _parquet_bytes(rows)
    ok = sum(1 for r in rows if r["status"] == "ok")
    meta = {"version": FORMAT_VERSION, "count": len(rows), "ok": ok, "failed": len(rows) - ok,
            "index": [p.name for p in files], "attr_vector": [asdict(c) for c in columns],
            "attrs_not_in_vector": skipped, **dict(info or {})}
    files[folder / DATASET_JSON] = json.dumps(meta, indent=1, sort_keys=True, default=str) + "\n"
    write_files(files)
    return list(files)
