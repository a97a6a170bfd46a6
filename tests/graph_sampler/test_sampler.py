"""The sampler end to end on a small castle: validity, incremental graphs, determinism, dedupe."""
import numpy as np
import pytest

from grammarkit.tiling import shape_graph, validate
from grammarkit_graph_sampler import geometry
from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions

# counts="grammar": the lattice examples' counts are nearly equal (8-9 towers), and these tests
# are about the method's steps, not about the count range (test_counts.py)
OPTS = SamplerOptions(attempts_per_shape=64, min_attempts=256, batch_size=16, dedupe="histogram",
                      counts="grammar")
KIT = None


@pytest.fixture(scope="module", autouse=True)
def _kit(kit):
    global KIT
    KIT = kit


def castle_rules():
    return KIT.rules()


def examples():
    return KIT.examples()


def run(workers=1, seed=7, n=10, iterations=3, **kw):
    from grammarkit.run.executor import LocalExecutor

    opts = OPTS.model_copy(update=kw)
    # "always": two workers really run the attempts, however small the job
    s = GraphSampler(rules=castle_rules(), examples=examples(), seed=seed, options=opts,
                     executor=LocalExecutor(workers, parallel="always"))
    return s, list(s.run(n, iterations))


def fingerprint(shapes):
    return [(s.key, s.protos, s.transforms.tobytes(), s.edges, s.parents, s.operation["attempt"])
            for s in shapes]


@pytest.fixture(scope="module")
def sampled(_kit):
    return run()


def test_variants_are_new_valid_and_watertight(sampled):
    sampler, shapes = sampled
    assert len(shapes) >= 5
    rules = castle_rules()
    seen = {tuple(sorted(e.type_histogram().items())) for e in examples()}
    for shape in shapes:
        asm = sampler.to_assembly(shape)
        report = validate(rules, asm)  # the full check: graph recomputed from the geometry
        assert report.ok, report.format()
        assert all(p.mesh.is_watertight and p.mesh.is_volume for p in asm.parts)
        hist = tuple(sorted(asm.type_histogram().items()))
        assert hist not in seen  # histogram dedupe, examples included
        seen.add(hist)
        assert set(shape.parents) <= set(sampler.by_key)


def test_incremental_graph_equals_full_recompute(sampled):
    sampler, shapes = sampled
    for shape in shapes:
        asm = sampler.to_assembly(shape)
        g = shape_graph(asm, tolerance=sampler.contact_tolerance)
        full = {tuple(sorted((asm.parts[g.nodes[u]["index"]].id, asm.parts[g.nodes[v]["index"]].id)))
                for u, v in g.edges()}
        incremental = {tuple(sorted((shape.ids[a], shape.ids[b]))) for a, b in shape.edges}
        assert incremental == full
        # and at the tolerance `grammarkit validate` uses by default for this model
        assert {tuple(sorted(e)) for e in shape_graph(asm).edges()} == full


def test_full_recompute_mode_gives_the_same_variants(sampled):
    _, shapes = sampled
    _, full = run(incremental=False)
    assert fingerprint(full) == fingerprint(shapes)


def test_results_do_not_depend_on_the_number_of_workers(sampled):
    _, one = sampled
    _, two = run(workers=2)
    assert fingerprint(two) == fingerprint(one)


def test_runs_one_after_another_do_not_see_each_other(sampled):
    # Each run's executor owns its worker processes and stops them when it closes
    # (grammarkit.run.executor.WorkerPool): a later run starts from nothing of an earlier one.
    _, one = sampled
    s1, first = run(workers=2, seed=8)
    s2, again = run(workers=2)
    assert fingerprint(again) == fingerprint(one)
    assert [st.row()["outcomes"] for st in s2.stats] == [st.row()["outcomes"] for st in sampled[0].stats]
    assert fingerprint(first) != fingerprint(one)


def test_seed_changes_the_output(sampled):
    _, shapes = sampled
    _, other = run(seed=8)
    assert fingerprint(other) != fingerprint(shapes)


def test_isomorphism_dedupe_keeps_more_distinct_graphs():
    sampler, shapes = run(dedupe="isomorphism", n=40)
    hists = [tuple(sorted(s.histogram().items())) for s in shapes]
    assert len(hists) > len(set(hists))  # same type counts, different graphs: kept
    from grammarkit_graph_sampler.dedupe import Deduper

    d = Deduper("isomorphism")
    for e in sampler.examples:
        d.add(e.types, e.edges)
    assert all(d.add(s.types, s.edges) for s in shapes)  # pairwise non-isomorphic


def test_n_and_iterations_bound_the_output():
    sampler, shapes = run(n=3, iterations=3)
    assert len(shapes) == 3
    _, none = run(n=0)
    assert none == []
    _, first = run(iterations=1)
    assert all(s.iteration == 1 for s in first)
    assert [r["iteration"] for r in sampler.growth_table()][0] == 0


def test_docking_refuses_collinear_boundaries_and_aligns_rigidly():
    pts = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    assert geometry.dock(pts, pts + 1) is None
    a = np.random.default_rng(0).normal(size=(5, 3))
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    T, res = geometry.dock(a, a @ R.T + [1, 2, 3])
    assert res < 1e-9 and np.allclose(T[:3, :3], R) and np.allclose(T[:3, 3], [1, 2, 3])


def test_bad_options_are_clear_errors():
    from grammarkit.run import OptionError, parse_options

    def parse(**kw):
        return parse_options(SamplerOptions, kw, backend="graph-sampler")

    with pytest.raises(OptionError, match="no option 'tolerence'"):
        parse(tolerence="0.1")
    with pytest.raises(OptionError, match="tolerance=abc: graph-sampler option 'tolerance' expects a number"):
        parse(tolerance="abc")
    with pytest.raises(OptionError, match="dedupe"):
        parse(dedupe="wl")
    assert parse(**{"dedupe": "isomorphism", "dock-tolerance": "0.02", "incremental": "false"}).incremental is False
