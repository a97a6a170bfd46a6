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
