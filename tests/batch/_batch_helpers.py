"""Shared helpers of the batch tests (lots files, the CLI, manifests)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"
TINY = DATA / "tiny.grammar"  # ~15 ms a building
BLOCK = ROOT / "grammars" / "lots" / "block.grammar"  # ~100 ms a building
CLI = [sys.executable, "-m", "grammarkit"]


def feature(ring, fid=None, *, holes=(), kind="Polygon", **props) -> dict:
    ring = [list(p) for p in ring]
    if ring[0] != ring[-1]:
        ring = ring + [ring[0]]
    coords = [ring] + [[list(p) for p in h] + [list(h[0])] for h in holes]
    geometry = {"type": "Polygon", "coordinates": coords}
    if kind == "MultiPolygon":
        geometry = {"type": "MultiPolygon", "coordinates": [coords]}
    if fid is not None:
        props = {"id": fid, **props}
    return {"type": "Feature", "properties": props, "geometry": geometry}


def rect(x, y, w, d):
    return [(x, y), (x + w, y), (x + w, y + d), (x, y + d)]


def write_lots(path: Path, features, crs: str | None = None) -> Path:
    doc = {"type": "FeatureCollection", "features": list(features)}
    if crs:
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def grid_lots(path: Path, n: int, *, x0: float = 0.0, y0: float = 0.0) -> Path:
    """n rectangular lots of varying sizes on a grid (metres)."""
    feats = []
    for i in range(n):
        x, y = x0 + (i % 6) * 30.0, y0 + (i // 6) * 30.0
        feats.append(feature(rect(x, y, 12 + (i * 7) % 9, 9 + (i * 5) % 7), f"L{i:02d}"))
    return write_lots(path, feats)


def run_cli(*args, timeout: float = 600, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, timeout=timeout, **kw)


def listed(out: Path) -> list[dict]:
    path = Path(out) / "manifest.jsonl"
    return [json.loads(x) for x in path.read_text().splitlines()] if path.exists() else []


def without_timing(entries) -> list[dict]:
    """Manifest entries without the fields that measure time (everything else must match)."""
    return [{k: v for k, v in e.items() if k != "metrics"} | {"metrics": {
        k: v for k, v in (e.get("metrics") or {}).items() if not k.endswith("_s") and k != "seconds"}}
        for e in entries]


def item_files(out: Path) -> dict[str, bytes]:
    """Every model and render file of a folder, by name."""
    return {p.name: p.read_bytes() for p in Path(out).iterdir()
            if p.suffix in (".glb", ".png", ".obj", ".ply", ".stl")}
