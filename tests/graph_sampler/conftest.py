"""A tiny castle built in code (towers joined by walls on a 6-unit lattice) and its rules."""
import numpy as np
import pytest
import trimesh

from grammarkit.tiling.assembly import Assembly, Part
from grammarkit.tiling.rules import Rules


def _box(extents, at, rot_z=False):
    m = trimesh.creation.box(extents=extents)
    T = np.eye(4)
    if rot_z:
        T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    T[:3, 3] = at
    m.apply_transform(T)
    return m, T


def lattice_castle(nx_, ny, name):
    parts = []
    k = {"Tower": 0, "Wall": 0}

    def add(t, mesh, T):
        parts.append(Part(f"{t}.{k[t]}", t, mesh, T))
        k[t] += 1

    for i in range(nx_ + 1):
        for j in range(ny + 1):
            add("Tower", *_box((2, 2, 4), (6 * i, 6 * j, 2)))
    for i in range(nx_):
        for j in range(ny + 1):
            add("Wall", *_box((4, 1, 2), (6 * i + 3, 6 * j, 1)))
    for i in range(nx_ + 1):
        for j in range(ny):
            add("Wall", *_box((4, 1, 2), (6 * i, 6 * j + 3, 1), rot_z=True))
    return Assembly(parts, name=name)


def castle_rules():
    return Rules(
        name="minicastle",
        types=frozenset({"Tower", "Wall"}),
        neighbor_counts={"Tower": [{"Wall": (2, 4)}]},
        neighbor_multisets={"Wall": frozenset({("Tower", "Tower")})},
        pairs=frozenset({("Tower", "Wall")}),
        constraints=(("connected", {}, "test"),),
    )


@pytest.fixture(scope="session")
def kit():
    """Builders for the tests (fresh objects on each call)."""
    from types import SimpleNamespace

    return SimpleNamespace(
        rules=castle_rules, lattice=lattice_castle,
        examples=lambda: [lattice_castle(2, 2, "grid22"), lattice_castle(3, 1, "strip3")])
