"""Every example grammar (and seeded random attr samples of it) gives one watertight manifold."""
from __future__ import annotations

import itertools

import pytest

from grammarkit.geometry.convert import mesh_report
from grammarkit.split import derive, variations

EXAMPLES = ["paris", "skyscraper", "lshape"]


def _check(model, what):
    rep = mesh_report(model.mesh)
    assert rep.watertight and rep.manifold and rep.triangles > 0, f"{what}: {rep}"
    assert len(model.manifold.decompose()) == 1, f"{what}: more than one solid"
    return rep


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_default_is_watertight(examples, name):
    m = derive(examples[name], seed=0)
    _check(m, name)
    assert not [w for w in m.warnings if "no rule" in w], m.warnings


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_random_samples_are_watertight(examples, name):
    # variations resample every ranged attr, re-roll choices and swap snippets per `variants`
    for var, m in itertools.islice(variations(examples[name], 3, seed=11), 3):
        _check(m, f"{name} variation {var.index} attrs={var.attrs} bindings={var.bindings}")


def test_paris_meets_the_brief(examples):
    m = derive(examples["paris"], seed=0)
    assert len(m.parts) >= 200
    floors = {round(p.origin[2], 3) for p in m.parts if p.name == "Glass"}
    assert len(floors) >= 10
    assert {"Roof", "Chimney", "Frame", "Glass", "Railing"} <= {p.name for p in m.parts}
    kinds = {p.object_type for p in m.parts}
    assert {"Mass", "Roof", "Facade", "Floor", "Window", "Ledge"} <= kinds


def test_library_has_three_snippets_per_object_type_with_ranged_params(examples):
    g = examples["paris"]
    by_type = {}
    for s in g.snippets:
        by_type.setdefault(s.object_type, []).append(s)
        for a in s.attrs:
            assert a.range is not None or a.enum is not None, f"{s.name}.{a.name} has no range"
    for t in ("Mass", "Roof", "Facade", "Floor", "Window", "Ledge"):
        assert len(by_type.get(t, [])) >= 3, t


def test_variations_are_reproducible_and_differ(examples):
    a = [(v.attrs, v.bindings) for v, _ in variations(examples["paris"], 2, seed=4)]
    b = [(v.attrs, v.bindings) for v, _ in variations(examples["paris"], 2, seed=4)]
    assert a == b and a[0] != a[1]
    for attrs, _ in a:
        assert 36 <= attrs["mass_h"] <= 48
