"""Lots files that used to end in a traceback or take minutes (issue 31): an empty ring, JSON
nested 100,000 deep, and a lot of many vertices (bounded work: a vertex limit, not a clock)."""
from __future__ import annotations

import json
import math

import pytest

from grammarkit.geometry.footprints import MAX_VERTICES
from grammarkit.run.lots import LotsError, read_lots


def _write(tmp_path, coords, name="lots.geojson"):
    f = tmp_path / name
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": coords}}]}))
    return f


def test_an_empty_ring_is_a_lot_error_not_a_traceback(tmp_path):
    (lot,) = read_lots(_write(tmp_path, [[]]))
    assert lot.polygon is None and "a lot needs at least 3 distinct points" in lot.error


def test_json_nested_too_deeply_is_a_clear_error(tmp_path):
    f = tmp_path / "deep.geojson"
    f.write_text('{"type": "Polygon", "coordinates": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(LotsError, match="nested too deeply"):
        read_lots(f)


def _circle(n, r=50.0):
    return [[r * math.cos(2 * math.pi * i / n), r * math.sin(2 * math.pi * i / n)] for i in range(n)]


def test_a_fine_lot_at_the_limit_is_read_and_one_beyond_is_refused_by_name(tmp_path):
    (lot,) = read_lots(_write(tmp_path, [_circle(MAX_VERTICES)]))
    assert lot.error is None and len(lot.polygon) == MAX_VERTICES
    (lot,) = read_lots(_write(tmp_path, [_circle(MAX_VERTICES + 1)], "big.geojson"))
    assert lot.polygon is None and f"the limit per lot is {MAX_VERTICES:,}" in lot.error
