"""The sampler on the repository's tiling examples (grammars/tiling): outputs validate in full."""
from pathlib import Path

import pytest

from grammarkit.dsl import load
from grammarkit.tiling import example_count_ranges, shape_graph, validate
from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions

ROOT = Path(__file__).resolve().parents[2] / "grammars" / "tiling"
GRAMMARS = sorted(ROOT.glob("*/*.grammar"))


def test_the_three_tiling_examples_are_there():
    assert {p.parent.name for p in GRAMMARS} >= {"castle", "balltrack", "facade"}


@pytest.mark.parametrize("path", GRAMMARS, ids=lambda p: p.parent.name)
def test_variants_of_each_example_validate_in_full(path):
    grammar = load(path)
    sampler = GraphSampler(grammar, seed=7, workers=1,
                           options=SamplerOptions(attempts_per_shape=256, min_attempts=512))
    shapes = list(sampler.run(3, 2))
    if path.parent.name == "castle":
        assert shapes, "the castle always yields variants with this seed and budget"
    ranges = example_count_ranges(sampler.examples and [e.types for e in sampler.examples])
    for shape in shapes:
        asm = sampler.to_assembly(shape)
        have = asm.type_histogram()  # the default counts="examples": within the examples' range
        assert all(lo <= have.get(t, 0) <= hi for t, (lo, hi) in ranges.items()), have
        report = validate(grammar, asm)  # graph recomputed at the default tolerance, docks checked
        assert report.ok, report.format()
        assert all(p.mesh.is_watertight for p in asm.parts)
        g = shape_graph(asm, tolerance=sampler.contact_tolerance)
        assert {frozenset((shape.ids[a], shape.ids[b])) for a, b in shape.edges} == \
            {frozenset(e) for e in g.edges()}


def test_python_api_sample_yields_assemblies_with_provenance():
    from grammarkit_graph_sampler import sampler

    castle = ROOT / "castle" / "castle.grammar"
    out = list(sampler.sample(str(castle), n=2, iterations=2, seed=7, workers=1,
                              attempts_per_shape=256, min_attempts=512))
    assert len(out) == 2
    for asm in out:
        meta = asm.meta["graph_sampler"]
        assert meta["key"] == asm.name and len(meta["parents"]) == 2
        assert meta["operation"]["replaced"] and meta["operation"]["inserted"]
        assert validate(load(castle), asm).ok
