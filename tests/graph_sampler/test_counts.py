"""Option counts (issue 28): by default a variant's part counts stay within the examples' range
(a castle learned from castles with 1 and 2 gates gets no castle without a gate); `counts=grammar`
keeps whatever the grammar allows."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from grammarkit.tiling import example_count_ranges
from grammarkit_graph_sampler.sampler import GraphSampler, SamplerOptions, count_outside

OPTS = dict(attempts_per_shape=32, min_attempts=256, max_attempts=512, batch_size=32)


def examples(kit):
    """A 1x2 and a 3x2 lattice castle: 6..12 towers, 7..17 walls."""
    return [kit.lattice(1, 2, "small"), kit.lattice(3, 2, "large")]


def sample(kit, workers=1, **kw):
    from grammarkit.run.executor import LocalExecutor

    s = GraphSampler(rules=kit.rules(), examples=examples(kit), seed=5, options=SamplerOptions(**OPTS, **kw),
                     executor=LocalExecutor(workers, parallel="always"))
    return s, list(s.run(30, 3))


@pytest.fixture(scope="module")
def runs(kit):
    return {mode: sample(kit, counts=mode) for mode in ("examples", "grammar")}


def test_default_keeps_every_count_within_the_examples_range(kit, runs):
    ranges = example_count_ranges(examples(kit))
    assert ranges == {"Tower": (6, 12), "Wall": (7, 17)}
    s, shapes = runs["examples"]
    assert s.options.counts == "examples" == SamplerOptions().counts
    assert shapes, "some recombinations keep the examples' counts"
    for shape in shapes:
        h = shape.histogram()
        assert all(lo <= h.get(t, 0) <= hi for t, (lo, hi) in ranges.items()), h
    rejected = sum(st.outcomes["counts"] for st in s.stats)
    reasons = [(k, v) for st in s.stats for k, v in st.reasons.items() if k.startswith("counts ")]
    assert rejected > 0 and sum(v for _, v in reasons) == rejected
    assert {k for k, _ in reasons} <= {"counts Tower", "counts Wall"}


def test_counts_grammar_gives_the_old_behaviour(kit, runs):
    ranges = example_count_ranges(examples(kit))
    _, shapes = runs["grammar"]
    outside = [sh for sh in shapes if count_outside(ranges, tuple(sorted(sh.histogram().items())))]
    assert outside, "without the range the sampler makes castles of other sizes"
    assert all(st.outcomes["counts"] == 0 for st in runs["grammar"][0].stats)


def test_count_outside_names_the_type():
    rng = {"Gate": (1, 2), "Wall": (3, 9)}
    assert count_outside(rng, (("Wall", 4),)) == "Gate: 0 not in 1..2"
    assert count_outside(rng, (("Gate", 1), ("Tower", 1), ("Wall", 4))) == "Tower: no example has one"
    assert count_outside(rng, (("Gate", 2), ("Wall", 9))) == ""
    assert count_outside(None, (("Gate", 0),)) == ""


def test_one_example_gives_no_range(kit):
    s = GraphSampler(rules=kit.rules(), examples=kit.examples()[:1], seed=5, workers=1)
    assert s.count_range is None


def test_same_variants_with_one_and_two_workers_under_the_default(kit, runs):
    _, one = runs["examples"]
    _, two = sample(kit, workers=2)
    assert [(a.protos, a.transforms.tobytes(), a.edges) for a in one] == \
        [(b.protos, b.transforms.tobytes(), b.edges) for b in two]


def test_cli_counts_option(tmp_path):
    grammar = Path(__file__).parent / "data" / "minicastle.grammar"
    cmd = [sys.executable, "-m", "grammarkit", "derive", str(grammar), "-n", "3", "--seed", "7", "--workers", "1",
           "--json", "--option", "attempts_per_shape=64", "--option", "min_attempts=256"]
    r = subprocess.run([*cmd, "-o", str(tmp_path / "a")], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["stats"]["iterations"]
    assert sum(row["outcomes"]["counts"] for row in rows) > 0
    r = subprocess.run([*cmd, "-o", str(tmp_path / "b"), "--option", "counts=grammar"],
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["stats"]["iterations"]
    assert sum(row["outcomes"]["counts"] for row in rows) == 0
    r = subprocess.run([*cmd, "-o", str(tmp_path / "c"), "--option", "counts=some"], capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 1 and "Traceback" not in r.stderr and "counts" in r.stderr
