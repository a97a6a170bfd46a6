"""run_backend / iter_results: the run layer as back ends and API users see it."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from grammarkit.errors import GrammarkitError, LimitError, PluginError
from grammarkit.registry import Registries
from grammarkit.run import BackendSpec, Result, iter_results, run_backend

ROOT = Path(__file__).resolve().parents[2]


def test_iter_results_yields_models_in_memory(small):
    results = list(iter_results(small, n=3, seed=5))
    assert [r.id for r in results] == ["small_0000", "small_0001", "small_0002"]
    assert [r.seed for r in results] == [5, 6, 7]
    assert all(r.model.mesh.is_watertight for r in results)


def test_split_run_continues_to_the_same_bytes(small, tmp_path):
    whole = run_backend(small, out=tmp_path / "whole", n=5, seed=2, options={"variations": True})
    assert whole.written == 5 and whole.shortfall is None
    part = run_backend(small, out=tmp_path / "part", n=2, seed=2, options={"variations": True})
    rest = run_backend(small, out=tmp_path / "part", n=5, seed=2, options={"variations": True})
    assert (part.written, rest.resumed, rest.written) == (2, 2, 3)
    strip = lambda p: [{k: v for k, v in json.loads(x).items() if k != "metrics"}  # noqa: E731 - a one-line helper
                       for x in (p / "manifest.jsonl").read_text().splitlines()]
    assert strip(tmp_path / "part") == strip(tmp_path / "whole")
    for f in (tmp_path / "whole").glob("*.glb"):
        assert (tmp_path / "part" / f.name).read_bytes() == f.read_bytes()
    done = run_backend(small, out=tmp_path / "part", n=5, seed=2, options={"variations": True})
    assert done.written == 0 and done.resumed == 5


def _registries(*backends):
    from grammarkit.plugins import get_plugin_manager

    real = get_plugin_manager().registries()
    # every kind as installed (the grammar is checked against these registries too), with
    # only the given back ends
    kinds = {k: getattr(real, k) for k in Registries.KINDS}
    return Registries(**{**kinds, "backends": {b.name: b for b in backends}})


def _spec(run, families=("split",)):
    return BackendSpec("t", "test", frozenset(families), run, default_for=frozenset(families),
                       plugin="test-plugin")


def _box_results(request):
    import trimesh

    for i in range(request.start, min(request.n, 2)):
        yield Result(id=f"b{i}", index=i, model=trimesh.creation.box())
    return {"shortfall": "only two boxes exist"}


def test_a_shortfall_is_reported_with_the_back_end_s_reason(small, tmp_path):
    summary = run_backend(small, out=tmp_path / "o", n=5, registries=_registries(_spec(_box_results)))
    assert summary.total == 2 and summary.shortfall == "only two boxes exist"


@pytest.mark.parametrize("body,match", [
    ("yield 42", "yielded a int"),
    ("raise SystemExit(0)\n    yield", "SystemExit"),
    ("raise ZeroDivisionError('x')\n    yield", "ZeroDivisionError"),
])
def test_misbehaving_back_ends_are_named(small, tmp_path, body, match):
    ns: dict = {}
    exec(f"def run(request):\n    {body}\n", ns)
    with pytest.raises(PluginError, match=match) as info:
        run_backend(small, out=tmp_path / "o", n=1, registries=_registries(_spec(ns["run"])))
    assert "test-plugin" in str(info.value)
    assert not (tmp_path / "o").exists()


def test_a_reserved_manifest_field_is_refused(small, tmp_path):
    import trimesh

    def run(request):
        yield Result(id="a", index=0, model=trimesh.creation.box(), extra={"file": "evil"})

    with pytest.raises(PluginError, match="reserved"):
        run_backend(small, out=tmp_path / "o", n=1, registries=_registries(_spec(run)))


def test_an_exporter_that_writes_nothing_replaces_nothing(small, tmp_path):
    from grammarkit.registry import ExporterSpec

    out = tmp_path / "o"
    run_backend(small, out=out, n=1)
    before = (out / "small_0000.glb").read_bytes()
    from grammarkit.plugins import get_plugin_manager

    real = get_plugin_manager().registries()
    kinds = {k: getattr(real, k) for k in Registries.KINDS}
    kinds["exporters"] = {**real.exporters, "glb": ExporterSpec("glb", (".glb",), encode=lambda m: b"",
                                                                plugin="noop")}
    reg = Registries(**kinds)
    with pytest.raises(GrammarkitError, match="produced no data"):
        run_backend(small, out=tmp_path / "o2", n=1, registries=reg)
    assert not (tmp_path / "o2").exists()
    assert (out / "small_0000.glb").read_bytes() == before


def test_the_time_budget_stops_a_run(small, tmp_path):
    import time

    import trimesh  # imported before the clock starts: on a loaded machine it takes a while

    def run(request):
        for i in range(100):
            time.sleep(0.05)
            request.check_deadline()
            yield Result(id=f"b{i}", index=i, model=trimesh.creation.box())

    with pytest.raises(LimitError, match="time budget"):
        run_backend(small, out=tmp_path / "o", n=100, timeout=1.0, registries=_registries(_spec(run)))
    lines = (tmp_path / "o" / "manifest.jsonl").read_text().splitlines()
    assert 1 <= len(lines) < 100  # what was written is listed; a re-run continues


def test_bad_requests_are_clear_errors(small, tmp_path):
    with pytest.raises(GrammarkitError, match="n must be"):
        run_backend(small, out=tmp_path / "o", n=-1)
    with pytest.raises(GrammarkitError, match="unknown output format 'xyz'"):
        run_backend(small, out=tmp_path / "o", n=1, format="xyz")
    with pytest.raises(GrammarkitError, match="no option 'colour'"):
        run_backend(small, out=tmp_path / "o", n=1, options={"colour": "red"})
    with pytest.raises(GrammarkitError, match="does not derive split grammars"):
        run_backend(small, out=tmp_path / "o", n=1, backend="graph-sampler")
    assert not (tmp_path / "o").exists()
