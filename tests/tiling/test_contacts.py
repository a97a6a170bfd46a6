import numpy as np
import trimesh

from grammarkit.tiling import Assembly, Part, shape_graph
from grammarkit.tiling.contacts import (
    candidate_pairs, candidate_pairs_bruteforce, contacts, default_tolerance, prepare,
)

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _tiling_helpers import box_part, lattice  # noqa: E402


def edges(g):
    return {tuple(sorted(e)) for e in g.edges()}


def test_touching_apart_nested_and_overlapping_boxes():
    a = Assembly([
        box_part("A.0", "A", (0, 0, 0)),
        box_part("A.1", "A", (1, 0, 0)),          # face to face with A.0
        box_part("A.2", "A", (3, 0, 0)),          # 1.0 away from A.1
        box_part("B.0", "B", (0, 0, 0), (0.2, 0.2, 0.2)),  # inside A.0
        box_part("B.1", "B", (3.5, 0, 0.9)),      # overlaps A.2 deeply
    ])
    g = shape_graph(a)
    assert edges(g) == {("A.0", "A.1"), ("A.0", "B.0"), ("A.2", "B.1")}
    assert g.edges["A.2", "B.1"]["kind"] == "overlap"
    assert g.edges["A.0", "A.1"]["kind"] == "touch"
    assert g.nodes["A.1"]["type"] == "A"
    np.testing.assert_allclose(g.nodes["A.1"]["centroid"], (1, 0, 0), atol=1e-12)


def test_gap_within_and_beyond_tolerance():
    for gap, expected in ((0.0005, True), (0.05, False)):
        a = Assembly([box_part("A.0", "A", (0, 0, 0)), box_part("A.1", "A", (1 + gap, 0, 0))])
        # tolerance is relative: 0.001 x diagonal (about 2.2) = 0.0022
        assert (shape_graph(a).number_of_edges() == 1) is expected, gap


def test_rotated_parts_use_exact_surface_distance():
    # a box rotated 45 degrees: its bounding box reaches the neighbour, its surface does not
    rotated = box_part("R.0", "R", (0, 0, 0), rot_z=45)
    near = box_part("A.0", "A", (1.2, 1.2, 0))  # corner region of the AABBs overlaps
    touching = box_part("A.1", "A", (-(np.sqrt(2) / 2 + 0.5), 0, 0))  # face touches the rotated tip
    g = shape_graph(Assembly([rotated, near, touching]))
    assert edges(g) == {("A.1", "R.0")}


def test_open_mesh_fallback_detects_touching_and_apart():
    box = trimesh.creation.box(extents=(1, 1, 1))
    open_mesh = trimesh.Trimesh(box.vertices, box.faces[:-2], process=False)  # one face missing
    p_open = Part("O.0", "O", open_mesh)
    touching = box_part("A.0", "A", (1, 0, 0))
    apart = box_part("A.1", "A", (0, 0, 2.0))
    g = shape_graph(Assembly([p_open, touching, apart]))
    assert edges(g) == {("A.0", "O.0")}


def test_box_fast_path_agrees_with_manifold_path():
    rng = np.random.default_rng(3)
    parts = [box_part(f"A.{i}", "A", rng.uniform(0, 6, 3), rng.uniform(0.5, 1.5, 3)) for i in range(40)]
    a = Assembly(parts)
    geom = prepare(parts)
    assert geom.boxy.all()
    tol = default_tolerance(a)
    fast = {(c.a, c.b) for c in contacts(a, tol)}
    geom.boxy[:] = False  # force the general (manifold3d min_gap) narrow phase
    slow = {(c.a, c.b) for c in contacts(a, tol, geom=geom)}
    assert fast == slow and len(fast) > 10


def test_box_detection_rejects_non_boxes():
    box = trimesh.creation.box(extents=(1, 2, 3))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2], process=False)
    cyl = trimesh.creation.cylinder(radius=1, height=1, sections=8)
    geom = prepare([Part("a", "a", box), Part("b", "b", open_box), Part("c", "c", cyl)])
    assert geom.boxy.tolist() == [True, False, False]


def test_rtree_broad_phase_equals_brute_force():
    rng = np.random.default_rng(7)
    parts = [box_part(f"A.{i}", "A", rng.uniform(0, 20, 3), rng.uniform(0.2, 3, 3)) for i in range(300)]
    geom = prepare(parts)
    for tol in (0.0, 0.05, 0.5):
        fast = {tuple(p) for p in candidate_pairs(geom, tol).tolist()}
        brute = {tuple(p) for p in candidate_pairs_bruteforce(geom, tol).tolist()}
        assert fast == brute


def test_lattice_graph_structure():
    a = lattice(3, 3, 2)
    g = shape_graph(a)
    # every beam touches exactly its two cubes; cubes never touch each other or other beams
    for n, d in g.nodes(data=True):
        nbr = [g.nodes[m]["type"] for m in g.neighbors(n)]
        if d["type"] == "Beam":
            assert sorted(nbr) == ["Node", "Node"]
        else:
            assert set(nbr) == {"Beam"}
    n_beams = sum(1 for p in a.parts if p.type == "Beam")
    assert g.number_of_edges() == 2 * n_beams


def test_empty_and_single_part_assemblies():
    assert shape_graph(Assembly([])).number_of_nodes() == 0
    g = shape_graph(Assembly([box_part("A.0", "A", (0, 0, 0))]))
    assert g.number_of_nodes() == 1 and g.number_of_edges() == 0


def test_open_meshes_crossing_without_any_vertex_near():
    quad = lambda v: trimesh.Trimesh(np.array(v, float), [[0, 1, 2], [0, 2, 3]], process=False)  # noqa: E731
    flat = quad([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    upright = quad([(0, -0.5, -1), (0, 0.5, -1), (0, 0.5, 1), (0, -0.5, 1)])
    far = quad([(5, -0.5, -1), (5, 0.5, -1), (5, 0.5, 1), (5, -0.5, 1)])
    g = shape_graph(Assembly([Part("F.0", "F", flat), Part("U.0", "U", upright), Part("U.1", "U", far)]))
    assert edges(g) == {("F.0", "U.0")}
