"""A plugin can add a split operation: registered through the hook, checked, derived."""
from __future__ import annotations

import pytest

from grammarkit.errors import DerivationError, GrammarError
from grammarkit.geometry.convert import mesh_report
from grammarkit.plugins import get_plugin_manager
from grammarkit.split import derive

TEXT = """
Lot --> footprint(rect(6, 4)) stilts(3, 0.5) extrude(2) House.
"""


@pytest.fixture
def stilts_plugin(plugin_path):
    import split_op_plugin

    pm = get_plugin_manager()
    pm.register(split_op_plugin, name="split-op-fixture")
    yield split_op_plugin
    pm.unregister("split-op-fixture")


def test_builtin_operations_come_from_the_hook():
    ops = get_plugin_manager().operations()
    assert ops["split"].plugin == "split-operations" and ops["split"].apply is not None
    assert "stilts" not in ops


def test_plugin_operation_derives(stilts_plugin, G):
    ops = get_plugin_manager().operations()
    assert ops["stilts"].plugin == "split-op-fixture"
    m = derive(G(TEXT))
    rep = mesh_report(m.mesh)
    assert rep.watertight and rep.manifold
    # house 6 x 4 x 2 raised by 3 on four 0.5 x 0.5 x 3 posts, all fused into one solid
    assert rep.volume == pytest.approx(48 + 4 * 0.75, rel=3e-3)
    assert m.mesh.bounds[1][2] == pytest.approx(5.0, abs=3e-3)
    assert len(m.manifold.decompose()) == 1
    assert "Stilt" in {t.name for t in m.tags}


def test_plugin_operation_errors_are_reported_with_span(stilts_plugin, G):
    with pytest.raises(DerivationError, match="stilts") as e:
        derive(G("Lot --> footprint(rect(6, 4)) stilts(-1, 0.5) extrude(2) House."))
    assert e.value.span is not None and e.value.span.line == 1


def test_unknown_operation_without_plugin(G):
    with pytest.raises(GrammarError):
        derive(G(TEXT))
