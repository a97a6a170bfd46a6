"""The CGA corpus table: how much of each real rule file `grammarkit import-cga` translates.

    python benchmarks/bench_cga.py                 # every file in grammars/cga/
    python benchmarks/bench_cga.py --json out.json # also the machine-readable table
    python benchmarks/bench_cga.py ~/outside/*.cga # rule files from outside (docs/cga.md, "Rule
                                                   # files from outside the project")

Per file: constructs total / translated / warned (approximated + dropped); whether the
translation passes `grammarkit check`; whether it derives (`grammarkit.derive` on a 20 x 16 m
rectangular lot, seed 0, in a child process with a time limit; a failure gives the reason);
the triangles of the model's solid and of its surface layer (open faces, docs/language.md
"Solids and surfaces") and how many of them carry CGA texture coordinates (uv set 0); whether
the solid is watertight when written as GLB (UVs and textures included) and read back by
trimesh with default arguments ("no solid" when the model is made of surfaces only); the import
time (median of several runs) and its ratio to parsing alone (the baseline measured in the
same run). Then the corpus share of translated constructs and the missing features ranked by
how many warned constructs each accounts for: the work order for the engine.

Assets referenced by the corpus are not shipped (see grammars/cga/README.md), so the table is
made with `missing_assets="drop"`: an `i()` of a missing asset counts as a warned construct
(feature `asset:missing`), and the derive column measures the engine, not the absent files.
Timing numbers are noisy when other jobs share the machine's two cores.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import statistics
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "grammars" / "cga"
LOT = [(0.0, 0.0), (20.0, 0.0), (20.0, 16.0), (0.0, 16.0)]


def _derive_child(text: str, filename: str, queue: "mp.Queue") -> None:
    try:
        import numpy as np

        import grammarkit
        from grammarkit.split import Limits
        g = grammarkit.parse(text, filename=filename)
        model = grammarkit.derive(g, seed=0, lot=LOT, limits=Limits(max_shapes=50_000))
        mesh = model.mesh  # the solid; the surface layer (open faces) is apart from it
        n_surface = int(len(model.surface_faces))
        uv = [u for u in (model.triangle_uvs, model.surface_uvs) if u is not None]
        n_uv = int(sum((~np.isnan(u).any(axis=(1, 2))).sum() for u in uv))
        if len(mesh.faces):
            watertight: object = _glb_solid_watertight(model)
        else:
            watertight = "no solid"  # only surfaces: no solid to be watertight
        queue.put(("ok", watertight, (int(len(mesh.faces)), n_surface, n_uv)))
    except Exception as exc:  # noqa: BLE001 - the reason goes into the table
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        queue.put(("fail", f"{type(exc).__name__}: {first}", (0, 0, 0)))


def _glb_solid_watertight(model: object) -> bool:
    """The model written as GLB (textures and UVs included), read back by `trimesh.load` with
    default arguments, the solid's primitives (not the surface layer's node) concatenated and
    made a Trimesh with trimesh's default processing (which merges vertices by position):
    watertight or not. As tests/qa/test_readback_all_grammars.py reads files."""
    import tempfile

    import trimesh

    with tempfile.TemporaryDirectory() as tmp:
        path = model.save(Path(tmp) / "m.glb")
        scene = trimesh.load(path)
    parents = scene.graph.transforms.parents
    meshes = []
    for node in scene.graph.nodes_geometry:
        up, surface = node, False
        while up is not None:
            surface = surface or str(up).endswith(" surfaces")
            up = parents.get(up)
        if not surface:
            matrix, name = scene.graph[node]
            meshes.append(scene.geometry[name].copy().apply_transform(matrix))
    merged = trimesh.util.concatenate(meshes)
    return bool(trimesh.Trimesh(vertices=merged.vertices, faces=merged.faces).is_watertight)


def derive_in_child(text: str, filename: str, timeout: float) -> tuple[str, object, tuple[int, int, int]]:
    queue: mp.Queue = mp.get_context("spawn").Queue()
    proc = mp.get_context("spawn").Process(target=_derive_child, args=(text, filename, queue))
    proc.start()
    proc.join(timeout)
    if proc.is_alive():
        proc.terminate()
        proc.join()
        return "fail", f"timeout after {timeout:g} s", (0, 0, 0)
    try:
        return queue.get(timeout=5)
    except Exception:  # noqa: BLE001
        return "fail", f"child exited with status {proc.exitcode}", (0, 0, 0)


def median_time(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", type=Path)
    ap.add_argument("--runs", type=int, default=3, help="timing runs per file (median)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per derivation")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)

    from grammarkit.cga import translate_cga
    from grammarkit.cga.parser import parse_cga, read_cga

    files = args.files or sorted(CORPUS.glob("*.cga"))
    rows = []
    features: Counter = Counter()
    total = translated = warned = 0
    header = (f"{'file':32s} {'total':>5s} {'transl':>6s} {'warned':>6s} {'share':>6s} {'check':>5s} "
              f"{'derive':>6s} {'solid tri':>9s} {'surf tri':>8s} {'uv tri':>6s} {'watertight':>10s} {'import ms':>9s} "
              f"{'x parse':>7s}  reason")
    print(header)
    print("-" * len(header))
    for path in files:
        result = translate_cga(path, missing_assets="drop")
        rep = result.report
        text, _ = read_cga(path)
        t_parse = median_time(lambda: parse_cga(text, str(path)), args.runs)
        t_import = median_time(lambda: translate_cga(path, missing_assets="drop"), args.runs)
        derived, watertight, reason, tris = False, None, "", (0, 0, 0)
        if result.ok:
            status, value, tris = derive_in_child(result.text, str(path.with_suffix(".grammar")),
                                                   args.timeout)
            if status == "ok":
                derived, watertight = True, value
            else:
                reason = str(value)
        else:
            errors = [d.message for d in result.diagnostics if d.severity == "error"]
            reason = errors[0] if errors else "not translated"
        total += rep.total
        translated += rep.translated
        warned += rep.warned
        features.update(rep.features())
        share = rep.translated / rep.total if rep.total else 0.0
        row = {"file": path.name, "total": rep.total, "translated": rep.translated,
               "warned": rep.warned, "share": round(share, 3), "checks": bool(rep.checks),
               "derived": derived, "watertight": watertight, "reason": reason,
               "solid_triangles": tris[0], "surface_triangles": tris[1], "uv_triangles": tris[2],
               "import_ms": round(t_import * 1000, 2), "parse_ms": round(t_parse * 1000, 2)}
        rows.append(row)
        wt = ("-" if watertight is None else watertight if isinstance(watertight, str)
              else ("yes" if watertight else "NO"))
        print(f"{path.name:32s} {rep.total:5d} {rep.translated:6d} {rep.warned:6d} {share:6.1%} "
              f"{'yes' if rep.checks else 'no':>5s} {'yes' if derived else 'no':>6s} {tris[0]:9d} {tris[1]:8d} {tris[2]:6d} {wt:>10s} "
              f"{t_import * 1000:9.1f} {t_import / t_parse if t_parse else 0:7.1f}  {reason[:90]}")
    print("-" * len(header))
    share = translated / total if total else 0.0
    n_derived = sum(r["derived"] for r in rows)
    n_solid = sum(1 for r in rows if r["derived"] and r["watertight"] != "no solid")
    n_wt = sum(1 for r in rows if r["watertight"] is True)
    print(f"corpus: {len(rows)} files, {total} constructs, {translated} translated ({share:.1%}), "
          f"{warned} warned; {sum(r['checks'] for r in rows)} check, {n_derived} derive; "
          f"{n_solid} of those emit a solid, {n_wt} of which read back watertight "
          f"({n_derived - n_solid} emit surfaces only)")
    print("\nmissing features, ranked by the warned constructs they account for:")
    for feature, n in features.most_common():
        print(f"  {n:5d}  {feature}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "total": total, "translated": translated,
                                         "warned": warned, "share": share,
                                         "features": dict(features.most_common())}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
