"""Shared fixtures: the castle grammar, castle-like graphs made in code, a tiny trained model."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grammarkit_string_vae.graphs import GraphSet, TypedGraph

ROOT = Path(__file__).resolve().parents[2]
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
BALLTRACK = ROOT / "grammars" / "tiling" / "balltrack" / "balltrack.grammar"


def castle_graph(rng: np.random.Generator) -> TypedGraph:
    """A ring of towers joined by pairs of walls, with a few extra wall pairs between towers
    that have room (a tower takes 2 or 3 walls): valid for grammars/tiling/castle."""
    k = int(rng.integers(2, 9))
    types: list[str] = []
    edges: list[tuple[int, int]] = []
    towers = []
    for _ in range(k):
        towers.append(len(types))
        types.append("Tower")
    deg = {t: 0 for t in towers}

    def wall_pair(a: int, b: int) -> None:
        w1, w2 = len(types), len(types) + 1
        types.extend(["Wall", "Wall"])
        edges.extend([(a, w1), (w1, w2), (w2, b)])
        deg[a] += 1
        deg[b] += 1

    for i in range(k):
        wall_pair(towers[i], towers[(i + 1) % k])
    for _ in range(int(rng.integers(0, 3))):
        free = [t for t in towers if deg[t] < 3]
        if len(free) < 2:
            break
        a, b = rng.choice(free, size=2, replace=False)
        wall_pair(int(a), int(b))
    return TypedGraph.make(types, edges)


def castle_graphs(n: int, seed: int = 0) -> list[TypedGraph]:
    rng = np.random.default_rng(seed)
    seen = GraphSet()
    out = []
    tries = 0
    while len(out) < n and tries < 50 * n:
        tries += 1
        g = castle_graph(rng)
        if seen.add(g):
            out.append(g)
    return out


@pytest.fixture(scope="session")
def castle_grammar():
    from grammarkit.dsl import load

    return load(CASTLE)


@pytest.fixture(scope="session")
def castle_dataset(tmp_path_factory, castle_grammar):
    """A dataset folder of 30 castle-like graphs, 6 strings each (no sampler: fast)."""
    from grammarkit.run import grammar_hash
    from grammarkit_string_vae.dataset import load_dataset, make_dataset, write_dataset
    from grammarkit_string_vae.strings import Alphabet
    from grammarkit_string_vae.topology import TopologyRules

    rules = TopologyRules.from_grammar(castle_grammar)
    graphs = castle_graphs(30)
    assert all(rules.is_valid(g) for g in graphs)
    ds = make_dataset(graphs, rules, Alphabet.for_types(rules.types), strings_per_graph=6, seed=0,
                      meta={"grammar": castle_grammar.name, "grammar_hash": grammar_hash(castle_grammar),
                            "grammar_file": str(CASTLE), "source": "test"})
    folder = tmp_path_factory.mktemp("ds") / "castle_ds"
    write_dataset(ds, folder)
    return load_dataset(folder)


@pytest.fixture(scope="session")
def tiny_vae(tmp_path_factory, castle_dataset):
    """A tiny string VAE trained for 3 epochs (seconds on a CPU), saved and reloaded."""
    pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from grammarkit_string_vae.modelfile import load_vae
    from grammarkit_string_vae.train import TrainConfig
    from grammarkit_string_vae.vaefile import train_and_save

    path = tmp_path_factory.mktemp("model") / "castle.vae"
    cfg = TrainConfig(epochs=3, batch_size=32, latent=8, hidden=32, enc_hidden=32, embed=8, seed=1,
                      monitor_samples=8)
    train_and_save(castle_dataset, cfg, path)
    return load_vae(path)
