"""Lots for `grammarkit batch --lots`: GeoJSON (or shapefile) polygons as building footprints.

    from grammarkit.run.lots import read_lots

    lots = read_lots("grammars/lots/block.geojson", seed=0)
    for lot in lots:
        lot.id, lot.polygon, lot.seed, lot.attrs, lot.error

Input: a GeoJSON FeatureCollection (or one Feature) of Polygon / MultiPolygon geometries, or an
ESRI shapefile (`.shp`, read by the optional `pyshp`, MIT licence: `pip install
"grammarkit[shapefile]"`). Each polygon is one lot: a MultiPolygon feature with k polygons
gives k lots named `<id>-1 .. <id>-k`.

Properties read from each feature (every other property is ignored):

- `id` (or the feature's own GeoJSON `id`): the lot's name, used for its files (characters
  other than letters, digits, `.`, `_`, `-` become `_`; a name used twice gets `_2`, `_3`, ...);
  default `lot_00007` (its position in the file).
- `seed`: an integer; default: derived from the run seed and the lot's id, so a lot keeps its
  building when lots are added or reordered.
- `attrs`: an object of attr overrides, e.g. `{"mass_h": 30, "Roof.roof_deg": 40}`; and/or one
  property per attr named `attr.<name>` (`"attr.mass_h": 30`). They override `--set` values.
- `choices`: an object binding anchors to snippets for this lot, e.g. `{"Roof": "roof_gable"}`
  (what `derive(choices=...)` takes; the snippet must be of the anchor's object type).

Units. The split engine works in metres. Coordinates are localised: the city origin (the
south-west corner of all lots, rounded down to whole metres) is subtracted, so GLB files keep
millimetre precision even for UTM coordinates; every lot's files share that origin and overlay
into the city. Coordinates in geographic degrees (lon/lat, which RFC 7946 GeoJSON uses) are
detected (a `crs` member or `.prj` naming a geographic CRS, or every coordinate within lon/lat
bounds and each lot smaller than 0.01 degree, i.e. no lot is larger than 1 cm were it metres) and
then, by default, projected to metres with a local equirectangular projection about the centre of
the lots, using the WGS84 ellipsoid's radii of curvature there (scale error under 0.1 % within
10 km of the centre); `degrees="refuse"` refuses each such lot with a message instead.

Per-lot problems never stop the other lots: a lot that is not a polygon, has fewer than three
distinct points, zero or tiny area, self-intersecting edges, holes (the engine's `derive(lot=)`
takes one simple polygon; `holes="fill"` builds on the outer ring instead) or looks like degrees
in a file of metres carries an `error` and is recorded as failed.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from .. import confine
from ..errors import GrammarkitError
from ..geometry.footprints import MAX_VERTICES, first_crossing
from ..geometry.footprints import area as polygon_area

__all__ = ["Lot", "LotSet", "LotsError", "lot_seed", "read_lots"]

MIN_AREA = 1.0  # m²: anything smaller is not a building lot (a sliver, or degrees read as metres)
MAX_EXTENT = 50_000.0  # m from the city origin: beyond this the model's float32 GLB loses detail
DEGREE_LOT_SIZE = 0.01  # a lot whose lon/lat extent is below this is taken as given in degrees
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
GEOGRAPHIC_CRS = re.compile(r"(CRS84|CRS83|CRS27|EPSG:{1,2}(4326|4269|4258|4267|4283|4617|4674)\b)", re.I)

Point = tuple[float, float]


class LotsError(GrammarkitError):
    """The lots file as a whole cannot be used (missing, not GeoJSON, no features)."""


@dataclass(frozen=True)
class Lot:
    """One building lot, ready to derive (picklable; crosses to workers)."""

    index: int  # position among the lots (manifest order)
    id: str  # file-safe, unique
    feature: int  # the feature's position in the file
    source_id: str | None  # the id as the file gives it
    part: int | None  # polygon number within a MultiPolygon (1-based), else None
    polygon: tuple[Point, ...] | None  # outer ring in local metres (None if unusable)
    holes: int = 0
    seed: int = 0
    attrs: Mapping[str, Any] = field(default_factory=dict)
    choices: Mapping[str, str] = field(default_factory=dict)
    error: str | None = None  # why this lot cannot be built (recorded as failed)
    note: str | None = None  # something the manifest should say (holes filled, id renamed)

    @property
    def area(self) -> float:
        if not self.polygon:
            return 0.0
        return abs(polygon_area(self.polygon))


@dataclass
class LotSet:
    """The lots of one file, localised to metres, with what the run needs to know about them."""

    path: Path
    lots: list[Lot]
    units: str  # "metres" or "degrees"
    origin: tuple[float, float]  # subtracted from metre coordinates (local = given - origin)
    projection: dict | None  # for degrees: {"kind": "equirectangular", "lon0", "lat0", ...}
    sha256: str  # of the file's bytes (run.json: a changed file is a different run)

    def __iter__(self) -> Iterator[Lot]:
        return iter(self.lots)

    def __len__(self) -> int:
        return len(self.lots)

    def describe(self) -> dict:
        """What run.json records about the lots."""
        return {"file": self.path.name, "sha256": self.sha256, "units": self.units,
                "origin": list(self.origin), "projection": self.projection, "count": len(self.lots)}


def lot_seed(run_seed: int, lot_id: str) -> int:
    """The seed of a lot without a `seed` property: a stable hash of the run seed and its id."""
    digest = hashlib.blake2b(f"{run_seed}:{lot_id}".encode("utf-8"), digest_size=4).digest()
    return int.from_bytes(digest, "big")


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------
def _read_geojson(path: Path, data: bytes) -> tuple[list[dict], str | None]:
    try:
        doc = json.loads(data.decode("utf-8-sig"))
    except RecursionError:  # arrays nested 100,000 deep: Python's decoder recurses
        raise LotsError(f"{path}: the JSON is nested too deeply to be GeoJSON lots") from None
    except UnicodeDecodeError as exc:
        raise LotsError(f"{path}: not a text file ({exc.reason}); expected GeoJSON") from None
    except json.JSONDecodeError as exc:
        raise LotsError(f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    if not isinstance(doc, dict):
        raise LotsError(f"{path}: expected a GeoJSON FeatureCollection (a JSON object), "
                        f"got a JSON {type(doc).__name__}")
    crs = None
    c = doc.get("crs")
    if isinstance(c, dict) and isinstance(c.get("properties"), dict):
        crs = str(c["properties"].get("name") or "") or None
    kind = doc.get("type")
    if kind == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise LotsError(f"{path}: the FeatureCollection has no `features` list")
    elif kind == "Feature":
        features = [doc]
    elif kind in ("Polygon", "MultiPolygon"):
        features = [{"type": "Feature", "geometry": doc, "properties": {}}]
    else:
        raise LotsError(f"{path}: expected a GeoJSON FeatureCollection of Polygons, got "
                        f"type {kind!r}")
    return features, crs


def _read_shapefile(path: Path) -> tuple[list[dict], str | None]:
    try:
        import shapefile  # pyshp
    except ImportError:
        raise LotsError(f"{path}: reading shapefiles needs pyshp: pip install "
                        '"grammarkit[shapefile]" (or convert the file to GeoJSON)') from None
    try:
        reader = shapefile.Reader(str(path))
        features = []
        for rec in reader.iterShapeRecords():
            try:
                geometry = rec.shape.__geo_interface__
            except Exception as exc:  # noqa: BLE001 - pyshp refuses a broken shape: per-lot error
                geometry = {"type": "Invalid", "error": str(exc)}
            features.append({"type": "Feature", "geometry": geometry,
                             "properties": rec.record.as_dict()})
        reader.close()
    except shapefile.ShapefileException as exc:
        raise LotsError(f"{path}: cannot read the shapefile: {exc}") from None
    prj = path.with_suffix(".prj")
    crs = None
    if prj.is_file():
        text = prj.read_text(encoding="utf-8", errors="replace").lstrip().upper()
        crs = "geographic" if text.startswith(("GEOGCS", "GEOGCRS")) else "projected"
    return features, crs


def _rings(geometry: Any) -> tuple[list[list[list]], str | None]:
    """The polygons of a geometry as [[outer, hole, ...], ...], or an error."""
    if not isinstance(geometry, dict):
        return [], "has no geometry"
    kind = geometry.get("type")
    coords = geometry.get("coordinates")
    if kind == "Invalid":
        return [], f"unreadable shape ({geometry.get('error')})"
    polys: Any  # checked below: the file may hold anything
    if kind == "Polygon":
        polys = [coords]
    elif kind == "MultiPolygon":
        polys = coords
    else:
        return [], f"is a {kind}, not a Polygon or MultiPolygon"
    if not isinstance(polys, list) or not polys:
        return [], "has an empty geometry"
    for poly in polys:
        if not isinstance(poly, list) or not poly or not all(isinstance(r, list) for r in poly):
            return [], "has malformed coordinates (a polygon is a list of rings of [x, y] points)"
    return polys, None


def _points(ring: list) -> tuple[list[Point] | None, str | None]:
    pts = []
    for p in ring:
        if not isinstance(p, (list, tuple)) or len(p) < 2 or not all(
                isinstance(c, (int, float)) and not isinstance(c, bool) for c in p[:2]):
            return None, f"has a point that is not [x, y] numbers: {json.dumps(p)[:60]}"
        x, y = float(p[0]), float(p[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            return None, "has a non-finite coordinate"
        pts.append((x, y))
    if len(pts) < 3:  # an empty ring ([[]]) or a line: nothing to build on
        return None, "is degenerate: a lot needs at least 3 distinct points"
    return pts, None


def _looks_like_degrees(pts: Sequence[Point]) -> bool:
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    in_bounds = min(xs) >= -180 and max(xs) <= 180 and min(ys) >= -90 and max(ys) <= 90
    return in_bounds and max(max(xs) - min(xs), max(ys) - min(ys)) < DEGREE_LOT_SIZE


def _file_id(raw: str) -> str:
    safe = re.sub(r"[^A-Za-z0-9._-]+", "_", raw).strip("._") or "lot"
    return safe[:80]


def _seed(value: Any) -> tuple[int | None, str | None]:
    if value is None:
        return None, None
    if isinstance(value, bool):
        return None, f"property seed={value!r} is not an integer"
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, str) and re.fullmatch(r"-?\d+", value.strip()):
        value = int(value.strip())
    if not isinstance(value, int):
        return None, f"property seed={value!r} is not an integer"
    return value, None


def _attrs(props: Mapping[str, Any]) -> tuple[dict, str | None]:
    out: dict[str, Any] = {}
    given = props.get("attrs")
    if isinstance(given, str) and not given.strip():
        given = None  # an empty text field (shapefiles have a value in every record)
    if given is not None:
        if isinstance(given, str):  # shapefile attributes are flat text: allow a JSON object
            try:
                given = json.loads(given)
            except ValueError:
                return {}, f"property attrs={given[:60]!r} is not a JSON object"
        if not isinstance(given, dict):
            return {}, f"property attrs must be an object of attr values, got {type(given).__name__}"
        out.update({str(k): v for k, v in given.items()})
    for key, value in props.items():
        if isinstance(key, str) and key.startswith("attr.") and len(key) > 5:
            out[key[5:]] = value
    for key, value in out.items():
        if not isinstance(value, (int, float, str, bool)) or value is None:
            return {}, f"attr {key!r} = {json.dumps(value)[:60]} is not a number, text or boolean"
    return out, None


def _choices(props: Mapping[str, Any]) -> tuple[dict, str | None]:
    given = props.get("choices")
    if isinstance(given, str):
        if not given.strip():
            return {}, None
        try:
            given = json.loads(given)
        except ValueError:
            return {}, f"property choices={given[:60]!r} is not a JSON object"
    if given is None:
        return {}, None
    if not isinstance(given, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                              for k, v in given.items()):
        return {}, "property choices must be an object of anchor names to snippet names"
    return dict(given), None


def _radii(lat0: float) -> tuple[float, float]:
    """WGS84 meridional (M) and prime-vertical (N) radii of curvature at latitude lat0 (deg)."""
    e2 = WGS84_F * (2 - WGS84_F)
    s = math.sin(math.radians(lat0))
    w = math.sqrt(1 - e2 * s * s)
    return WGS84_A * (1 - e2) / w ** 3, WGS84_A / w


def read_lots(path: str | Path, *, seed: int = 0, degrees: str = "project", holes: str = "refuse",
              units: str = "auto") -> LotSet:
    """The lots of a GeoJSON or shapefile (see the module docstring).

    seed:    run seed (lots without a `seed` property derive theirs from it and their id).
    degrees: "project" (default) or "refuse" lots given in geographic degrees.
    holes:   "refuse" (default) or "fill": build on the outer ring of a lot with holes.
    units:   "auto" (detect), "metres" or "degrees" (what the coordinates are).
    """
    if degrees not in ("project", "refuse"):
        raise GrammarkitError(f"degrees= must be 'project' or 'refuse', not {degrees!r}")
    if holes not in ("refuse", "fill"):
        raise GrammarkitError(f"holes= must be 'refuse' or 'fill', not {holes!r}")
    if units not in ("auto", "metres", "degrees"):
        raise GrammarkitError(f"units= must be 'auto', 'metres' or 'degrees', not {units!r}")
    path = Path(path)
    confine.check(path, what="lots file")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise LotsError(f"{path}: cannot read the lots file: {exc.strerror or exc}") from None
    if path.suffix.lower() == ".shp":
        features, crs = _read_shapefile(path)
    else:
        features, crs = _read_geojson(path, data)
    if not features:
        raise LotsError(f"{path}: has no features (no lots to build on)")

    raw = _raw_polygons(features)
    units, projection, origin = _to_metres(raw, units, crs, degrees)
    run_seed = seed_int(seed)
    ids = _Ids()
    lots = [_make_lot(index, r, origin, holes, run_seed, ids) for index, r in enumerate(raw)]
    return LotSet(path=path, lots=lots, units=units, origin=(float(origin[0]), float(origin[1])),
                  projection=projection, sha256=hashlib.sha256(data).hexdigest())


def _raw_polygons(features: list) -> list[dict]:
    """Every polygon of the features with its raw points, or the reason it is unusable."""
    raw: list[dict] = []
    for fi, feature in enumerate(features):
        if not isinstance(feature, dict):
            raw.append({"feature": fi, "source_id": None, "part": None, "props": {},
                        "error": "is not a GeoJSON Feature object"})
            continue
        props = feature.get("properties") or {}
        if not isinstance(props, dict):
            props = {}
        sid = props.get("id", feature.get("id"))
        sid = None if sid is None else str(sid)
        polys, err = _rings(feature.get("geometry"))
        if err:
            raw.append({"feature": fi, "source_id": sid, "part": None, "props": props, "error": err})
            continue
        for pi, rings in enumerate(polys):
            entry: dict[str, Any] = {"feature": fi, "source_id": sid, "part": pi + 1 if len(polys) > 1 else None,
                                     "props": props, "error": None, "holes": len(rings) - 1}
            outer, err = _points(rings[0])
            if err is None:
                for hole in rings[1:]:
                    _, err = _points(hole) if isinstance(hole, list) else (None, "has a malformed hole")
                    if err:
                        break
            entry["points"], entry["error"] = outer, err
            raw.append(entry)
    return raw


def _usable(raw: list[dict]) -> list[dict]:
    return [r for r in raw if r["error"] is None and r["points"]]


def _to_metres(raw: list[dict], units: str, crs: str | None, degrees: str
               ) -> tuple[str, dict | None, tuple[float, float]]:
    """Decide the units (degrees or metres), project degrees to metres in place (or mark the
    lots refused), and find the origin: (units, projection or None, origin)."""
    usable = _usable(raw)
    if units == "auto":
        if crs is not None:
            units = "degrees" if (crs == "geographic" or GEOGRAPHIC_CRS.search(crs)) else "metres"
        elif usable and all(_looks_like_degrees(r["points"]) for r in usable):
            units = "degrees"
        else:
            units = "metres"
            for r in usable:
                if _looks_like_degrees(r["points"]):
                    r["error"] = ("looks like longitude/latitude degrees (extent below "
                                  f"{DEGREE_LOT_SIZE} while other lots are in metres); give every "
                                  "lot in the same units")
    usable = _usable(raw)
    projection = None
    origin: tuple[float, float] = (0.0, 0.0)
    if units == "degrees":
        if degrees == "refuse":
            for r in usable:
                r["error"] = ("coordinates are longitude/latitude degrees, not metres; re-run "
                              "with --degrees project (a local equirectangular projection), or "
                              "reproject the file to a metric CRS (e.g. UTM with ogr2ogr -t_srs)")
        elif usable:
            xs = [p[0] for r in usable for p in r["points"]]
            ys = [p[1] for r in usable for p in r["points"]]
            lon0, lat0 = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
            m, n = _radii(lat0)
            kx, ky = n * math.cos(math.radians(lat0)) * math.pi / 180, m * math.pi / 180
            projection = {"kind": "equirectangular", "lon0": lon0, "lat0": lat0,
                          "metres_per_degree": [kx, ky], "ellipsoid": "WGS84"}
            for r in usable:
                r["points"] = [((x - lon0) * kx, (y - lat0) * ky) for x, y in r["points"]]
    usable = _usable(raw)
    if usable:
        origin = (math.floor(min(p[0] for r in usable for p in r["points"])),
                  math.floor(min(p[1] for r in usable for p in r["points"])))
        if projection is not None:
            projection["origin_m"] = list(origin)
    return units, projection, origin


@dataclass
class _Ids:
    """The file ids given so far (`used`: id -> last suffix) and how often each source id was
    seen, so that repeated ids get distinct files and seeds."""

    used: dict[str, int] = field(default_factory=dict)
    seen: dict[str, int] = field(default_factory=dict)

    def take(self, base: str) -> tuple[str, int, str | None]:
        """(file id, occurrence of `base`, note) for the next lot named `base`."""
        fid = _file_id(base)
        note = None
        occurrence = self.seen[base] = self.seen.get(base, 0) + 1
        if fid in self.used:
            k = self.used[fid] + 1
            while f"{fid}_{k}" in self.used:
                k += 1
            self.used[fid] = k
            note = f"the id {base!r} is used by an earlier lot; this lot's files are named {fid}_{k}"
            fid = f"{fid}_{k}"
        self.used.setdefault(fid, 1)
        return fid, occurrence, note


def _make_lot(index: int, r: dict, origin: tuple[float, float], holes: str, run_seed: int,
              ids: _Ids) -> Lot:
    """Lot `index` of the file from its raw polygon `r`: id, seed, attrs, the checked polygon
    or the reason it is not built."""
    base = r["source_id"] if r["source_id"] is not None else f"lot_{r['feature']:05d}"
    if r.get("part") is not None:
        base = f"{base}-{r['part']}"
    fid, occurrence, note = ids.take(base)
    props = r["props"]
    seed_value, serr = _seed(props.get("seed"))
    attrs, aerr = _attrs(props)
    choices, cerr = _choices(props)
    err = r["error"] or serr or aerr or cerr
    polygon = None
    if err is None:
        polygon, err, hole_note = _checked_polygon(r, origin, holes)
        note = _join(note, hole_note) if hole_note else note
    if err is not None:
        polygon = None
        where = f"feature {r['feature']}" + (f", polygon {r['part']}" if r.get("part") else "")
        err = f"lot {base!r} ({where}): {err}"
    # a lot's seed depends on its id (and which occurrence of that id it is), not on its
    # position: adding or reordering lots keeps every other building
    key = base if occurrence == 1 else f"{base}#{occurrence}"
    lseed = seed_value if seed_value is not None else lot_seed(run_seed, key)
    return Lot(index=index, id=fid, feature=r["feature"], source_id=r["source_id"],
               part=r.get("part"), polygon=polygon, holes=r.get("holes", 0) or 0, seed=lseed,
               attrs=attrs, choices=choices, error=err, note=note)


def _checked_polygon(r: dict, origin: tuple[float, float], holes: str
                     ) -> tuple[Any, str | None, str | None]:
    """(polygon, error, note) of a raw polygon moved to `origin`: bounded, simple, not
    degenerate, near the others; holes refused or filled."""
    from ..geometry.footprints import validate_polygon

    pts = [(x - origin[0], y - origin[1]) for x, y in r["points"]]
    far = max(max(abs(x), abs(y)) for x, y in pts)
    if len(pts) > MAX_VERTICES:  # bounded work per lot, whatever the machine's load
        return None, (f"has {len(pts):,} vertices; the limit per lot is {MAX_VERTICES:,} "
                      "(simplify the outline)"), None
    crossing = _first_crossing(pts)
    if crossing is not None:
        return None, f"is self-intersecting: edges {crossing[0]} and {crossing[1]} cross", None
    try:
        polygon = validate_polygon(pts)
    except ValueError as exc:
        return None, _polygon_message(str(exc)), None
    if far > MAX_EXTENT:
        return None, (f"lies {far / 1000:.0f} km from the other lots' origin (more than "
                      f"{MAX_EXTENT / 1000:.0f} km); split the file by district"), None
    if abs(polygon_area(polygon)) < MIN_AREA:
        return None, (f"is degenerate: its area is {abs(polygon_area(polygon)):.3g} m² (less than "
                      f"{MIN_AREA:g} m²)"), None
    if r.get("holes"):
        if holes == "fill":
            return polygon, None, f"{r['holes']} hole(s) filled: built on the outer ring"
        return None, (f"has {r['holes']} hole(s) (an inner courtyard); the split engine builds "
                      "on one simple polygon, so lots with holes are not built; use "
                      "--holes fill to build on the outer ring, or split the lot"), None
    return polygon, None, None


def _first_crossing(pts: Sequence[Point]) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges that cross properly, if any (geometry's one
    near-linear test). Checked before the footprint validator, which looks at the area first,
    so a symmetric bow-tie (zero signed area) is reported as crossing, not as "zero area"."""
    ring = list(pts)
    if len(ring) > 1 and ring[0] == ring[-1]:
        ring.pop()
    return first_crossing(ring)


def seed_int(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise GrammarkitError(f"seed must be an integer, got {seed!r}")
    return seed


def _join(a: str | None, b: str) -> str:
    return b if not a else f"{a}; {b}"


def _polygon_message(text: str) -> str:
    """The footprint validator's words, said about a lot."""
    if "cross" in text:
        return f"is self-intersecting: {text.replace('footprint ', '')}"
    if "zero area" in text or "at least 3" in text:
        return f"is degenerate: {text.replace('a footprint', 'a lot').replace('footprint ', '')}"
    return text.replace("footprint", "lot")
