"""Reading lots: localised metres, lon/lat degrees detected and projected (or refused), and a
clear per-lot message for every polygon that cannot be built."""
from __future__ import annotations

import json
import math

import pytest

from _batch_helpers import feature, rect, write_lots
from grammarkit.run.lots import LotsError, lot_seed, read_lots


def one(lots, i=0):
    return lots.lots[i]


def test_metre_lots_are_localised_to_a_shared_origin(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [
        feature(rect(652310.4, 6862150.7, 20, 12), "a"),
        feature(rect(652340.0, 6862160.0, 10, 10), "b")], crs="urn:ogc:def:crs:EPSG::2154")
    lots = read_lots(path)
    assert lots.units == "metres" and lots.projection is None
    assert lots.origin == (652310.0, 6862150.0)
    a, b = lots.lots
    assert a.error is None and b.error is None
    assert min(x for x, _ in a.polygon) == pytest.approx(0.4)
    assert min(y for _, y in b.polygon) == pytest.approx(10.0)
    assert a.area == pytest.approx(240.0)
    assert lots.describe()["sha256"] == lots.sha256 and len(lots.sha256) == 64


def test_degrees_are_detected_and_projected_with_local_scale(tmp_path):
    # two lots 0.001 degree of latitude apart near Paris (48.85 N): about 111.2 m
    d = 0.0001  # ~7 x 11 m lots
    path = write_lots(tmp_path / "l.geojson", [
        feature(rect(2.3500, 48.8500, d, d), "south"),
        feature(rect(2.3500, 48.8510, d, d), "north")])
    lots = read_lots(path)
    assert lots.units == "degrees" and lots.projection["kind"] == "equirectangular"
    s, n = lots.lots
    assert s.error is None and n.error is None
    dy = min(y for _, y in n.polygon) - min(y for _, y in s.polygon)
    assert dy == pytest.approx(111.2, abs=0.2)  # WGS84 meridian arc of 0.001 degree at 48.85 N
    width = max(x for x, _ in s.polygon) - min(x for x, _ in s.polygon)
    assert width == pytest.approx(0.0001 * 111_320 * math.cos(math.radians(48.85)), rel=3e-3)


def test_degrees_can_be_refused_per_lot_with_a_message(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [feature(rect(2.35, 48.85, 1e-4, 1e-4), "a")],
                      crs="urn:ogc:def:crs:OGC:1.3:CRS84")
    lot = one(read_lots(path, degrees="refuse"))
    assert lot.polygon is None
    assert "lot 'a' (feature 0): coordinates are longitude/latitude degrees, not metres" in lot.error
    assert "--degrees project" in lot.error


def test_a_degree_lot_among_metre_lots_is_refused(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [
        feature(rect(100, 100, 20, 10), "m"), feature(rect(2.35, 48.85, 1e-4, 1e-4), "deg")])
    m, deg = read_lots(path).lots
    assert m.error is None
    assert "looks like longitude/latitude degrees" in deg.error and "'deg'" in deg.error


@pytest.mark.parametrize("ring,words", [
    ([(0, 0), (10, 10), (10, 0), (0, 10)], "is self-intersecting: edges 0 and 2 cross"),
    ([(0, 0), (10, 0), (20, 0)], "is degenerate"),
    ([(0, 0), (10, 0)], "is degenerate: a lot needs at least 3 distinct points"),
    ([(0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5)], "is degenerate: its area is 0.25 m²"),
])
def test_invalid_polygons_get_a_clear_per_lot_message(tmp_path, ring, words):
    path = write_lots(tmp_path / "l.geojson", [feature(rect(0, 0, 10, 10), "good"),
                                                {"type": "Feature", "properties": {"id": "bad"},
                                                 "geometry": {"type": "Polygon",
                                                              "coordinates": [[list(p) for p in ring]]}}])
    good, bad = read_lots(path).lots
    assert good.error is None
    assert bad.error.startswith("lot 'bad' (feature 1): ") and words in bad.error, bad.error


def test_holes_are_refused_or_filled(tmp_path):
    outer = rect(0, 0, 30, 30)
    hole = [(10, 10), (10, 20), (20, 20), (20, 10)]
    path = write_lots(tmp_path / "l.geojson", [feature(outer, "court", holes=[hole])])
    refused = one(read_lots(path))
    assert "has 1 hole(s)" in refused.error and "--holes fill" in refused.error
    filled = one(read_lots(path, holes="fill"))
    assert filled.error is None and filled.holes == 1 and "filled" in filled.note
    assert filled.area == pytest.approx(900.0)


def test_other_geometries_and_broken_features_are_per_lot_messages(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [
        {"type": "Feature", "properties": {"id": "pt"}, "geometry": {"type": "Point", "coordinates": [1, 2]}},
        {"type": "Feature", "properties": {"id": "none"}, "geometry": None},
        {"type": "Feature", "properties": {"id": "txt"},
         "geometry": {"type": "Polygon", "coordinates": [[[0, 0], ["a", 1], [1, 1]]]}},
        feature(rect(0, 0, 10, 10), "ok")])
    pt, none, txt, ok = read_lots(path).lots
    assert "is a Point, not a Polygon or MultiPolygon" in pt.error
    assert "has no geometry" in none.error
    assert "is not [x, y] numbers" in txt.error
    assert ok.error is None


def test_multipolygons_give_one_lot_per_polygon(tmp_path):
    doc = {"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"id": "twin"},
        "geometry": {"type": "MultiPolygon", "coordinates": [
            [[list(p) for p in rect(0, 0, 10, 10)] + [[0, 0]]],
            [[list(p) for p in rect(20, 0, 10, 10)] + [[20, 0]]]]}}]}
    path = tmp_path / "l.geojson"
    path.write_text(json.dumps(doc))
    a, b = read_lots(path).lots
    assert (a.id, a.part, b.id, b.part) == ("twin-1", 1, "twin-2", 2)
    assert a.seed != b.seed


def test_ids_seeds_and_attrs_come_from_properties(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [
        feature(rect(0, 0, 10, 10), "rue de la Paix/3", seed=42, attrs={"h": 9}, **{"attr.roof_deg": 25}),
        feature(rect(20, 0, 10, 10), "rue de la Paix/3"),
        feature(rect(40, 0, 10, 10)),
        feature(rect(60, 0, 10, 10), "s", seed="7"),
        feature(rect(80, 0, 10, 10), "bad-seed", seed=1.5),
        feature(rect(100, 0, 10, 10), "bad-attr", attrs={"h": [1, 2]})])
    lots = read_lots(path, seed=3)
    first, dup, anon, s, bad_seed, bad_attr = lots.lots
    assert first.id == "rue_de_la_Paix_3" and first.source_id == "rue de la Paix/3"
    assert first.seed == 42 and dict(first.attrs) == {"h": 9, "roof_deg": 25}
    assert dup.id == "rue_de_la_Paix_3_2" and "used by an earlier lot" in dup.note
    assert dup.seed == lot_seed(3, "rue de la Paix/3#2")  # the id's second occurrence
    assert anon.id == "lot_00002" and anon.seed == lot_seed(3, "lot_00002")
    assert s.seed == 7
    assert "seed=1.5 is not an integer" in bad_seed.error
    assert "attr 'h' = [1, 2] is not a number" in bad_attr.error
    # a lot keeps its seed when other lots are added or reordered
    unique = feature(rect(0, 0, 10, 10), "uniq")
    a = read_lots(write_lots(tmp_path / "a.geojson", [unique, feature(rect(20, 0, 9, 9), "x")]), seed=3)
    b = read_lots(write_lots(tmp_path / "b.geojson", [feature(rect(20, 0, 9, 9), "y"),
                                                      feature(rect(40, 0, 9, 9), "z"), unique]), seed=3)
    assert a.lots[0].seed == b.lots[2].seed == lot_seed(3, "uniq")
    assert read_lots(tmp_path / "a.geojson", seed=4).lots[0].seed != a.lots[0].seed


def test_lots_far_apart_are_refused(tmp_path):
    path = write_lots(tmp_path / "l.geojson", [feature(rect(0, 0, 10, 10), "near"),
                                                feature(rect(90_000, 0, 10, 10), "far")])
    near, far = read_lots(path).lots
    assert near.error is None and "lies 90 km from the other lots' origin" in far.error


@pytest.mark.parametrize("text,words", [
    ("{not json", ":1:2: not valid JSON"),
    ("[1, 2]", "expected a GeoJSON FeatureCollection (a JSON object)"),
    ('{"type": "Topology"}', "expected a GeoJSON FeatureCollection of Polygons, got type 'Topology'"),
    ('{"type": "FeatureCollection", "features": []}', "has no features"),
])
def test_an_unusable_file_is_one_clear_error(tmp_path, text, words):
    path = tmp_path / "l.geojson"
    path.write_text(text)
    with pytest.raises(LotsError, match="l.geojson") as info:
        read_lots(path)
    assert words in str(info.value)


def test_shapefiles_are_read_with_pyshp(tmp_path):
    shapefile = pytest.importorskip("shapefile")  # the optional [shapefile] extra
    base = tmp_path / "lots"
    with shapefile.Writer(str(base), shapeType=shapefile.POLYGON) as w:
        w.field("id", "C")
        w.field("seed", "N")
        w.field("attrs", "C", size=100)
        # shapefile rings: outer clockwise
        w.poly([[(0, 0), (0, 10), (12, 10), (12, 0), (0, 0)]])
        w.record("a", 5, '{"h": 7}')
        w.poly([[(20, 0), (30, 10), (30, 0), (20, 10), (20, 0)]])
        w.record("bowtie", 1, "")
    lots = read_lots(tmp_path / "lots.shp")
    a, bow = lots.lots
    assert a.error is None and a.seed == 5 and dict(a.attrs) == {"h": 7} and a.area == pytest.approx(120)
    assert "self-intersecting" in bow.error
