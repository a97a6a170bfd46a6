"""Benchmark of the CPU renderer (grammarkit.geometry.render).

Prints a table: median wall time per style and image size for a ~20k-triangle building
(window recesses cut with manifold3d, hip roof, face colours), triangles per second, and two
baselines measured in the same run on the same model and camera:

- a naive rasteriser looping over triangles in Python (numpy inside each bounding box),
  at the same sizes, against our "shaded" style without supersampling (same pixel count;
  the other rows use the default 2x supersampling, i.e. 4x the pixels);
- trimesh's own ray casting (first hit per pixel; rtree-backed `RayMeshIntersector`, or
  embree when installed) for a depth image. It needs ~4 ms per ray on this model, so it is
  measured at a small size only (--ray-size, default 48x48) against our renderer at that size.

Usage:  python benchmarks/bench_render.py [--runs 5] [--sizes 256,512,1024] [--no-ray]
"""
from __future__ import annotations

import argparse
import os
import sys

import manifold3d as mf
import numpy as np
import trimesh

from grammarkit.geometry.camera import Camera
from grammarkit.geometry.convert import to_trimesh
from grammarkit.geometry.render import prepare, render
from _timing import median_time  # noqa: E402 - benchmarks/ is on sys.path


def make_building(nx: int = 20, ny: int = 12, floors: int = 20) -> trimesh.Trimesh:
    sx, sy, fh = 2.0, 2.0, 3.0
    W, D, H = nx * sx, ny * sy, floors * fh
    body = mf.Manifold.cube((W, D, H)).as_original()
    cuts = []
    for f in range(floors):
        z = f * fh + 0.9
        for i in range(nx):
            cuts.append(mf.Manifold.cube((1.0, 0.6, 1.5)).translate((i * sx + 0.5, -0.3, z)))
            cuts.append(mf.Manifold.cube((1.0, 0.6, 1.5)).translate((i * sx + 0.5, D - 0.3, z)))
        for j in range(ny):
            cuts.append(mf.Manifold.cube((0.6, 1.0, 1.5)).translate((-0.3, j * sy + 0.5, z)))
            cuts.append(mf.Manifold.cube((0.6, 1.0, 1.5)).translate((W - 0.3, j * sy + 0.5, z)))
    cutters = mf.Manifold.batch_boolean(cuts, mf.OpType.Add).as_original()
    roof = mf.Manifold.batch_hull([
        mf.Manifold.cube((W + 1, D + 1, 0.01)).translate((-0.5, -0.5, H)),
        mf.Manifold.cube((W * 0.2, 0.01, 0.01)).translate((W * 0.4, D / 2, H + 6))]).as_original()
    solid = (body - cutters) + roof
    raw = solid.to_mesh()
    mesh = to_trimesh(solid)
    ids = np.zeros(len(mesh.faces), dtype=np.int64)
    for k in range(len(raw.run_original_id)):
        ids[raw.run_index[k] // 3: raw.run_index[k + 1] // 3] = raw.run_original_id[k]
    colors = np.tile(np.array([225, 215, 190, 255], np.uint8), (len(ids), 1))
    colors[ids == cutters.original_id()] = [110, 140, 170, 255]
    colors[ids == roof.original_id()] = [150, 70, 55, 255]
    mesh.visual.face_colors = colors
    return mesh


def naive_zbuffer(mesh: trimesh.Trimesh, camera: Camera, size: tuple[int, int]) -> np.ndarray:
    """The obvious implementation: one Python iteration per triangle."""
    view = camera.resolve(mesh.vertices, size)
    W, H = size
    px, key = view.project(mesh.vertices)
    depth = np.full((H, W), np.inf)
    face = np.full((H, W), -1)
    for f, (a, b, c) in enumerate(mesh.faces):
        (x0, y0), (x1, y1), (x2, y2) = px[a], px[b], px[c]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area == 0:
            continue
        xa = max(int(np.ceil(min(x0, x1, x2) - 0.5)), 0)
        xb = min(int(np.floor(max(x0, x1, x2) - 0.5)), W - 1)
        ya = max(int(np.ceil(min(y0, y1, y2) - 0.5)), 0)
        yb = min(int(np.floor(max(y0, y1, y2) - 0.5)), H - 1)
        if xb < xa or yb < ya:
            continue
        X, Y = np.meshgrid(np.arange(xa, xb + 1) + 0.5, np.arange(ya, yb + 1) + 0.5)
        l1 = ((X - x0) * (y2 - y0) - (Y - y0) * (x2 - x0)) / area
        l2 = ((x1 - x0) * (Y - y0) - (y1 - y0) * (X - x0)) / area
        inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        z = key[a] + l1 * (key[b] - key[a]) + l2 * (key[c] - key[a])
        region = depth[ya:yb + 1, xa:xb + 1]
        closer = inside & (z < region)
        region[closer] = z[closer]
        face[ya:yb + 1, xa:xb + 1][closer] = f
    return face


def ray_depth(mesh: trimesh.Trimesh, camera: Camera, size: tuple[int, int]) -> np.ndarray:
    view = camera.resolve(mesh.vertices, size)
    W, H = size
    ys, xs = np.mgrid[0:H, 0:W]
    nx, ny = (xs + 0.5) / W * 2 - 1, 1 - (ys + 0.5) / H * 2
    d = view.forward + nx[..., None] * view.half_w * view.right + \
        ny[..., None] * view.half_h * view.up
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    origins = np.tile(view.eye, (len(d), 1))
    loc, ray_idx, _ = mesh.ray.intersects_location(origins, d, multiple_hits=False)
    depth = np.full(W * H, np.inf)
    depth[ray_idx] = np.linalg.norm(loc - view.eye, axis=1)
    return depth.reshape(H, W)




def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--baseline-runs", type=int, default=3)
    ap.add_argument("--sizes", default="256,512,1024")
    ap.add_argument("--ray-size", type=int, default=48)
    ap.add_argument("--no-ray", action="store_true", help="skip the (slow) ray-casting baseline")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]

    mesh = make_building()
    tris = len(mesh.faces)
    camera = Camera()
    geom = prepare(mesh)
    render(geom, camera, size=(64, 64))  # warm-up (imports, caches)
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs "
          "(other jobs inflate every time below alike)")
    print(f"model: building, {tris} triangles, {len(mesh.vertices)} vertices; "
          f"camera pitch 30 yaw -45 fov 45; supersample 2; median of {args.runs} runs")
    t_prepare = median_time(lambda: prepare(mesh), args.runs)
    print(f"prepare (gather + edge topology, reusable across cameras): {t_prepare * 1000:.1f} ms\n")

    rows = []
    for size in sizes:
        naive = median_time(lambda: naive_zbuffer(mesh, camera, (size, size)), args.baseline_runs)
        # ss=1: no supersampling, the same pixel count as the naive z-buffer (a fair pair)
        t1 = median_time(lambda: render(mesh, camera, style="shaded", size=(size, size),
                                        supersample=1), args.runs)
        rows.append((f"{size}x{size}", "shaded, ss=1", f"{t1 * 1000:.0f}",
                     f"{tris / t1 / 1e3:.0f}k", "naive loop z-buffer", f"{naive:.3f}",
                     f"{naive / t1:.1f}x"))
        for style in ("shaded", "lines", "shaded+lines"):
            t = median_time(lambda: render(mesh, camera, style=style, size=(size, size)),
                            args.runs)
            rows.append((f"{size}x{size}", style, f"{t * 1000:.0f}", f"{tris / t / 1e3:.0f}k",
                         "", "", ""))
    if not args.no_ray:
        rs = args.ray_size
        t_ray = median_time(lambda: ray_depth(mesh, camera, (rs, rs)), 1)
        t = median_time(lambda: render(mesh, camera, style="shaded", size=(rs, rs),
                                       supersample=1), args.runs)
        rows.append((f"{rs}x{rs}", "shaded, ss=1", f"{t * 1000:.0f}", f"{tris / t / 1e3:.0f}k",
                     f"trimesh ray casting ({type(mesh.ray).__name__}, 1 run)",
                     f"{t_ray:.3f}", f"{t_ray / t:.0f}x"))

    head = ("size", "style", "ours ms", "tris/s", "baseline", "baseline s", "speed-up")
    widths = [max(len(str(r[i])) for r in rows + [head]) for i in range(len(head))]
    line = "  ".join(h.ljust(w) for h, w in zip(head, widths))
    print(line)
    print("-" * len(line))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r, widths)))
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
