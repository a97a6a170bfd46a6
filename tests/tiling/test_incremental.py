"""grammarkit.tiling.incremental: contacts of edited parts equal a full recompute; the part
cache and PartGeometry's public solid seeding keep results; partial rule checks agree with
the full validation."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import trimesh

from grammarkit.tiling import (
    ForbiddenContact, Part, PartCache, Rules, bounds_of, contacts, contacts_involving,
    edit_violations, full_check, moved_mesh, part_key, prepare,
)

_spec = importlib.util.spec_from_file_location("_tiling_helpers", Path(__file__).with_name("_tiling_helpers.py"))
_helpers = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_helpers)


def _all_edges(meshes, types, tol):
    parts = [Part(str(i), t, m) for i, (m, t) in enumerate(zip(meshes, types))]
    return {(c.a, c.b) for c in contacts(parts, tol)}


def _ring_of_spheres(n=10, ring=3.1):
    """Closed (non-box) meshes, so the manifold3d narrow phase and its solids are used."""
    meshes, types = [], []
    for k in range(n):
        a = 2 * np.pi * k / n
        m = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        m.apply_translation([ring * np.cos(a), ring * np.sin(a), 0])
        meshes.append(m)
        types.append("Ball")
    return meshes, types


def test_moved_mesh_and_bounds():
    box = trimesh.creation.box(extents=(1, 2, 3))
    assert moved_mesh(box, np.eye(4)) is box
    T = np.eye(4)
    T[:3, 3] = [5, 0, 0]
    lo, hi = bounds_of([box, moved_mesh(box, T)])
    assert np.allclose(lo[1] - lo[0], [5, 0, 0]) and np.allclose(hi[0], [0.5, 1, 1.5])


@pytest.mark.parametrize("which", ["lattice", "spheres"])
def test_contacts_involving_equal_the_full_recompute(which):
    if which == "lattice":
        asm = _helpers.lattice(4, 3, 2)
        meshes, types = [p.mesh for p in asm.parts], [p.type for p in asm.parts]
    else:
        meshes, types = _ring_of_spheres()
    tol = 1e-3 * 10
    full = _all_edges(meshes, types, tol)
    lo, hi = bounds_of(meshes)
    rng = np.random.default_rng(0)
    for _ in range(5):
        new = sorted(rng.choice(len(meshes), size=4, replace=False).tolist())
        got = contacts_involving(meshes, types, new, tol, lo, hi)
        assert got == {e for e in full if e[0] in new or e[1] in new}
        # with the cache, twice (the second call reads bounds and solids from the cache)
        cache = PartCache()
        keys = [part_key(i, np.eye(4)) for i in range(len(meshes))]
        for _ in range(2):
            assert contacts_involving(meshes, types, new, tol, lo, hi, keys=keys, cache=cache) == got
        if which == "spheres":
            assert cache.solids and all(s is not None for s in cache.solids.values())


def test_part_geometry_seeds_and_shares_its_solids():
    meshes, types = _ring_of_spheres(6, 1.9)  # neighbours overlap (chord 1.9 < 2 radii): all measured
    parts = [Part(str(i), t, m) for i, (m, t) in enumerate(zip(meshes, types))]
    g1 = prepare(parts)
    first = contacts(parts, 0.3, geom=g1)
    solids = g1.known_solids()
    assert set(solids) == set(range(6))
    g2 = prepare(parts)
    g2.seed_solids(solids)
    assert contacts(parts, 0.3, geom=g2) == first
    assert all(g2.known_solids()[k] is solids[k] for k in solids)  # reused, not rebuilt


def test_forbidden_pairs_are_reported_first():
    rules = Rules(name="r", types=frozenset({"Node", "Beam"}), pairs=frozenset({("Beam", "Node")}))
    asm = _helpers.lattice(2, 1, 1)
    meshes, types = [p.mesh for p in asm.parts], [p.type for p in asm.parts]
    lo, hi = bounds_of(meshes)
    # fine as it is
    contacts_involving(meshes, types, range(len(meshes)), 0.01, lo, hi, rules)
    # a second cube pushed onto the first: Node -- Node is no allowed pair
    T = np.eye(4)
    T[:3, 3] = [0.9, 0, 0]
    meshes2 = meshes + [moved_mesh(meshes[0], T)]
    types2 = types + ["Node"]
    lo2, hi2 = bounds_of(meshes2)
    with pytest.raises(ForbiddenContact, match="Node"):
        contacts_involving(meshes2, types2, [len(meshes)], 0.01, lo2, hi2, rules)


def test_edit_violations_agree_with_the_full_check():
    rules = Rules(name="r", types=frozenset({"Node", "Beam"}), pairs=frozenset({("Beam", "Node")}),
                  neighbor_multisets={"Beam": frozenset({("Node", "Node")})},
                  constraints=(("connected", {}, "test"),))
    asm = _helpers.lattice(3, 1, 1)
    meshes, types = [p.mesh for p in asm.parts], [p.type for p in asm.parts]
    edges, problems = full_check(rules, meshes, types, 0.01)
    assert problems == []
    cents = prepare(asm.parts).centroid
    assert edit_violations(rules, types, sorted(edges), meshes, cents, 0.01, []) == []
    # drop the last cube: the beam before it has one Node neighbour only
    keep = list(range(len(meshes) - 1))
    m2, t2 = [meshes[i] for i in keep], [types[i] for i in keep]
    e2, p2 = full_check(rules, m2, t2, 0.01)
    got = edit_violations(rules, t2, sorted(e2), m2, cents[keep], 0.01, [])
    assert p2 and got and ("Beam" in got[0]) == ("Beam" in p2[0])
