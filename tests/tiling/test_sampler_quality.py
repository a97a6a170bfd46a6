"""Issue 11, sampler output quality: every variant the graph sampler writes passes the stricter
checks (orientation, support, counts, required sites, site docks), checked by the full
validator on the written assembly; invalid attempts are tallied by the rule that rejected them."""
import sys
from pathlib import Path

import pytest

from grammarkit.dsl import load
from grammarkit.tiling import validate

sys.path.insert(0, str(Path(__file__).parent))
from _tiling_helpers import EXAMPLES  # noqa: E402

grammarkit_graph_sampler = pytest.importorskip("grammarkit_graph_sampler")


@pytest.mark.parametrize("path", ["balltrack/balltrack.grammar", "wfc/coast.grammar"])
def test_every_sampled_variant_passes_the_strict_checks(path):
    g = load(EXAMPLES / path)
    # counts=grammar: the checks under test are the grammar's own; the coast's examples' count
    # range admits no new variant at all (tests/graph_sampler/test_counts.py covers that mode)
    options = grammarkit_graph_sampler.SamplerOptions(counts="grammar")
    sampler = grammarkit_graph_sampler.GraphSampler(g, seed=3, workers=1, options=options)
    variants = [sampler.to_assembly(s) for s in sampler.run(5, 2)]
    assert len(variants) >= 3
    for a in variants:
        r = validate(g, a)
        assert r.ok, r.format()[:1500]
    rows = [s.row() for s in sampler.stats]
    invalid = sum(r["outcomes"]["invalid"] + r["outcomes"]["counts"] for r in rows)
    assert sum(sum(r["reasons"].values()) for r in rows) == invalid
    if path.startswith("balltrack"):  # the strict checks do reject attempts
        reasons = {k for r in rows for k in r["reasons"]}
        assert reasons & {"orientation", "constraint grounded"}, reasons


def test_rejection_reason_names_the_rule():
    from grammarkit_graph_sampler.sampler import rejection_reason

    assert rejection_reason("part 3 (Ramp): [orientation] is upside down") == "orientation"
    assert rejection_reason("[constraint grounded] parts not carried: 4") == "constraint grounded"
    assert rejection_reason("part 1 (A) touches 2 (B), but no dock allows A -- B") == "pair"
