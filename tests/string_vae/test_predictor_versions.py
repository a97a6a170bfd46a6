"""The edge-category predictor's two versions (the paper's and this project's), the votings and
the joint assignment per part (issue 15 follow-up)."""
from __future__ import annotations

import numpy as np
import pytest

from grammarkit_string_vae.graphs import TypedGraph

from .test_instantiation import _grammar


def test_graph_features_count_neighbour_types():
    from grammarkit_string_vae.predictor import graph_features

    # Wall0 - Tower1 - Wall2 - Wall3
    g = TypedGraph.make(["Wall", "Tower", "Wall", "Wall"], [(0, 1), (1, 2), (2, 3)])
    f = graph_features(g, ("Gate", "Tower", "Wall")) * 4
    assert f.shape == (4, 6)
    assert f[1].tolist() == [0, 0, 2, 0, 2, 1]  # the tower: 2 walls; walks of 2: tower twice, wall once
    assert f[3].tolist() == [0, 0, 1, 0, 1, 1]


def test_votings_differ_as_documented():
    from grammarkit_string_vae.predictor import vote

    lp = np.log
    strings = [np.array([lp(0.6), lp(0.4), -1e9]), np.array([lp(0.6), lp(0.4), -1e9]),
               np.array([lp(0.01), lp(0.99), -1e9])]
    maj, lps = vote(strings, "majority"), vote(strings, "logprob")
    assert int(np.argmax(maj)) == 0  # two strings of three say 0
    assert int(np.argmax(lps)) == 1  # one very sure string outweighs two unsure ones
    assert maj[2] <= -1e8 and lps[2] <= -1e8  # a masked category stays impossible


def test_joint_assignment_gives_a_part_distinct_docking_places():
    from grammarkit_string_vae.categories import Category, EdgeCategories
    from grammarkit_string_vae.predictor import assign_jointly

    cats = EdgeCategories(("Tower", "Wall"), [Category(0, "Tower", "Wall", np.eye(4), 1),
                                               Category(1, "Tower", "Wall", np.eye(4), 1)], {"Tower": 1, "Wall": 1})
    g = TypedGraph.make(["Tower", "Wall", "Wall"], [(0, 1), (0, 2)])
    votes = {(0, 1): np.array([-0.1, -2.5]), (0, 2): np.array([-0.2, -1.5])}  # both prefer category 0
    seen = {("Tower", (("Wall", 0), ("Wall", 1))), ("Wall", (("Tower", 0),)), ("Wall", (("Tower", 1),))}
    out = assign_jointly(g, votes, cats, seen)
    assert out == {(0, 1): 0, (0, 2): 1}  # the cheaper change: edge (0, 2) moves
    assert assign_jointly(g, votes, cats, set()) == {(0, 1): 0, (0, 2): 0}  # nothing seen: argmax


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from grammarkit_string_vae.dataset import build_dataset, load_dataset, write_dataset

    from .conftest import ROOT

    g = _grammar("castle")
    # counts=grammar: the examples' count range leaves too few castles for a 6-graph dataset
    ds, _ = build_dataset(g, n=6, iterations=1, seed=3, strings_per_graph=3, options={"counts": "grammar"},
                          grammar_file=str(ROOT / "grammars/tiling/castle/castle.grammar"))
    folder = tmp_path_factory.mktemp("pv") / "ds"
    write_dataset(ds, folder)
    return g, load_dataset(folder), folder


@pytest.mark.parametrize("paper", [True, False])
def test_both_versions_train_save_and_load(small_dataset, paper):
    from grammarkit_string_vae.edgemodel import EdgeTrainConfig, load_edge_model, save_edge_model, train_edge_model

    g, ds, folder = small_dataset
    kw = dict(bidirectional=False, voting="majority") if paper else dict(graph_features=True)
    em = train_edge_model(ds, g, EdgeTrainConfig(epochs=1, hidden=12, embed=6, strings_per_graph=2, vote_strings=2,
                                                 val_fraction=0.3, **kw))
    path = folder.parent / f"{'paper' if paper else 'ours'}.edges"
    save_edge_model(em, path)
    back = load_edge_model(path, g)
    cfg = back.model.config
    assert cfg.bidirectional is (not paper) and back.model.lstm.bidirectional is (not paper)
    assert (cfg.features == 0) is paper and cfg.types == (() if paper else tuple(ds.alphabet.types))
    assert back.voting == ("majority" if paper else "logprob")
    assert back.configurations and back.configurations == em.configurations
    row = em.meta["training"]["history"][-1]
    for key in ("char_accuracy", "edge_accuracy_majority", "edge_accuracy_voted", "edge_accuracy_joint"):
        assert 0.0 <= row[key] <= 1.0
    graph = ds.graphs[0]
    for voting in ("majority", "logprob", "joint"):
        ranks = back.rankings(graph, strings=2, voting=voting)
        assert set(ranks) == set(graph.edges)
        for (u, v), order in ranks.items():
            assert sorted(order) == sorted(back.categories.pair_categories(graph.types[u], graph.types[v]))
    a = back.predict(graph, strings=3, seed=5)
    b = back.predict(graph, strings=3, seed=5)
    assert {e: k for e, (k, _) in a.items()} == {e: k for e, (k, _) in b.items()}  # deterministic
    with pytest.raises(ValueError, match="unknown voting"):
        back.predict(graph, voting="plurality")


def test_train_command_paper_flag(small_dataset):
    from click.testing import CliRunner

    from grammarkit.cli import main
    from grammarkit_string_vae.edgemodel import load_edge_model

    g, ds, folder = small_dataset
    out = folder.parent / "cli_paper.edges"
    res = CliRunner().invoke(main, ["train", "edge-categories", str(folder), "-o", str(out), "--epochs", "1",
                                    "--strings-per-graph", "1", "--votes", "2", "--paper"])
    assert res.exit_code == 0, res.output
    em = load_edge_model(out, g)
    assert not em.model.config.bidirectional and em.voting == "majority"
