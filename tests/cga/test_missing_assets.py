"""An i() of an asset the project does not carry: CityEngine (and PRT) warn "asset not found"
and insert nothing, the rest of the model is generated. The importer's default ("keep") does
the same while deriving, with a located warning; "error" is the strict option (the derivation
stops at the first missing file); "drop" leaves such an i() out at import."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from _cga_helpers import imported

from grammarkit.dsl import load
from grammarkit.errors import GrammarkitError
from grammarkit.split import derive

PARTS = Path(__file__).resolve().parents[2] / "grammars" / "parts"
LOT3 = [(0, 0), (3, 0), (3, 2), (0, 2)]
# a part chosen while deriving (a rule argument): one file is there, the other is not
CGA = ('Lot --> extrude(2) split(x) { 1: Part("parts/chimney.glb") | ~1: Part("parts/none.glb") }\n'
       'Part(asset) --> i(asset) X.\n')


def _written(tmp_path: Path, text: str) -> Path:
    (tmp_path / "parts").mkdir(exist_ok=True)
    shutil.copy(PARTS / "chimney.glb", tmp_path / "parts" / "chimney.glb")
    path = tmp_path / "t.grammar"
    path.write_text(text)
    return path


def test_a_missing_asset_leaves_its_shape_out_with_a_located_warning(tmp_path):
    r = imported(CGA)
    assert r.ok and "Part(asset) --> i(asset, missing=skip) X." in r.text
    path = _written(tmp_path, r.text)
    m = derive(load(path), lot=LOT3)
    # the chimney of the first metre is there; the second part (2 m of the box) is not
    hi = np.asarray(m.mesh.vertices).max(axis=0)
    assert hi[0] < 1.0 + 2e-3
    (warning,) = [w for w in m.warnings if "none.glb" in w]
    number = r.text.splitlines().index("Part(asset) --> i(asset, missing=skip) X.") + 1
    assert warning.startswith(f"{path}:{number}:1: in rule 'Part': i(): mesh file not found")
    assert "left out" in warning


def test_the_strict_option_keeps_a_missing_asset_an_error(tmp_path):
    r = imported(CGA, missing_assets="error")
    assert "Part(asset) --> i(asset) X." in r.text
    path = _written(tmp_path, r.text)
    with pytest.raises(GrammarkitError, match=r"t\.grammar:\d+:\d+: in rule 'Part' .*mesh file not found: .*none\.glb"):
        derive(load(path), lot=LOT3)


def test_a_literal_missing_asset_is_reported_at_import_and_skipped_while_deriving(tmp_path):
    r = imported('Lot --> extrude(2) split(x) { 1: i("parts/none.obj") X | ~1: Y }\n')
    assert r.ok
    (entry,) = [a for a in r.report.to_json()["assets"] if a["path"] == "parts/none.obj"]
    assert entry["found"] is False
    m = derive(load(_written(tmp_path, r.text)), lot=LOT3)
    assert np.asarray(m.mesh.vertices).min(axis=0)[0] > 1.0 - 2e-3  # only the box Y is left
    assert any("none.obj" in w for w in m.warnings)


def test_the_native_language_still_stops_at_a_missing_file(tmp_path):
    """`missing=` defaults to error: a hand-written grammar's typo is not silently a hole."""
    path = _written(tmp_path, 'grammar g\nLot --> extrude(2) i("parts/nothere.obj") X.\n')
    with pytest.raises(GrammarkitError, match="mesh file not found"):
        derive(load(path), lot=LOT3)
    bad = _written(tmp_path, 'grammar g\nLot --> extrude(2) i("parts/nothere.obj", missing=maybe) X.\n')
    with pytest.raises(GrammarkitError, match="missing.*error\\|skip"):
        load(bad)
