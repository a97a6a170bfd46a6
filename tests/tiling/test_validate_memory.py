"""validate on large shapes keeps its verdicts while its memory is bounded (issue 33).

The memory work (contacts read in chunks, per-part arrays without per-part Python objects,
poses and frames in chunks, the shape graph freed as validate returns) must not change a
report: the same violations, in the same order, with the same messages. The expected verdicts
below were recorded with the implementation before that work (commit 3ab15ce).
"""
from __future__ import annotations

import gc
import importlib
import math
import sys
import weakref
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _tiling_helpers import lattice  # noqa: E402

from grammarkit.tiling import Assembly, Part, learn, shape_graph, validate  # noqa: E402

V = importlib.import_module("grammarkit.tiling.validate")  # the module (the package exports the function)
G = importlib.import_module("grammarkit.tiling.graph")


def _about(p: Part, T: np.ndarray) -> Part:
    """p moved by T applied about its mesh centroid."""
    c = np.asarray(p.mesh.centroid, dtype=np.float64)
    A, B = np.eye(4), np.eye(4)
    A[:3, 3], B[:3, 3] = c, -c
    return p.transformed(A @ T @ B)


def broken() -> Assembly:
    """A 4x3x5 lattice with one edit of each kind: shifted, turned over, yawed, removed,
    mirrored, an unknown type."""
    asm = lattice(4, 3, 5)
    parts = list(asm.parts)
    by_id = {p.id: k for k, p in enumerate(parts)}
    shift = np.eye(4)
    shift[:3, 3] = (0.21, -0.13, 0.08)
    edits = {
        "Node.0": lambda p: p.transformed(shift),
        "Beam.5": lambda p: _about(p, trimesh.transformations.rotation_matrix(math.pi / 2, (1, 0, 0))),
        "Node.23": lambda p: _about(p, trimesh.transformations.rotation_matrix(0.3, (0, 0, 1))),
        "Beam.33": None,
        "Node.41": lambda p: _about(p, np.diag([-1.0, 1.0, 1.0, 1.0])),
        "Node.64": lambda p: Part(p.id, "Alien", p.mesh, p.transform, dict(p.meta)),
    }
    for pid, edit in edits.items():
        k = by_id[pid]
        parts[k] = None if edit is None else edit(parts[k])
    return Assembly([p for p in parts if p is not None], name="broken")


@pytest.fixture(scope="module")
def grammar():
    return learn([lattice(3, 3, 3)], name="lattice")


@pytest.fixture(scope="module")
def shape():
    return broken()


# (rule, part, other part, message) of every violation of broken(), in report order, as
# validate gave them before the issue-33 memory work
EXPECTED = [
    ('unknown-type', 'Node.64', None,
     "type 'Alien' does not occur in the grammar"),
    ('pair', 'Beam.13', 'Node.64',
     'touches Node.64 (Alien), but no dock allows Beam -- Alien'),
    ('pair', 'Beam.63', 'Node.64',
     'touches Node.64 (Alien), but no dock allows Beam -- Alien'),
    ('pair', 'Node.64', 'Beam.65',
     'touches Beam.65 (Beam), but no dock allows Alien -- Beam'),
    ('pair', 'Node.64', 'Beam.66',
     'touches Beam.66 (Beam), but no dock allows Alien -- Beam'),
    ('pair', 'Node.64', 'Beam.67',
     'touches Beam.67 (Beam), but no dock allows Alien -- Beam'),
    ('orientation', 'Beam.5', None,
     'is turned over: the direction +y of its part frame points up (allowed: +z, (0.606, -0.758, 0.242), (0.515, 0.606, 0.606); 20 degrees)'),
    ('dock', 'Node.0', 'Beam.1',
     "touches Beam.1 (Beam) at a placement no `dock Node -- Beam` allows: Beam.1 sits at (0.485, -0.441, 0.467) in Node.0's frame (tolerance 0.0866, 20 degrees)"),
    ('dock', 'Node.0', 'Beam.3',
     "touches Beam.3 (Beam) at a placement no `dock Node -- Beam` allows: Beam.3 sits at (0.485, 0.784, -0.24) in Node.0's frame (tolerance 0.0866, 20 degrees)"),
    ('dock', 'Node.4', 'Beam.5',
     "touches Beam.5 (Beam) at a placement no `dock Node -- Beam` allows: Beam.5 sits at (0.577, -0.408, 0.707) in Node.4's frame (tolerance 0.0866, 20 degrees)"),
    ('dock', 'Beam.5', 'Node.56',
     "touches Node.56 (Node) at a placement no `dock Beam -- Node` allows: Node.56 sits at (0.87, -0.492, 0) in Beam.5's frame (tolerance 0.0866, 20 degrees)"),
    ('dock', 'Node.23', 'Beam.24',
     "touches Beam.24 (Beam) at a placement no `dock Node -- Beam` allows: Beam.24 sits at (0.381, -0.269, 0.884) in Node.23's frame (tolerance 0.102, 20 degrees)"),
    ('dock', 'Node.23', 'Beam.25',
     "touches Beam.25 (Beam) at a placement no `dock Node -- Beam` allows: Beam.25 sits at (0.722, -0.511, -0.467) in Node.23's frame (tolerance 0.102, 20 degrees)"),
    ('constraint grounded', None, None,
     '14 part(s) are held only sideways in runs longer than max_span=1 (no carried part below them): Beam.1, Beam.10, Beam.13, Beam.14, Beam.17, Beam.18, Beam.5, Beam.6 and 6 more'),
    ('constraint grounded', None, None,
     '4 part(s) are not carried down to the ground z=-0.5 (no chain of contacts from below or from the side): Beam.11, Beam.15, Beam.3, Beam.7'),
]


def _verdicts(report) -> list[tuple]:  # noqa: ANN001
    return [(v.rule, v.part_id, v.other_id, v.message) for v in report.violations]


def test_verdicts_as_before(grammar, shape) -> None:
    report = validate(grammar, shape, max_violations=10_000)
    assert (report.parts, report.contacts) == (192, 263)
    assert _verdicts(report) == EXPECTED


def test_chunk_sizes_do_not_change_the_report(grammar, shape, monkeypatch) -> None:
    """Chunk boundaries everywhere (contacts, frames, poses, docking placements, edges of the
    graph): the report is identical to one computed in single chunks."""
    whole = validate(grammar, shape, max_violations=10_000).to_json()
    for size in (1, 3, 7):
        for mod, name in ((V, "CHUNK"), (V, "EDGE_CHUNK"), (V, "FRAME_CHUNK"), (G, "EDGE_CHUNK")):
            monkeypatch.setattr(mod, name, size)
        assert validate(grammar, shape, max_violations=10_000).to_json() == whole, size


def test_given_and_plain_graphs_give_the_same_report(grammar, shape) -> None:
    """A shape graph passed in and a plain nx.Graph copy of it (no node arrays: the general
    path of validate) give the same report as validate's own graph."""
    own = validate(grammar, shape, max_violations=10_000).to_json()
    g = shape_graph(shape)
    assert validate(grammar, shape, graph=g, max_violations=10_000).to_json() == own
    assert validate(grammar, shape, graph=nx.Graph(g), max_violations=10_000).to_json() == own
    assert g.number_of_edges() == own["contacts"]  # a graph given by the caller stays usable


def test_max_violations_stops_at_the_same_place(grammar, shape) -> None:
    full = validate(grammar, shape, max_violations=10_000)
    for k in (1, 4, 9):
        assert _verdicts(validate(grammar, shape, max_violations=k)) == _verdicts(full)[:k]


def test_validate_frees_its_own_graph_without_a_collection(grammar, shape, monkeypatch) -> None:
    """The graph validate builds is not left as cyclic garbage (networkx's cached edge and
    degree views refer back to it) for a later full collection: at 100k parts that was a second
    graph alive during the next validate (issue 33)."""
    made = []

    def spy(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        g = G.shape_graph(*args, **kwargs)
        made.append(weakref.ref(g))
        return g

    monkeypatch.setattr(V, "shape_graph", spy)
    enabled = gc.isenabled()
    gc.disable()
    try:
        validate(grammar, shape)
        assert len(made) == 1 and made[0]() is None
    finally:
        if enabled:
            gc.enable()


def test_shape_graph_rows_and_duplicate_ids() -> None:
    from grammarkit.errors import ShapeError
    from grammarkit.tiling.contacts import prepare

    asm = lattice(3, 2, 2)
    g = shape_graph(asm)
    geom = prepare(asm.parts)
    arrays = G.node_arrays(g)
    for key in ("centroid", "lo", "hi"):
        assert not arrays[key].flags.writeable
        assert np.array_equal(arrays[key], getattr(geom, key))
    for i, p in enumerate(asm.parts):
        d = g.nodes[p.id]
        assert (d["type"], d["index"], d["box"]) == (p.type, i, True)
        assert np.array_equal(d["centroid"], geom.centroid[i])
    dup = Assembly(list(asm.parts) + [asm.parts[0]], name="dup")
    with pytest.raises(ShapeError, match="duplicate part ids"):
        shape_graph(dup)
