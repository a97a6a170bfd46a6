"""The sampler's own graph step: deduplication (the shared graph steps are tested in
tests/tiling/test_graphops.py)."""
import pytest

from grammarkit_graph_sampler.dedupe import Deduper


def test_dedupe_histogram_versus_isomorphism():
    path = [(0, 1), (1, 2), (2, 3)]
    star = [(0, 1), (0, 2), (0, 3)]
    types = ["A", "A", "A", "A"]
    h = Deduper("histogram")
    assert h.add(types, path) and not h.add(types, star)
    iso = Deduper("isomorphism")
    assert iso.add(types, path) and iso.add(types, star)
    relabelled = [(3, 2), (2, 0), (0, 1)]  # a path again
    assert not iso.add(types, relabelled)
    # types matter for isomorphism
    assert iso.add(["B", "A", "A", "A"], path)
    with pytest.raises(ValueError):
        Deduper("nope")


def test_geometric_keys_see_through_translation_and_part_symmetry_only():
    import numpy as np
    import trimesh

    from grammarkit_graph_sampler.dedupe import Orientations, geometric_key, source_geometry

    square = trimesh.creation.box(extents=(2, 2, 4))  # a 90-degree symmetry about z
    plank = trimesh.creation.box(extents=(4, 1, 2))  # 180 degrees only
    geo, poses, local = source_geometry([square, plank], [np.eye(4), np.eye(4)], ["Tower", "Wall"], 1e-3)
    assert geo.tolist() == [0, 1]
    orient = Orientations(local, 1e-3)

    def at(angle, x):
        T = np.eye(4)
        c, s = np.cos(angle), np.sin(angle)
        T[:2, :2] = [[c, -s], [s, c]]
        T[:3, 3] = [x, 0, 0]
        return T

    def key(*placements):
        g = np.array([k for k, _ in placements])
        return geometric_key(g, np.array([T for _, T in placements]), 1e-3, orient)

    base = key((0, at(0, 0)), (1, at(0, 3)))
    assert key((1, at(0, 3)), (0, at(0, 0))) == base  # node order does not matter
    assert key((0, at(0, 10)), (1, at(0, 13))) == base  # nor a translation of the whole
    assert key((0, at(np.pi / 2, 0)), (1, at(np.pi, 3))) == base  # each part turned by its own symmetry
    assert key((0, at(0, 0)), (1, at(np.pi / 2, 3))) != base  # the plank turned: another shape
    assert key((0, at(0, 0)), (1, at(0, 3.01))) != base  # moved by 10 x the step: another shape


def test_isomorphism_dedupe_with_and_without_geometric_keys_keeps_the_same_variants(kit):
    from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions

    runs = {}
    for geometric in (True, False):
        opts = SamplerOptions(attempts_per_shape=16, min_attempts=128, max_attempts=256, batch_size=16,
                              geometric_keys=geometric, counts="grammar")
        s = GraphSampler(rules=kit.rules(), examples=kit.examples(), seed=3, options=opts, workers=1)
        shapes = list(s.run(12, 3))
        runs[geometric] = (s, [(sh.protos, sh.transforms.round(9).tobytes(), sh.edges) for sh in shapes])
    assert runs[True][1] == runs[False][1] and runs[True][1]
    known = sum(st.outcomes["known"] for st in runs[True][0].stats)
    assert known > 0 and sum(st.outcomes["known"] for st in runs[False][0].stats) == 0


def test_part_cache_memos_answer_by_relative_placement():
    """The sampler's per-placement memos (grammarkit.tiling.incremental): a frame moves with its
    part; a pair's verdict is found again for the same relative placement anywhere."""
    import numpy as np
    import trimesh

    from grammarkit.tiling import PartCache, part_key
    from grammarkit.tiling.frames import local_frames
    from grammarkit.tiling.incremental import moved_mesh

    mesh = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=7)
    T = np.eye(4)
    c, s = np.cos(0.7), np.sin(0.7)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:3, 3] = [5, -2, 1]
    cache = PartCache()
    cache.frames[part_key(0, np.eye(4))] = local_frames([mesh])[0]
    assert np.allclose(cache.frames.get(part_key(0, T)), local_frames([moved_mesh(mesh, T)])[0], atol=1e-9)
    assert cache.frames.get(part_key(1, T)) is None  # another source part: unknown
    memo = cache.support_for(0.01)
    U = np.eye(4)
    U[:3, 3] = [0, 0, 2]
    memo[(part_key(0, np.eye(4)), part_key(0, U))] = 1
    shift = np.eye(4)
    shift[:3, 3] = [30, 4, 0]
    assert memo[(part_key(0, shift), part_key(0, shift @ U))] == 1  # the same pair elsewhere
    assert (part_key(0, np.eye(4)), part_key(0, T)) not in memo
