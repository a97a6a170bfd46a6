"""Molecules as a second domain: the codec round-trips RDKit's sample molecules and the masked
decoder makes molecules RDKit accepts (RDKit is an optional test dependency)."""
from __future__ import annotations

import numpy as np
import pytest

rdkit = pytest.importorskip("rdkit", reason="RDKit is not installed (python -m pip install rdkit): "
                            "the molecule tests of the string codec are skipped")

from grammarkit_string_vae.graphs import GraphSet  # noqa: E402
from grammarkit_string_vae.masked import Automaton, complete  # noqa: E402
from grammarkit_string_vae.molecules import (  # noqa: E402
    is_valid_molecule, load_molecules, molecule_rules, to_smiles,
)
from grammarkit_string_vae.strings import Alphabet, decode, strings_of  # noqa: E402
from grammarkit_string_vae.vocab import EOS, Vocab  # noqa: E402


@pytest.fixture(scope="module")
def molecules():
    mols = load_molecules(300)
    assert len(mols) == 300
    return mols


def test_strings_of_300_molecules_decode_to_the_same_molecule(molecules):
    types = sorted({t for _, g in molecules for t in g.types})
    alphabet = Alphabet.for_types(types)
    rules = molecule_rules(types)
    rng = np.random.default_rng(0)
    for smi, g in molecules:
        assert rules.is_valid(g) and is_valid_molecule(g)
        ref = to_smiles(g)
        one = GraphSet()
        one.add(g)
        for text in strings_of(g, alphabet, 5, rng=rng):
            back = decode(text, alphabet).graph
            assert back in one, (smi, text)
            assert to_smiles(back) == ref  # RDKit agrees it is the same skeleton


def test_every_molecule_string_passes_the_valence_masks(molecules):
    types = sorted({t for _, g in molecules for t in g.types})
    alphabet = Alphabet.for_types(types)
    rules = molecule_rules(types)
    vocab = Vocab(alphabet, 9)
    rng = np.random.default_rng(1)
    for _smi, g in molecules[:100]:
        for text in strings_of(g, alphabet, 3, rng=rng):
            ids = vocab.encode(text) + [EOS]
            state = Automaton(rules, vocab, len(ids)).start()
            for t in ids:
                assert t in state.allowed(), text
                state.apply(t)


def test_masked_random_molecules_are_valid_for_rdkit(molecules):
    types = sorted({t for _, g in molecules for t in g.types})
    alphabet = Alphabet.for_types(types)
    rules = molecule_rules(types)
    vocab = Vocab(alphabet, 9)
    auto = Automaton(rules, vocab, 40)
    rng = np.random.default_rng(2)
    for _ in range(100):
        state = auto.start()
        while not state.done:
            allowed = state.allowed()
            if not allowed:  # cannot happen with valences (a leaf atom always ends a branch)
                plan = complete(state)
                assert plan is not None
                for t in plan:
                    state.apply(t)
                break
            state.apply(int(rng.choice(allowed)))
        g = decode(state.graph_text(), alphabet).graph
        assert rules.is_valid(g) and is_valid_molecule(g), state.graph_text()
