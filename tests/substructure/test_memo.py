"""The `memo` option: evaluations on shapes named by their chain of operations are kept for
the run; the variants are the same with and without it (fixed seeds), for fewer embeddings."""

from pathlib import Path

import pytest

from grammarkit.dsl import load
from grammarkit.run import run_backend
from grammarkit_substructure import backend

ROOT = Path(__file__).resolve().parents[2]


def _run(grammar, out, seed, memo, **extra):
    return run_backend(
        load(grammar),
        out=out,
        backend="substructure",
        n=3,
        seed=seed,
        workers=1,
        options={"memo": memo, **extra},
    )


@pytest.mark.parametrize(
    "grammar, seed, extra",
    [
        (
            ROOT / "grammars" / "tiling" / "castle" / "castle.grammar",
            0,
            {"patience": 40},
        ),
        (
            ROOT / "grammars" / "tiling" / "balltrack" / "balltrack.grammar",
            3,
            {"tries": 16},
        ),
    ],
)
def test_memo_gives_the_same_variants_for_fewer_embeddings(
    tmp_path, monkeypatch, grammar, seed, extra
):
    calls = {"n": 0}
    real = backend.embed

    def counted(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        calls["n"] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(backend, "embed", counted)
    runs = {}
    for memo in (False, True):
        calls["n"] = 0
        summary = _run(grammar, tmp_path / str(memo), seed, memo, **extra)
        runs[memo] = (summary, calls["n"])
    (off, embeds_off), (on, embeds_on) = runs[False], runs[True]
    assert off.total == on.total >= 1
    for key in ("candidates", "embeddings_tried", "valid", "new", "outside_counts"):
        assert off.stats[key] == on.stats[key], key
    files = sorted((tmp_path / "False").glob("variant_*.glb"))
    assert [f.name for f in files] == sorted(
        f.name for f in (tmp_path / "True").glob("variant_*.glb")
    )
    for f in files:
        assert (tmp_path / "True" / f.name).read_bytes() == f.read_bytes()
    assert (tmp_path / "True" / "manifest.jsonl").exists()
    # the old path embeds every tried operation; the memo reuses what an earlier candidate did
    assert embeds_off == off.stats["embeddings_tried"]
    assert embeds_on < embeds_off


def test_a_full_memo_starts_afresh_with_the_same_results(tmp_path, monkeypatch):
    grammar = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
    ref = _run(grammar, tmp_path / "ref", 0, True, patience=40)
    monkeypatch.setattr(backend, "MEMO_SHAPES", 2)  # forgets every few embeddings
    small = _run(grammar, tmp_path / "small", 0, True, patience=40)
    assert small.stats["candidates"] == ref.stats["candidates"]
    assert small.stats["embeddings_tried"] == ref.stats["embeddings_tried"]
    assert small.total == ref.total >= 1
    for f in sorted((tmp_path / "ref").glob("variant_*.glb")):
        assert (tmp_path / "small" / f.name).read_bytes() == f.read_bytes()
