"""`grammarkit strings` and `grammarkit dataset`, and dataset folders (no torch needed)."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from grammarkit.cli import main
from grammarkit_string_vae.dataset import load_dataset
from grammarkit_string_vae.graphs import GraphSet
from grammarkit_string_vae.strings import Alphabet, decode
from grammarkit_string_vae.topology import TopologyRules

from .conftest import CASTLE

SMALL = CASTLE.parent / "castle_small.glb"


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_strings_of_a_model_are_different_and_decode_to_its_graph(castle_grammar):
    res = run("strings", SMALL, "--grammar", CASTLE, "-n", 20)
    assert res.exit_code == 0, res.output
    lines = [x for x in res.output.splitlines() if x and not x.startswith(("castle_small", str(SMALL)))]
    strings = [x for x in lines if set(x) <= set("GTW()123456789%")]
    assert len(strings) == 20 and len(set(strings)) == 20
    from grammarkit.tiling import read_assembly, shape_graph
    from grammarkit_string_vae.graphs import TypedGraph

    asm = read_assembly(SMALL)
    sg = shape_graph(asm)
    order = {p.id: k for k, p in enumerate(asm.parts)}
    g = TypedGraph.make([p.type for p in asm.parts], [(order[u], order[v]) for u, v in sg.edges()])
    ref = GraphSet()
    ref.add(g)
    alpha = Alphabet.for_types(TopologyRules.from_grammar(castle_grammar).types)
    assert all(decode(s, alpha).graph in ref for s in strings)


def test_strings_in_string2shape_format_and_json():
    res = run("strings", SMALL, "--grammar", CASTLE, "-n", 3, "--format", "string2shape", "--json")
    data = json.loads(res.output[: res.output.rindex("}") + 1])
    assert data["format"] == "string2shape" and data["alphabet"] == {"A": "Gate", "B": "Tower", "C": "Wall"}
    assert all(set(s) <= set("ABC()0123456789%") for s in data["strings"])
    assert data["parts"] == 20 and data["violations"] == []


def test_decode_prints_the_graph():
    res = run("strings", "--decode", "T1WWTWWTWWTWW1", "--grammar", CASTLE)
    assert res.exit_code == 0, res.output
    assert "12 parts, 12 edges (1 cycle edge(s))" in res.output and "valid" in res.output
    assert "grounded" in res.output  # said to need geometry


@pytest.mark.parametrize("text, col, words", [
    ("T1WWTWXTWWTW1", 7, "unknown character 'X'"),
    ("T1WWTWWTWWTW1", 12, "Wall has neighbours {Tower, Tower}"),
    ("TT", 2, "Tower may not touch Tower"),
    ("T1WWT(WWTWW1", 6, "never closed"),
])
def test_decode_says_where_the_string_breaks_the_grammar(text, col, words):
    res = run("strings", "--decode", text, "--grammar", CASTLE)
    assert res.exit_code == 1
    assert f"<string>:1:{col}:" in res.output and words in res.output, res.output
    assert "Traceback" not in res.output
    lines = res.output.splitlines()
    caret = next(i for i, x in enumerate(lines) if x.strip().startswith("^"))
    assert lines[caret].index("^") - 4 == col - 1


def test_strings_usage_errors(tmp_path):
    res = run("strings", "--grammar", CASTLE)
    assert res.exit_code == 2 and "MODEL" in res.output
    split = CASTLE.parents[2] / "paris.grammar"
    res = run("strings", "--decode", "AB", "--grammar", split)
    assert res.exit_code == 1 and "tiling" in res.output


def test_dataset_command_builds_a_folder_from_the_graph_sampler(tmp_path, castle_grammar):
    out = tmp_path / "castle_ds"
    res = run("dataset", CASTLE, "--from", "graph-sampler", "-n", 4, "--iterations", 1, "-o", out,
              "--seed", 3)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["dataset.json", "graphs.jsonl", "histograms.csv", "strings.tsv"]
    ds = load_dataset(out)
    meta = ds.meta
    assert meta["source"] == "graph-sampler" and meta["graphs"] == len(ds) >= 2  # the two examples at least
    assert meta["strings_per_graph"] == 10
    rules = TopologyRules.from_grammar(castle_grammar)
    seen = GraphSet()
    for g, ss, frames in zip(ds.graphs, ds.strings, ds.frames):
        assert rules.is_valid(g) and seen.add(g)  # valid, no two isomorphic
        assert 1 <= len(ss) <= 10 and len(set(ss)) == len(ss)
        assert all(decode(s, ds.alphabet).graph in _one(g) for s in ss)
        assert frames is not None and len(frames) == len(g) and len(frames[0]) == 16
    head = (out / "histograms.csv").read_text().splitlines()[0]
    assert head == "id,Gate,Tower,Wall"
    # the folder is not replaced without --overwrite, and never by a file name
    res = run("dataset", CASTLE, "-n", 1, "--iterations", 1, "-o", out)
    assert res.exit_code == 1 and "--overwrite" in res.output
    f = tmp_path / "file.txt"
    f.write_text("x")
    res = run("dataset", CASTLE, "-n", 1, "-o", f)
    assert res.exit_code == 1 and "is a file" in res.output


def _one(g):
    s = GraphSet()
    s.add(g)
    return s


def test_load_dataset_errors(tmp_path):
    from grammarkit.errors import GrammarkitError

    with pytest.raises(GrammarkitError, match="no such dataset folder"):
        load_dataset(tmp_path / "missing")
    (tmp_path / "d").mkdir()
    with pytest.raises(GrammarkitError, match="not a dataset folder"):
        load_dataset(tmp_path / "d")
    (tmp_path / "d" / "dataset.json").write_text(json.dumps({"format": "grammarkit-string-dataset", "version": 1}))
    (tmp_path / "d" / "graphs.jsonl").write_text('{"types": ["Tower"], "edges": []}\nnot json\n')
    (tmp_path / "d" / "strings.tsv").write_text("")
    with pytest.raises(GrammarkitError, match="graphs.jsonl:2"):
        load_dataset(tmp_path / "d")
