"""Given registries, the run layer and the DSL never read the process-wide plugin manager: the
registries travel from the edge (issue 25, item 5). Measured by making every read fail."""
from __future__ import annotations

import json

import pytest

import grammarkit.plugins as plugins
from grammarkit.dsl import check, load
from grammarkit.run import iter_results, run_backend
from grammarkit.run.batch import run_batch

SMALL = """grammar small
attr h = 6 @range(3, 12)
Lot --> footprint(rect(8, 6)) extrude(h) comp(f) { top: Roof. | side: Wall. }
"""


@pytest.fixture
def registries(monkeypatch):
    """The installed plugins' registries, then every read of the global manager an error."""
    regs = plugins.default_registries()

    def refuse(*_a, **_k):
        raise AssertionError("the process-wide plugin manager was read below the edge")

    monkeypatch.setattr(plugins, "get_plugin_manager", refuse)
    monkeypatch.setattr(plugins, "default_registries", refuse)
    return regs


@pytest.fixture
def small(tmp_path):
    p = tmp_path / "small.grammar"
    p.write_text(SMALL)
    return p


def test_the_fixture_catches_a_read(registries, small):
    with pytest.raises(AssertionError, match="plugin manager was read"):
        load(small)  # no registries given: the public function's edge reads the manager


def test_dsl_with_registries_reads_no_global(registries, small):
    assert load(small, registries=registries).name == "small"
    assert not [d for d in check(small, registries=registries) if d.severity == "error"]


def test_run_backend_and_iter_results_with_registries_read_no_global(registries, small, tmp_path):
    [result] = list(iter_results(small, n=1, seed=2, registries=registries))
    assert result.model.mesh.is_watertight
    summary = run_backend(small, out=tmp_path / "out", n=2, seed=2, workers=1,
                          options={"variations": True}, registries=registries)
    assert summary.written == 2


def test_run_batch_with_registries_reads_no_global(registries, small, tmp_path):
    summary = run_batch(small, 3, tmp_path / "ds", workers=1, seed=1, registries=registries)
    assert (summary.ok, summary.failed) == (3, 0)
    meta = json.loads((tmp_path / "ds" / "dataset.json").read_text())
    assert meta["count"] == 3 and meta["attr_vector"]
