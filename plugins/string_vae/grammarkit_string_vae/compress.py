"""Shape compression (Kalojanov et al. 2019, section 7): a shape as a string and its edge
categories, rebuilt from the example parts.

`compress(assembly, ...)` writes the shape graph as a string (deterministic traversal from
the first part), the edge category of every character (from the geometry: each edge's
placement between canonical frames classified among the model's categories), and the first
part's frame and geometry variant. `decompress` places the first part by that frame and every
other part through the category of its tree edge; with categories that are actual dockings of
the input shapes this rebuilds the shape exactly (up to rounding, and up to each part's own
symmetry: a part may come back turned onto itself, the same geometry).
"""
from __future__ import annotations

import json
from typing import Any

import numpy as np

from grammarkit.errors import GrammarkitError, ShapeError

from .categories import EdgeCategories, canonical_frames, relative_placement, variant_key
from .graphs import TypedGraph
from .strings import Alphabet, decode, encode_with_order, tokenize

__all__ = ["COMPRESSED_FORMAT", "compress", "decompress"]

COMPRESSED_FORMAT = "grammarkit-compressed-shape"
VERSION = 1


def _graph_and_frames(assembly: Any, tolerance: float | None):  # noqa: ANN202
    from grammarkit.tiling import local_frame, shape_graph

    sg = shape_graph(assembly, tolerance)
    order = {p.id: k for k, p in enumerate(assembly.parts)}
    g = TypedGraph.make([p.type for p in assembly.parts], [(order[u], order[v]) for u, v in sg.edges()])
    frames = np.array([local_frame(p) for p in assembly.parts])
    return g, frames


def compress(assembly: Any, cats: EdgeCategories, alphabet: Alphabet, *, grammar_name: str, grammar_hash: str,
             tolerance: float | None = None) -> dict:
    """The (string, categories) record of a shape; a ShapeError names an edge whose placement
    is none of the categories."""
    import networkx as nx

    g, F = _graph_and_frames(assembly, tolerance)
    if not nx.is_connected(g.to_networkx()):
        raise ShapeError(f"{assembly.name}: the shape falls apart into several pieces; one string describes "
                         "one connected shape")
    variants = [variant_key(p) for p in assembly.parts]
    text, order = encode_with_order(g, alphabet)
    parsed = decode(text, alphabet)
    toks = tokenize(text, alphabet)
    at = {t.index: k for k, t in enumerate(toks)}
    categories: list[int | None] = [None] * len(toks)
    edges: list[tuple[int, int, int]] = [(p, c, at[parsed.node_index[c]]) for p, c in parsed.tree_edges]
    for (o, c), (i, j) in zip(parsed.ring_edges, parsed.ring_chars):
        edges += [(o, c, at[i]), (o, c, at[j])]
    ids = [p.id for p in assembly.parts]

    def category(u: int, v: int, rel: np.ndarray) -> int:
        cat, d = cats.classify(g.types[u], g.types[v], rel, variants[u], variants[v])
        if cat is None:
            where = "in no known docking orientation" if not np.isfinite(d) else f"{d:.3f} part sizes from the nearest"
            raise ShapeError(f"{assembly.name}: parts {ids[u]} and {ids[v]} touch at a placement that no edge "
                             f"category of the model has ({where}); the model was trained on other shapes")
        return cat

    Fc = canonical_frames(cats, g.types, F, variants, g.edges)
    for a, b, k in edges:
        u, v = order[a], order[b]
        categories[k] = category(u, v, relative_placement(Fc[u], Fc[v]))
    first = order[0]
    return {"format": COMPRESSED_FORMAT, "version": VERSION, "grammar": grammar_name, "grammar_hash": grammar_hash,
            "string": text, "categories": categories,
            "start": [round(float(x), 9) for x in Fc[first].ravel()], "start_variant": variants[first],
            "parts": len(g), "ids": [ids[order[k]] for k in range(len(order))]}


def decompress(record: dict, cats: EdgeCategories, alphabet: Alphabet, instantiator: Any) -> Any:
    """The Assembly a compressed record describes (parts named Type.k in string order, or by the
    recorded ids)."""
    from grammarkit.tiling import Assembly

    if not isinstance(record, dict) or record.get("format") != COMPRESSED_FORMAT:
        raise GrammarkitError("not a grammarkit compressed shape (format field missing or different)")
    if record.get("version") != VERSION:
        raise GrammarkitError(f"compressed shape version {record.get('version')!r}; this grammarkit reads {VERSION}")
    try:
        text = str(record["string"])
        categories = list(record["categories"])
        start = np.array(record["start"], dtype=np.float64).reshape(4, 4)
    except (KeyError, TypeError, ValueError) as exc:
        raise GrammarkitError(f"damaged compressed shape ({type(exc).__name__}: {exc})") from None
    parsed = decode(text, alphabet)
    toks = tokenize(parsed.text, alphabet)
    if len(categories) != len(toks):
        raise GrammarkitError(f"the record has {len(categories)} categories for {len(toks)} string tokens")
    at = {t.index: k for k, t in enumerate(toks)}
    T = parsed.graph.types
    n = len(T)
    frames: list[np.ndarray | None] = [None] * n
    variants: list[str | None] = [None] * n
    frames[0] = start
    variants[0] = record.get("start_variant")
    for p, c in parsed.tree_edges:  # parents come before children in a string
        k = categories[at[parsed.node_index[c]]]
        if k is None or not (0 <= int(k) < len(cats)) or {cats.categories[int(k)].a, cats.categories[int(k)].b} != {T[p], T[c]}:
            raise GrammarkitError(f"character {parsed.node_index[c] + 1}: no valid edge category for the part")
        variants[c] = cats.variants(int(k), T[p], T[c])[1] or None
        frames[c] = frames[p] @ cats.placement(int(k), T[p], T[c])
    ids = record.get("ids")
    parts = []
    counts: dict[str, int] = {}
    for i, t in enumerate(T):
        j = counts.get(t, 0)
        counts[t] = j + 1
        pid = ids[i] if isinstance(ids, list) and len(ids) == n else f"{t}.{j}"
        parts.append(instantiator.part(t, frames[i], pid, variants[i]))
    return Assembly(parts, name="decompressed")


def dumps(record: dict) -> str:
    return json.dumps(record, separators=(",", ":")) + "\n"
