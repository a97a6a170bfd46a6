"""The string VAE end to end on a tiny model: training, model files, decoding, the back end, CLI."""
from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

pytest.importorskip("torch")
pytest.importorskip("safetensors")

import torch  # noqa: E402

from grammarkit.cli import main  # noqa: E402
from grammarkit_string_vae.decoding import decode_latents  # noqa: E402
from grammarkit_string_vae.modelfile import ModelFileError, load_vae, read_meta  # noqa: E402

from .conftest import BALLTRACK, CASTLE  # noqa: E402


def test_model_file_records_grammar_alphabet_and_version(tiny_vae, castle_grammar):
    from grammarkit.run import grammar_hash

    meta = read_meta(tiny_vae.path)
    assert meta["format"] == "grammarkit-string-vae" and meta["format_version"] == "1"
    assert meta["grammar_hash"] == grammar_hash(castle_grammar)
    assert meta["alphabet"] == {"G": "Gate", "T": "Tower", "W": "Wall"}
    assert len(meta["training"]["history"]) == 3
    assert tiny_vae.train_mu.shape == (len(tiny_vae.train_strings), 8)
    load_vae(tiny_vae.path, grammar=castle_grammar)  # the right grammar loads


def test_a_model_for_another_grammar_is_refused(tiny_vae):
    from grammarkit.dsl import load

    with pytest.raises(ModelFileError, match="trained for grammar 'castle'"):
        load_vae(tiny_vae.path, grammar=load(BALLTRACK))


def test_truncated_random_and_pickled_files_are_refused_without_running_code(tiny_vae, tmp_path):
    data = tiny_vae.path.read_bytes()
    cut = tmp_path / "cut.vae"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFileError, match="truncated"):
        load_vae(cut)
    empty = tmp_path / "empty.vae"
    empty.write_bytes(b"")
    with pytest.raises(ModelFileError, match="too short"):
        load_vae(empty)
    noise = tmp_path / "noise.vae"
    noise.write_bytes(np.random.default_rng(0).bytes(4096))
    with pytest.raises(ModelFileError, match="not a grammarkit string-VAE model file"):
        load_vae(noise)
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    evil = tmp_path / "evil.vae"
    evil.write_bytes(pickle.dumps({"state": Evil()}))
    with pytest.raises(ModelFileError, match="pickles and other files are refused"):
        load_vae(evil)
    torch_file = tmp_path / "torch.vae"
    torch.save({"weights": torch.zeros(3), "evil": Evil()}, torch_file)
    with pytest.raises(ModelFileError):
        load_vae(torch_file)
    assert not marker.exists()
    # the CLI says so without a traceback
    out = CliRunner().invoke(main, ["vae-metrics", str(evil), "--samples", "2"])
    assert out.exit_code == 1 and "Traceback" not in out.output and "refused" in out.output


def test_masked_decoding_is_valid_by_construction_even_for_an_untrained_network(tiny_vae):
    z = torch.randn(40, 8, generator=torch.Generator().manual_seed(0))
    masked = decode_latents(tiny_vae.model, z, vocab=tiny_vae.vocab, rules=tiny_vae.rules, mode="masked")
    assert all(d.valid for d in masked), [d.error for d in masked if not d.valid]
    assert all(tiny_vae.rules.is_valid(d.graph) for d in masked)
    free = decode_latents(tiny_vae.model, z, vocab=tiny_vae.vocab, rules=tiny_vae.rules, mode="free")
    assert len(free) == 40  # whatever the tiny network manages; checked, not assumed
    assert all(d.valid == (d.graph is not None and tiny_vae.rules.is_valid(d.graph)) for d in free)
    # deterministic
    again = decode_latents(tiny_vae.model, z, vocab=tiny_vae.vocab, rules=tiny_vae.rules, mode="masked")
    assert [d.text for d in again] == [d.text for d in masked]


def test_sampling_modes_and_latent_path(tiny_vae):
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    s = Sampler(tiny_vae, SamplingSettings(batch=8, points=4, path_length=6), seed=3)
    route = s.latent_path(0, 1)
    assert route[0] == 0 and route[-1] == 1 and len(route) == min(6, len(tiny_vae.train_strings))
    assert len(set(route)) == len(route)
    for mode in ("prior", "perturb", "interpolate", "path"):
        got = list(s.run(mode, 1))
        assert all(x.valid for x in got)  # masked decoding
        if mode == "perturb":
            for x in got:  # perturbation looks for a graph other than its seed's
                assert x.decoded.graph not in _set(s.train_graphs[x.parents[0]])
    assert s.decoded_points > 0


def test_perturbation_grows_its_offset_past_known_graphs(tiny_vae):
    from grammarkit_string_vae.graphs import GraphSet
    from grammarkit_string_vae.sampling import Sampler, SamplingSettings

    settings = SamplingSettings(batch=6, steps=3)
    plain = Sampler(tiny_vae, settings, seed=5)
    first = [x for x in plain.run("perturb", 1)]
    assert first
    known = GraphSet()
    for x in first:
        known.add(x.decoded.graph)
    # the same seeds again, now moving past every graph the first run found
    past = Sampler(tiny_vae, settings, seed=5)
    past.known = lambda g: g in known
    again = list(past.run("perturb", 1))
    assert all(x.decoded.graph not in known for x in again)
    assert past.lost.get("novelty", 0) >= len(first)  # every point that hit a known graph is counted
    assert past.decoded_points > plain.decoded_points  # and the search went on past it
    # everything known: no sample, every valid decode counted as lost to novelty
    none = Sampler(tiny_vae, settings, seed=5)
    none.known = lambda g: True
    assert list(none.run("perturb", 1)) == []
    assert none.lost["novelty"] == none.valid_points


def _set(g):
    from grammarkit_string_vae.graphs import GraphSet

    out = GraphSet()
    out.add(g)
    return out


def test_derive_with_the_string_vae_back_end_writes_strings_and_graphs(tiny_vae, castle_grammar, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["derive", str(CASTLE), "--backend", "string-vae", "-n", "4",
                                    "--option", f"model={tiny_vae.path}", "--option", "mode=prior",
                                    "--option", "include-training=true", "-o", str(out)])
    assert res.exit_code == 0, res.output
    lines = [json.loads(x) for x in (out / "manifest.jsonl").read_text().splitlines()]
    assert lines, res.output
    from grammarkit_string_vae.strings import decode
    from grammarkit_string_vae.topology import TopologyRules

    rules = TopologyRules.from_grammar(castle_grammar)
    for e in lines:
        assert e["file"] is None  # data only: no model file
        g = decode(e["string"], tiny_vae.alphabet).graph
        assert rules.is_valid(g)
        assert sorted(t for t in g.types) == sorted(n["type"] for n in e["graph"]["nodes"])
    assert sorted(p.name for p in out.iterdir()) == ["manifest.jsonl", "run.json"]


def test_derive_refuses_a_model_of_another_grammar(tiny_vae, tmp_path):
    res = CliRunner().invoke(main, ["derive", str(BALLTRACK), "--backend", "string-vae", "-n", "2",
                                    "--option", f"model={tiny_vae.path}", "-o", str(tmp_path / "o")])
    assert res.exit_code == 1 and "trained for grammar 'castle'" in res.output and "Traceback" not in res.output
    # no model option: the grammar's shipped model, and for a grammar without one, what ships
    facade = BALLTRACK.parents[1] / "facade" / "facade.grammar"
    res = CliRunner().invoke(main, ["derive", str(facade), "--backend", "string-vae", "-n", "2",
                                    "-o", str(tmp_path / "o2")])
    assert res.exit_code == 1 and "no model ships for grammar 'facade'" in res.output, res.output


def test_train_cli_and_small_datasets(castle_dataset, tmp_path):
    model = tmp_path / "m.vae"
    res = CliRunner().invoke(main, ["train", "string-vae", str(castle_dataset.path), "-o", str(model),
                                    "--epochs", "1", "--latent", "4", "--hidden", "16"])
    assert res.exit_code == 0, res.output
    assert "epoch 1/1" in res.output and "validity" in res.output and model.exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    res = CliRunner().invoke(main, ["train", "string-vae", str(empty), "-o", str(tmp_path / "x.vae")])
    assert res.exit_code == 1 and "not a dataset folder" in res.output
    from grammarkit_string_vae.dataset import Dataset, write_dataset

    small = Dataset(dict(castle_dataset.meta), castle_dataset.graphs[:3], castle_dataset.strings[:3],
                    castle_dataset.ids[:3], castle_dataset.sources[:3], castle_dataset.frames[:3])
    write_dataset(small, tmp_path / "small")
    res = CliRunner().invoke(main, ["train", "string-vae", str(tmp_path / "small"), "-o", str(tmp_path / "y.vae")])
    assert res.exit_code == 1 and "too few to train on" in res.output


def test_vae_metrics_cli(tiny_vae):
    res = CliRunner().invoke(main, ["vae-metrics", str(tiny_vae.path), "--samples", "20", "--mode-seeds", "4",
                                    "--graph-size", "30", "--grammar", str(CASTLE)])
    assert res.exit_code == 0, res.output
    assert "| masked | 20 | 1.000 |" in res.output  # valid by construction
    assert "Table 2" in res.output and "| latent |" in res.output and "| naive |" in res.output
    res = CliRunner().invoke(main, ["vae-metrics", str(tiny_vae.path), "--samples", "10", "--mode-seeds", "0",
                                    "--graph-size", "0", "--decoding", "masked", "--json"])
    data = json.loads(res.output)
    assert data["prior_masked"]["validity"] == 1.0 and "unique@10" in data["prior_masked"]


def test_commands_say_how_to_install_torch_when_it_is_missing(castle_dataset, tmp_path):
    code = ("import sys; sys.modules['torch'] = None; from grammarkit.cli import main; "
            f"main(['train', 'string-vae', {str(castle_dataset.path)!r}, '-o', {str(tmp_path / 'm.vae')!r}])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 1
    assert "learning" in out.stderr and "pip install" in out.stderr and "Traceback" not in out.stderr


def test_the_shipped_castle_weights_load_for_the_castle_grammar_and_decode_validly(castle_grammar):
    from grammarkit_string_vae.modelfile import WEIGHTS

    if not (WEIGHTS / "castle.vae").exists():
        pytest.skip("no shipped weights in this checkout")
    vae = load_vae("builtin:castle", grammar=castle_grammar)
    meta = vae.meta["training"]
    assert meta["config"]["epochs"] == 40 and meta["config"]["seed"] == 0  # as scripts/train_castle_weights.py
    z = torch.randn(16, vae.model.config.latent, generator=torch.Generator().manual_seed(3))
    out = decode_latents(vae.model, z, vocab=vae.vocab, rules=vae.rules, mode="masked")
    assert all(d.valid for d in out)
    with pytest.raises(ModelFileError, match="no shipped .vae model"):
        load_vae("builtin:nonesuch")
