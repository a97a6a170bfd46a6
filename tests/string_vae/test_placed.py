"""Placed decoding: the string and its edge categories decoded together, masked by what can
still be placed in 3D (plugins/string_vae/grammarkit_string_vae/placed.py)."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit.tiling import read_assembly, validate

from .conftest import CASTLE


@pytest.fixture(scope="module")
def shipped(castle_grammar):
    pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from grammarkit_string_vae.edgemodel import load_edge_model
    from grammarkit_string_vae.instantiate import Instantiator
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.placed import PlacedDecoder

    vae = load_vae("builtin:castle", grammar=castle_grammar)
    em = load_edge_model("builtin:castle", castle_grammar)
    inst = Instantiator(castle_grammar, em.categories)
    return vae, inst, PlacedDecoder(vae, inst, width=16)


def test_a_buildable_training_string_passes_the_placement_masks_and_builds(shipped, castle_grammar):
    vae, inst, dec = shipped
    text = min(vae.train_strings, key=len)  # the smallest training castle: a known buildable string
    d = dec.place_text(text, steps=3000)
    assert d.valid, d.error
    assert len(d.placement.frames) == len(d.graph.types)
    assert set(d.placement.categories) == set(d.graph.edges)  # a category for every edge, tree and ring
    asm, problem = inst.build(d.graph, d.placement.frames, d.placement.variants)
    assert problem is None and validate(castle_grammar, asm).ok


def test_a_ring_that_cannot_close_in_3d_is_masked_out(shipped):
    vae, inst, dec = shipped
    # a grammatical ring of four towers joined by single walls: no castle wall run is that short
    d = dec.place_text("T1WTWTWTW1", steps=2000)
    assert not d.valid and "masked out" in d.error


def test_the_length_prior_bounds_the_budget(shipped):
    vae, inst, dec = shipped
    assert dec.budget_for(40) == 46  # 40 * 1.15
    assert dec.budget_for(None) == dec.budget_for(10**6)  # never beyond the masked decoder's cap


def test_placed_decoding_needs_categories(tmp_path):
    pytest.importorskip("torch")
    res = CliRunner().invoke(main, ["derive", str(CASTLE), "--backend", "string-vae", "-n", "1",
                                    "--option", "model=builtin:castle", "--option", "decoding=placed",
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code != 0 and "needs edge categories" in res.output


def test_derive_placed_writes_only_valid_shapes_and_names_the_bottleneck(tmp_path, castle_grammar):
    pytest.importorskip("torch")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["derive", str(CASTLE), "--backend", "string-vae", "-n", "2",
                                    "--option", "model=builtin:castle", "--option", "categories=builtin:castle",
                                    "--option", "decoding=placed", "--option", "max-decodes=3",
                                    "--option", "placed-steps=60", "-o", str(out)])
    assert res.exit_code == 0, res.output
    manifest = out / "manifest.jsonl"
    entries = [json.loads(x) for x in manifest.read_text().splitlines()] if manifest.exists() else []
    for e in entries:
        assert validate(castle_grammar, read_assembly(out / e["file"])).ok
    if len(entries) < 2:
        assert "made " in res.output and "bottleneck is" in res.output, res.output


def test_max_tokens_starts_sampling_only_from_short_training_strings(shipped):
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    vae, _inst, _dec = shipped
    sampler = Sampler(vae, SamplingSettings(max_tokens=30, batch=2), seed=0)
    pool = sampler.pool
    assert len(pool) and all(len(vae.train_strings[i]) <= 30 for i in pool)
    assert len(pool) < len(vae.train_strings)
    assert len(Sampler(vae, SamplingSettings(), seed=0).pool) == len(vae.train_strings)
    assert sampler._targets([(int(pool[0]),)]) == [len(vae.train_strings[int(pool[0])])]  # the length prior


def test_the_length_bucketed_prior_draws_budgets_from_short_training_strings(shipped):
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    vae, _inst, _dec = shipped
    sampler = Sampler(vae, SamplingSettings(max_length=40, batch=2), seed=0)
    targets = sampler._targets([(i,) for i in range(50)])  # start points of any size
    short = {len(t) for t in vae.train_strings if len(t) <= 40}
    assert set(targets) <= short and len(set(targets)) > 1
    assert len(sampler.pool) == len(vae.train_strings)  # the start points stay the whole pool


def test_the_sampler_reports_every_decoded_point(shipped):
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    vae, _inst, _dec = shipped
    sampler = Sampler(vae, SamplingSettings(batch=1, steps=2, max_tokens=20), seed=0)  # short strings: fast
    seen = []
    sampler.on_point = lambda: seen.append(sampler.decoded_points)  # the progress bar's hook
    list(sampler.run("perturb", 1))
    assert seen and seen[-1] == sampler.decoded_points and seen == sorted(seen)


def test_no_model_option_uses_the_shipped_models_or_says_what_ships():
    from grammarkit.errors import GrammarkitError
    from grammarkit_string_vae.generate import shipped_defaults
    from grammarkit_string_vae.options import StringVAEOptions

    opts = shipped_defaults(StringVAEOptions(), "castle")
    assert (opts.model, opts.categories, opts.decoding, opts.min_length, opts.max_length, opts.max_open_rings) == \
        ("builtin:castle", "builtin:castle", "placed", 41, 56, 2)
    given = shipped_defaults(StringVAEOptions(model="m.vae"), "castle")
    assert (given.categories, given.decoding, given.max_length) == (None, "masked", None)
    small = shipped_defaults(StringVAEOptions(), "balltrack")  # a small shipped model, the plain length prior
    assert (small.model, small.categories, small.decoding, small.max_length, small.max_open_rings) == \
        ("builtin:balltrack", "builtin:balltrack", "placed", None, None)
    with pytest.raises(GrammarkitError, match="no model ships for grammar 'paris'.*shipped: balltrack, castle"):
        shipped_defaults(StringVAEOptions(), "paris")


def test_a_time_limit_ends_a_placed_run_and_says_so(tmp_path):
    pytest.importorskip("torch")
    # the shipped models by default (placed decoding); the budget is over before the first point
    res = CliRunner().invoke(main, ["derive", str(CASTLE), "--backend", "string-vae", "-n", "5",
                                    "--time-limit", "0.001", "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert "made 0 of 5" in res.output and "time limit" in res.output, res.output


def _small_point(vae):
    """The latent point of the smallest training castle and its string's length."""
    i = min(range(len(vae.train_strings)), key=lambda k: len(vae.train_strings[k]))
    return vae.train_mu[i].numpy(), len(vae.train_strings[i])


def test_a_rejected_graph_is_a_dead_end_and_the_search_goes_on(shipped):
    from grammarkit_string_vae.graphs import GraphSet

    vae, _inst, dec = shipped
    z, n = _small_point(vae)
    first = dec.decode(z, n, seed=0)
    assert first.valid, first.error
    known = GraphSet()
    known.add(first.graph)
    again = dec.decode(z, n, seed=0, reject=lambda g: g in known)
    # either another graph that the masks let through, or nothing, charged to novelty
    assert (again.valid and again.graph not in known) or (not again.valid and again.stage == "novelty")


def test_per_point_returns_distinct_graphs_from_one_latent_point(shipped):
    from grammarkit_string_vae.graphs import GraphSet

    vae, inst, dec = shipped
    z, _n = _small_point(vae)
    d = dec.decode(z, 30, seed=0, per_point=3)  # a budget of 30 tokens leaves room for a second castle
    assert d.valid, d.error
    assert d.text == dec.decode(z, 30, seed=0).text  # the first is what one string per point gives
    assert d.more  # the search went on past the first string
    graphs = GraphSet()
    for x in [d, *d.more]:
        assert x.valid and graphs.add(x.graph)  # all distinct
        asm, problem = inst.build(x.graph, x.placement.frames, x.placement.variants)
        assert problem is None


def test_the_finish_check_builds_each_finished_string_and_rejects_ones_that_fail(shipped, castle_grammar):
    from grammarkit_string_vae.placed import PlacedDecoder

    vae, inst, _dec = shipped
    text = min(vae.train_strings, key=len)
    checked = PlacedDecoder(vae, inst, width=16, finish_check=True)
    d = checked.place_text(text, steps=3000)
    assert d.valid, d.error
    assert d.placement.assembly is not None and validate(castle_grammar, d.placement.assembly).ok

    class Refusing:  # an instantiator whose final check fails every shape (e.g. a `filled` hole)
        def __init__(self, inner):
            self.inner = inner

        def __getattr__(self, name):
            return getattr(self.inner, name)

        def build(self, graph, frames, variants=None):
            return None, "the finished shape breaks the grammar: [constraint filled] a hole"

    refused = PlacedDecoder(vae, Refusing(inst), width=16, finish_check=True).place_text(text, steps=3000)
    assert not refused.valid and "unbuildable" in refused.error
    # without the check the same string is returned unbuilt (the build comes later, in generate)
    plain = PlacedDecoder(vae, Refusing(inst), width=16).place_text(text, steps=3000)
    assert plain.valid and plain.placement.assembly is None
