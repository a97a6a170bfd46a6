"""CityEngine's own runtime as the reference: each corpus rule package through `import-cga` +
`grammarkit.derive`, and (when PyPRT is installed) through PyPRT, on the same lots.

    python benchmarks/bench_prt.py                      # grammars/cga/packages/*.rpk
    python benchmarks/bench_prt.py --extra a.rpk b.rpk  # also packages kept out of the repository
    python benchmarks/bench_prt.py --record tests/cga/data/prt_reference.json
    python benchmarks/bench_prt.py --baseline           # also time the open-face single union
    python benchmarks/bench_prt.py --surfaces cga       # CityEngine's open faces as the default
    python benchmarks/bench_prt.py --previous           # also time the solid mode before issue 27's
                                                        # second step (prev ms, prev tris)
    python benchmarks/bench_prt.py --last               # ... before its third step (last ms, last tris)
    python benchmarks/bench_prt.py --prior              # ... with issue 27's speed switches off (prior ms)

PyPRT (`pip install pyprt`) is Esri's, under Esri's terms: never a dependency of grammarkit,
only this optional reference. Without it the PRT columns are empty.

Lots: the 20 x 12 m rectangle and `lshape(20, 12, 8, 5)`, default attributes, seed 0. PRT gets
the lot as `InitialShape([x0, 0, -y0, ...])` (CGA's y up, the street along -z) and its output
is turned to z-up with (X, Y, Z) -> (X, -Z, Y).

Per package and lot: derives yes/no (else the first line of the error), the largest
difference of the bounding boxes' corners (m), terminals (grammarkit) and faces (PRT),
triangles of each, whether each is watertight (trimesh, vertices welded by position) and how
many connected bodies it has, and the time ratio grammarkit / PRT: medians of alternating runs
in one process (grammarkit: `derive` of the already parsed grammar up to the finished mesh;
PRT: `generate_model` with the PyEncoder, geometry only).

grammarkit's model is checked as the user gets it too: `glb` says whether the GLB written by
`Model.save` reads back watertight with `trimesh.load(p, force="mesh")` and nothing else
(textured solids are written with UV seams, see docs/derive.md "Files"), and `open` counts
the triangles of the open surface layer (0 in the default `surfaces="solid"` mode).
`--baseline` also times, alternating with the others, the derivation as it was before issue
27: `surfaces="cga"` (open faces) and one batched union of every solid (`base ms`).

`--previous` times, alternating too, the default solid mode as it was before issue 27's second
step (open pieces closed without the convex-patch step, the walls of openings as slabs of their
own: grammarkit.geometry.closing.CONVEX_PATCHES and grammarkit.split.engine.REVEAL_VIEWS off),
with its triangles (`prev ms`, `prev tris`). `--last` times the solid mode before issue 27's third
step (`last ms`, `last tris`: the numpy sliver pre-check and the parts left out of the union in
window openings, grammarkit.split.union.SLIVER_PRECHECK and FREE_PARTS, off).

`--prior` times, alternating too, the default mode with issue 27's speed switches off
(PRIOR_SWITCHES below: each leaves the output byte-identical, tests/split/test_cga_speed.py), as
`prior ms` and `prior cpu x` (the CPU time of the switches-off run over the default one's).

On a machine shared by many jobs wall-clock times swing by several times between runs; `cpu x`
is the ratio of the processes' CPU time (time.process_time, all threads) for the same alternating
runs, steadier there.

`--union-study` (with `--only`) measures, on each package's parts as the final union gets them
(20 x 12 lot; the added solids, not the cuts), what the union's time is made of: the batched
union as `compose` runs it; the same parts first concatenated into layers of parts whose boxes
are apart (numpy, no boolean), then the layers united; and the sum of the unions of every pair
of parts whose boxes meet (the intersection work alone). CPU medians of `--runs`.

`--record` writes PRT's bounding boxes as reference numbers for tests/cga (which cannot need
PyPRT).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ROOT / "grammars" / "cga" / "packages"
LOTS = {"rect": [(0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)]}


def _lots() -> dict:
    from grammarkit.functions import lshape
    return {**LOTS, "lshape": [tuple(map(float, p)) for p in lshape(20, 12, 8, 5)]}


def import_package(rpk: Path, workdir: Path):
    """import-cga of the package as it comes -> (parsed grammar, error)."""
    import grammarkit
    from grammarkit.cga import translate_cga
    from grammarkit.cga.project import ProjectError, open_input

    out = workdir / rpk.stem / f"{rpk.stem}.grammar"
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        project = open_input(rpk, extract_to=out.parent / (rpk.name + ".d"))
    except ProjectError as exc:
        return None, str(exc)
    result = translate_cga(project.rule_file, output=out, project=project)
    if not result.ok:
        first = next((d.message for d in result.diagnostics if d.severity == "error"), "does not check")
        return None, f"import: {first}"
    out.write_text(result.text, encoding="utf-8")
    return grammarkit.parse(result.text, filename=str(out)), None


def _mesh_stats(vertices: np.ndarray, faces: np.ndarray) -> tuple[bool, int]:
    import trimesh
    if len(faces) == 0:
        return False, 0
    m = trimesh.Trimesh(vertices, faces, process=True)  # welds by position
    bodies = len(m.split(only_watertight=False))
    return bool(m.is_watertight), bodies


class single_union:
    """The baseline's composition: one batched union of every solid (the grouping of solids
    whose bounding boxes fall apart, grammarkit.split.model.MIN_GROUPED, switched off)."""

    def __enter__(self):
        from grammarkit.split import model
        self.saved = model.MIN_GROUPED, model.ALWAYS_GROUPED
        model.MIN_GROUPED = model.ALWAYS_GROUPED = 1 << 62

    def __exit__(self, *exc):
        from grammarkit.split import model
        model.MIN_GROUPED, model.ALWAYS_GROUPED = self.saved


class previous_solid:
    """The default solid mode before issue 27's second step (see the module docstring); with
    `last=True`, before its third step only (the second step's solid mode)."""

    def __init__(self, last: bool = False):
        self.last = last

    def __enter__(self):
        from grammarkit.geometry import closing
        from grammarkit.split import engine, union
        self.saved = closing.CONVEX_PATCHES, engine.REVEAL_VIEWS, union.FREE_PARTS, union.SLIVER_PRECHECK
        if not self.last:
            closing.CONVEX_PATCHES = engine.REVEAL_VIEWS = False
        union.FREE_PARTS = union.SLIVER_PRECHECK = False

    def __exit__(self, *exc):
        from grammarkit.geometry import closing
        from grammarkit.split import engine, union
        closing.CONVEX_PATCHES, engine.REVEAL_VIEWS, union.FREE_PARTS, union.SLIVER_PRECHECK = self.saved


#: issue 27's speed switches, (module, attribute): True is the default, False the code before
PRIOR_SWITCHES = [("grammarkit.split.closings", "NUMPY_REACH"),
                  ("grammarkit.split.ops.lots", "NUMPY_INNER_RECTANGLE")]


class prior_speed:
    """Every PRIOR_SWITCHES switch off (the same output, the slower code before it)."""

    def __enter__(self):
        import importlib
        self.mods = [(importlib.import_module(m), a) for m, a in PRIOR_SWITCHES]
        self.saved = [getattr(m, a) for m, a in self.mods]
        for m, a in self.mods:
            setattr(m, a, False)

    def __exit__(self, *exc):
        for (m, a), v in zip(self.mods, self.saved):
            setattr(m, a, v)


def gk_time(grammar, lot, surfaces: str, single: bool, previous: bool = False,
            last: bool = False, prior: bool = False) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of one derive."""
    import contextlib

    import grammarkit
    with single_union() if single else contextlib.nullcontext(), \
            previous_solid(last) if previous or last else contextlib.nullcontext(), \
            prior_speed() if prior else contextlib.nullcontext():
        t, c = time.perf_counter(), time.process_time()
        grammarkit.derive(grammar, seed=0, lot=lot, surfaces=surfaces)
        return time.perf_counter() - t, time.process_time() - c


def gk_triangles(grammar, lot, last: bool = False) -> int:
    import grammarkit
    with previous_solid(last):
        m = grammarkit.derive(grammar, seed=0, lot=lot)
    return int(m.solid_triangle_count + m.surface_triangle_count)


def glb_watertight(model) -> bool:
    import trimesh
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.glb"
        model.save(path)
        mesh = trimesh.load(path, force="mesh")
        return bool(len(mesh.faces) and mesh.is_watertight and mesh.is_winding_consistent)


def gk_run(grammar, lot, surfaces: str = "solid", check_glb: bool = False) -> dict:
    import grammarkit
    t = time.perf_counter()
    model = grammarkit.derive(grammar, seed=0, lot=lot, surfaces=surfaces)
    dt = time.perf_counter() - t
    solid_v, solid_f = np.asarray(model.mesh.vertices), np.asarray(model.mesh.faces)
    sv = np.asarray(model.surface_vertices) if model.surface_vertices is not None else np.zeros((0, 3))
    sf = np.asarray(model.surface_faces) if model.surface_faces is not None else np.zeros((0, 3), int)
    verts = np.vstack([solid_v.reshape(-1, 3), sv.reshape(-1, 3)])
    faces = np.vstack([solid_f.reshape(-1, 3), sf.reshape(-1, 3) + len(solid_v)])
    bbox = [verts.min(axis=0).tolist(), verts.max(axis=0).tolist()] if len(verts) else None
    tight, bodies = _mesh_stats(verts, faces)
    terminals = sum(1 for _ in model.parts) if hasattr(model, "parts") else None
    return {"time": dt, "bbox": bbox, "triangles": int(len(faces)), "terminals": terminals,
            "watertight": tight, "bodies": bodies, "open": int(len(sf)),
            "glb": glb_watertight(model) if check_glb else None}


def prt_run(pyprt, rpk: Path, lot) -> dict:
    coords = []
    for x, y in lot:
        coords += [x, 0.0, -y]
    gen = pyprt.ModelGenerator([pyprt.InitialShape(coords)])
    t, c = time.perf_counter(), time.process_time()
    models = gen.generate_model([{}], str(rpk.resolve()), "com.esri.pyprt.PyEncoder",
                                {"emitReport": False, "emitGeometry": True})
    dt, dc = time.perf_counter() - t, time.process_time() - c
    verts, tris, nfaces = [], [], 0
    base = 0
    for m in models:
        v = np.asarray(m.get_vertices(), float).reshape(-1, 3)
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)  # y-up -> z-up
        idx = m.get_indices()
        k = 0
        for n in m.get_faces():
            poly = idx[k:k + n]
            k += n
            nfaces += 1
            tris += [(base + poly[0], base + poly[j], base + poly[j + 1]) for j in range(1, n - 1)]
        verts.append(v)
        base += len(v)
    allv = np.vstack(verts) if verts else np.zeros((0, 3))
    faces = np.asarray(tris, int).reshape(-1, 3)
    bbox = [allv.min(axis=0).tolist(), allv.max(axis=0).tolist()] if len(allv) else None
    tight, bodies = _mesh_stats(allv, faces)
    return {"time": dt, "cpu": dc, "bbox": bbox, "triangles": int(len(faces)), "faces": nfaces,
            "watertight": tight, "bodies": bodies}


def bbox_diff(a, b) -> float | None:
    if a is None or b is None:
        return None
    return float(np.abs(np.asarray(a) - np.asarray(b)).max())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--extra", nargs="*", type=Path, default=[], help="more .rpk packages")
    ap.add_argument("--runs", type=int, default=5, help="alternating timed runs per lot (median)")
    ap.add_argument("--record", type=Path, default=None, help="write PRT's bboxes here (JSON)")
    ap.add_argument("--json", type=Path, default=None, help="also write the table as JSON")
    ap.add_argument("--surfaces", choices=("solid", "cga"), default="solid",
                    help="grammarkit's output: one watertight solid (default) or CGA's open faces")
    ap.add_argument("--single-union", action="store_true",
                    help="compose with one batched union of every solid (the baseline's way)")
    ap.add_argument("--baseline", action="store_true",
                    help="also time surfaces=cga with a single union (before issue 27)")
    ap.add_argument("--previous", action="store_true",
                    help="also time the solid mode before issue 27's second step")
    ap.add_argument("--last", action="store_true",
                    help="also time the solid mode before issue 27's third step (last ms, last tris)")
    ap.add_argument("--prior", action="store_true",
                    help="also time the default mode with issue 27's speed switches off (prior ms)")
    ap.add_argument("--only", nargs="*", default=None, help="only these package names (stems)")
    ap.add_argument("--union-study", action="store_true",
                    help="what the final union's time is made of (see the module docstring)")
    args = ap.parse_args(argv)
    if args.union_study:
        return union_study(args.only, args.runs)
    try:
        import pyprt  # noqa: F401 - optional reference (Esri's terms), never a dependency
    except ImportError:
        pyprt = None
    rpks = sorted(PACKAGES.glob("*.rpk")) + list(args.extra)
    if args.only is not None:
        rpks = [r for r in rpks if r.stem in args.only]
    rows, reference = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for rpk in rpks:
            grammar, err = import_package(rpk, Path(tmp))
            for lot_name, lot in _lots().items():
                row = {"package": rpk.stem, "lot": lot_name, "derives": False, "error": err}
                gk, prt, gk_t, prt_t, base_t, prev_t, gk_c, prt_c = None, None, [], [], [], [], [], []
                last_t: list = []
                prior_t: list = []
                prior_c: list = []
                if grammar is not None:
                    try:  # once untimed: the GLB check, and warm caches for every timed run
                        gk = gk_run(grammar, lot, args.surfaces, check_glb=True)
                    except Exception as exc:  # noqa: BLE001 - a failing package is a row, not a crash
                        row["error"] = f"derive: {str(exc).splitlines()[0][:120]}"
                for _ in range(max(1, args.runs)):  # alternate: the same machine state for both
                    if grammar is not None and row["error"] is None:
                        wall, cpu = gk_time(grammar, lot, args.surfaces, args.single_union)
                        gk_t.append(wall)
                        gk_c.append(cpu)
                        if args.baseline:
                            base_t.append(gk_time(grammar, lot, "cga", True)[0])
                        if args.previous:
                            prev_t.append(gk_time(grammar, lot, "solid", False, previous=True)[0])
                        if args.last:
                            last_t.append(gk_time(grammar, lot, "solid", False, last=True)[0])
                        if args.prior:
                            pw, pc = gk_time(grammar, lot, args.surfaces, args.single_union, prior=True)
                            prior_t.append(pw)
                            prior_c.append(pc)
                    if pyprt is not None:
                        prt = prt_run(pyprt, rpk, lot)
                        prt_t.append(prt["time"])
                        prt_c.append(prt["cpu"])
                row["derives"] = gk is not None and row["error"] is None
                row["gk"], row["prt"] = gk, prt
                row["bbox_diff"] = bbox_diff(gk and gk["bbox"], prt and prt["bbox"])
                row["gk_ms"] = statistics.median(gk_t) * 1e3 if gk_t else None
                row["prt_ms"] = statistics.median(prt_t) * 1e3 if prt_t else None
                row["base_ms"] = statistics.median(base_t) * 1e3 if base_t else None
                row["prev_ms"] = statistics.median(prev_t) * 1e3 if prev_t else None
                row["prev_tris"] = gk_triangles(grammar, lot) if prev_t else None
                row["last_ms"] = statistics.median(last_t) * 1e3 if last_t else None
                row["last_tris"] = gk_triangles(grammar, lot, last=True) if last_t else None
                row["prior_ms"] = statistics.median(prior_t) * 1e3 if prior_t else None
                row["prior_cpu_x"] = (statistics.median(prior_c) / statistics.median(gk_c)
                                      if prior_c and gk_c and statistics.median(gk_c) > 0 else None)
                row["cpu_ratio"] = (statistics.median(gk_c) / statistics.median(prt_c)
                                    if gk_c and prt_c and statistics.median(prt_c) > 0 else None)
                row["gk_cpu_ms"] = statistics.median(gk_c) * 1e3 if gk_c else None
                row["prt_cpu_ms"] = statistics.median(prt_c) * 1e3 if prt_c else None
                row["ratio"] = row["gk_ms"] / row["prt_ms"] if gk_t and prt_t and row["prt_ms"] else None
                rows.append(row)
                if prt is not None:
                    reference.setdefault(rpk.stem, {})[lot_name] = {
                        "bbox": [[round(c, 4) for c in prt["bbox"][0]], [round(c, 4) for c in prt["bbox"][1]]]
                        if prt["bbox"] else None, "triangles": prt["triangles"]}
    _print(rows, pyprt is not None, args.baseline, args.previous, args.last, args.prior)
    if args.record is not None and reference:
        args.record.parent.mkdir(parents=True, exist_ok=True)
        args.record.write_text(json.dumps({"source": "PyPRT generate_model, default attributes, lots of "
                                           "benchmarks/bench_prt.py, z-up", "packages": reference},
                                          indent=1, sort_keys=True) + "\n", encoding="utf-8")
        print(f"recorded PRT reference bboxes in {args.record}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1, default=str) + "\n", encoding="utf-8")
    return 0


def union_parts(grammar, lot) -> list:
    """The solids the final union of one derive gets (openings cut, free parts left out)."""
    import grammarkit
    from grammarkit.split import model
    seen = []
    original = model.surface_layer  # called by compose once `adds` is final

    def spy(ctx):
        seen.append(list(ctx.adds))
        return original(ctx)
    model.surface_layer = spy
    try:
        grammarkit.derive(grammar, seed=0, lot=lot)
    finally:
        model.surface_layer = original
    return seen[-1]


def _concatenated(parts: list):
    """One manifold of disjoint parts, their meshes concatenated (no boolean)."""
    import manifold3d
    meshes = [p.to_mesh() for p in parts]
    offsets = np.cumsum([0] + [len(m.vert_properties) for m in meshes])
    v = np.concatenate([np.asarray(m.vert_properties, dtype=np.float32) for m in meshes])
    f = np.concatenate([np.asarray(m.tri_verts, dtype=np.uint32) + np.uint32(o) for m, o in zip(meshes, offsets)])
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.ascontiguousarray(v),
                                               tri_verts=np.ascontiguousarray(f)))


def _box_layers(boxes: np.ndarray, sizes: np.ndarray) -> list[list[int]]:
    """Greedy colouring, largest parts first: layers of parts whose closed boxes are apart."""
    layers: list[list[int]] = []
    for i in np.argsort(-sizes, kind="stable").tolist():
        for layer in layers:
            lb = boxes[layer]
            if not ((lb[:, :3] <= boxes[i, 3:]) & (boxes[i, :3] <= lb[:, 3:])).all(axis=1).any():
                layer.append(i)
                break
        else:
            layers.append([i])
    return layers


def _cpu(fn) -> float:
    c = time.process_time()
    fn().num_tri()  # manifold3d evaluates lazily
    return time.process_time() - c


def union_study(only: list | None, runs: int) -> int:
    import manifold3d
    add = manifold3d.OpType.Add
    print(f"{'package':<12} {'parts':>5} {'in tris':>8} {'out tris':>8} {'pairs':>6} {'union ms':>9} "
          f"{'layers':>6} {'layered ms':>10} {'pairs ms':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for rpk in sorted(PACKAGES.glob("*.rpk")):
            if only is not None and rpk.stem not in only:
                continue
            grammar, err = import_package(rpk, Path(tmp))
            if grammar is None:
                print(f"{rpk.stem:<12} {err}")
                continue
            parts = union_parts(grammar, LOTS["rect"])
            if len(parts) < 2:
                continue
            boxes = np.asarray([p.bounding_box() for p in parts], dtype=np.float64)
            sizes = np.asarray([p.num_tri() for p in parts])
            meet = ((boxes[:, None, :3] <= boxes[None, :, 3:]) & (boxes[None, :, :3] <= boxes[:, None, 3:])).all(2)
            pairs = [(i, j) for i, j in zip(*np.nonzero(np.triu(meet, 1)))]
            layers = _box_layers(boxes, sizes)
            plain, layered, pair = [], [], []
            for _ in range(runs):
                plain.append(_cpu(lambda: manifold3d.Manifold.batch_boolean(parts, add)))
                layered.append(_cpu(lambda: manifold3d.Manifold.batch_boolean(
                    [_concatenated([parts[i] for i in layer]) for layer in layers], add)))
                pair.append(sum(_cpu(lambda i=i, j=j: parts[i] + parts[j]) for i, j in pairs))
            out = manifold3d.Manifold.batch_boolean(parts, add).num_tri()
            print(f"{rpk.stem:<12} {len(parts):>5} {int(sizes.sum()):>8} {out:>8} {len(pairs):>6} "
                  f"{statistics.median(plain) * 1e3:>9.0f} {len(layers):>6} "
                  f"{statistics.median(layered) * 1e3:>10.0f} {statistics.median(pair) * 1e3:>9.0f}")
    return 0


def _fmt(v, spec=".2f") -> str:
    return "-" if v is None else format(v, spec)


# long: one table, one column group per option, and the summed line
def _print(rows: list, have_prt: bool, baseline: bool = False, previous: bool = False,
           last: bool = False, prior: bool = False) -> None:
    print(f"{'package':18} {'lot':6} {'der':3} {'bbox d(m)':>9} {'terms':>6} {'prt faces':>9} "
          f"{'tris gk':>8} {'tris prt':>8} {'tris x':>6} {'open':>6} {'tight gk/prt':>12} {'glb':>3} "
          f"{'bodies gk/prt':>13} {'gk ms':>8} {'prt ms':>8} {'ratio':>6} {'cpu x':>6}"
          + (f" {'base ms':>8}" if baseline else "") + (f" {'prev ms':>8} {'prev tris':>9}" if previous else "")
          + (f" {'last ms':>8} {'last tris':>9}" if last else "")
          + (f" {'prior ms':>8} {'prior cpu x':>11}" if prior else ""))
    for r in rows:
        gk, prt = r["gk"] or {}, r["prt"] or {}
        tight = f"{_yn(gk.get('watertight'))}/{_yn(prt.get('watertight'))}"
        bodies = f"{gk.get('bodies', '-')}/{prt.get('bodies', '-')}"
        tris_x = gk["triangles"] / prt["triangles"] if gk.get("triangles") and prt.get("triangles") else None
        print(f"{r['package'][:18]:18} {r['lot'][:6]:6} {'yes' if r['derives'] else 'no':3} "
              f"{_fmt(r['bbox_diff'], '.3f'):>9} {gk.get('terminals', '-')!s:>6} {prt.get('faces', '-')!s:>9} "
              f"{gk.get('triangles', '-')!s:>8} {prt.get('triangles', '-')!s:>8} {_fmt(tris_x):>6} "
              f"{gk.get('open', '-')!s:>6} {tight:>12} {_yn(gk.get('glb')):>3} {bodies:>13} "
              f"{_fmt(r['gk_ms'], '.1f'):>8} {_fmt(r['prt_ms'], '.1f'):>8} {_fmt(r['ratio']):>6} "
              f"{_fmt(r.get('cpu_ratio')):>6}"
              + (f" {_fmt(r.get('base_ms'), '.1f'):>8}" if baseline else "")
              + (f" {_fmt(r.get('prev_ms'), '.1f'):>8} {r.get('prev_tris') or '-'!s:>9}" if previous else "")
              + (f" {_fmt(r.get('last_ms'), '.1f'):>8} {r.get('last_tris') or '-'!s:>9}" if last else "")
              + (f" {_fmt(r.get('prior_ms'), '.1f'):>8} {_fmt(r.get('prior_cpu_x')):>11}" if prior else ""))
        if r["error"]:
            print(f"    {r['error']}")
    timed = [r for r in rows if r["gk_ms"] is not None and r["prt_ms"] is not None]
    if timed:
        gk_sum, prt_sum = sum(r["gk_ms"] for r in timed), sum(r["prt_ms"] for r in timed)
        line = (f"summed over {len(timed)} package x lot rows: grammarkit {gk_sum:.1f} ms, PyPRT "
                f"{prt_sum:.1f} ms, ratio {gk_sum / prt_sum:.2f}")
        cpu = [r for r in timed if r.get("gk_cpu_ms") is not None and r.get("prt_cpu_ms")]
        if cpu:
            line += (f"; CPU {sum(r['gk_cpu_ms'] for r in cpu):.1f} vs {sum(r['prt_cpu_ms'] for r in cpu):.1f} ms, "
                     f"ratio {sum(r['gk_cpu_ms'] for r in cpu) / sum(r['prt_cpu_ms'] for r in cpu):.2f}")
        if baseline and all(r.get("base_ms") is not None for r in timed):
            line += f"; baseline {sum(r['base_ms'] for r in timed):.1f} ms"
        if previous and all(r.get("prev_ms") is not None for r in timed):
            prev = sum(r["prev_ms"] for r in timed)
            line += f"; previous solid mode {prev:.1f} ms (ratio {prev / prt_sum:.2f})"
        if last and all(r.get("last_ms") is not None for r in timed):
            lt = sum(r["last_ms"] for r in timed)
            line += f"; last step's solid mode {lt:.1f} ms (ratio {lt / prt_sum:.2f})"
        if prior and all(r.get("prior_ms") is not None for r in timed):
            pr = sum(r["prior_ms"] for r in timed)
            line += f"; speed switches off {pr:.1f} ms (ratio {pr / prt_sum:.2f})"
        print(line)
    if not have_prt:
        print("(PyPRT is not installed: no reference columns; `pip install pyprt`, Esri's terms)")


def _yn(v) -> str:
    return "-" if v is None else ("y" if v else "n")


if __name__ == "__main__":
    sys.exit(main())
