"""The retargeter: resize a mesh by stitching translated copies of itself along its principal
offsets (Wu et al., "3D Model Retargeting Using Offset Statistics").

    retarget(mesh, size) -> trimesh.Trimesh
    retarget_report(mesh, size) -> RetargetReport   (the mesh plus everything the method found)
    scale_to(mesh, size) -> trimesh.Trimesh          (plain scaling, the baseline)

`size` is the requested bounding box (world units, the mesh's own axes). Along a principal
offset the output grows or shrinks by whole steps of it, so the bounding box is the nearest
reachable one (within one voxel of the request); `exact=True` then scales the small remainder.
A world axis that no principal offset runs along (e.g. the height of a fence) cannot be
retargeted: a request to change it is an error unless `allow_scale=True`, which scales along
that axis. A mesh without principal offsets is an error unless `allow_scale=True` (plain
scaling). Every error is a `grammarkit.errors.ShapeError` whose message starts with `name`
(the file name, when the mesh came from a file).

Parts: a mesh is read per part (its components connected by vertex index, as a GLB node or
an OBJ object gives them). A mesh is closed when every part is; parts may touch or share
edges (they are united before stitching, never welded to each other).

Open meshes: the booleans that stitch closed meshes need an inside, so an open mesh is
refused unless `open_surface=True`, which stitches its triangles as a surface (the output is
then open where the input was). A mesh with edges shared by more than two faces (parts
welded together where they touch) is refused with that remedy, not `open_surface`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import trimesh

from grammarkit.errors import ShapeError

from .alpha_expansion import Solution, alpha_expansion
from .features import SamplingParams
from .labelling import (Labelling, build_lattice, build_problem, initial_labels,
                        steps_for_target, voxel_content)
from .offsets import OffsetParams, Offsets, principal_offsets
from .stitch import stitch_solid, stitch_surface

__all__ = ["RetargetReport", "retarget", "retarget_report", "scale_to", "prepare_mesh",
           "target_from_scale", "MAX_TRIANGLES"]

AXES = "xyz"
MAX_TRIANGLES = 2_000_000


@dataclass
class RetargetReport:
    """The result of `retarget_report`.

    mesh:       the output (world units).
    method:     "retarget" (stitched copies), "scale" (plain scaling: no structure and
                allow_scale) or "unchanged" (no step along any principal offset; the mesh is
                the input's, scaled along the axes `scale` says).
    requested:  the requested bounding box size; size: the output's.
    steps:      generator steps k (0 along dummy generators).
    scale:      per-axis scale factors applied after stitching (1 where none).
    offsets:    the principal offsets and their statistics.
    labelling / solution / label_grid: the MRF, its solution and the output voxels' labels.
    stats:      graph size, label count, timings (seconds), pieces stitched.
    """

    mesh: trimesh.Trimesh
    method: str
    requested: np.ndarray
    size: np.ndarray
    input_size: np.ndarray
    steps: np.ndarray
    scale: np.ndarray
    offsets: Offsets | None
    closed: bool
    labelling: Labelling | None = None
    solution: Solution | None = None
    label_grid: np.ndarray | None = None
    stats: dict[str, Any] = field(default_factory=dict)
    input_mesh: trimesh.Trimesh | None = field(default=None, repr=False)

    @property
    def voxel_size(self) -> np.ndarray | None:
        """World size of one voxel along each world axis (the per-axis size tolerance)."""
        if self.offsets is None:
            return None
        return np.abs(self.offsets.generators).sum(axis=0)

    def summary(self) -> dict:
        out = {"method": self.method,
               "requested": np.round(self.requested, 6).tolist(),
               "size": np.round(self.size, 6).tolist(),
               "input_size": np.round(self.input_size, 6).tolist(),
               "steps": self.steps.astype(int).tolist(),
               "scale": np.round(self.scale, 6).tolist(),
               "closed": self.closed,
               "triangles": int(len(self.mesh.faces)),
               **self.stats}
        if self.offsets is not None:
            out["offsets"] = self.offsets.summary()
        return out


# ------------------------------------------------------------------------------------------
# Input checks
# ------------------------------------------------------------------------------------------
def prepare_mesh(mesh: Any, name: str = "mesh") -> trimesh.Trimesh:
    """One Trimesh from a Trimesh or Scene; ShapeError (naming `name`) for anything unusable:
    not a mesh, no triangles, NaN or infinite coordinates, a flat or point-like extent."""
    if isinstance(mesh, trimesh.Scene):
        from grammarkit.geometry.meshio import flatten

        mesh = flatten(mesh)
    if not isinstance(mesh, trimesh.Trimesh):
        raise ShapeError(f"{name}: expected a triangle mesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0:
        raise ShapeError(f"{name}: the mesh is empty (no triangles)")
    if len(mesh.faces) > MAX_TRIANGLES:
        raise ShapeError(f"{name}: {len(mesh.faces)} triangles is more than the retargeter's "
                         f"limit of {MAX_TRIANGLES}")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.isfinite(v).all():
        raise ShapeError(f"{name}: the mesh has NaN or infinite vertex coordinates")
    f = np.asarray(mesh.faces)
    if (f < 0).any() or (f >= len(v)).any():
        raise ShapeError(f"{name}: the mesh has faces referring to missing vertices")
    ext = v[np.unique(f)].max(axis=0) - v[np.unique(f)].min(axis=0)
    if float(ext.max()) <= 0.0:
        raise ShapeError(f"{name}: the mesh has zero size")
    out = trimesh.Trimesh(v, f, process=False)
    if mesh.visual.kind in ("face", "vertex"):
        out.visual.face_colors = np.asarray(mesh.visual.face_colors, dtype=np.uint8)
    out.remove_unreferenced_vertices()
    return out


def _check_size(size: Sequence[float], name: str, what: str = "target size") -> np.ndarray:
    try:
        s = np.asarray([float(x) for x in size], dtype=np.float64)
    except (TypeError, ValueError):
        raise ShapeError(f"{name}: the {what} must be three numbers, got {size!r}") from None
    if s.shape != (3,):
        raise ShapeError(f"{name}: the {what} must be three numbers (x y z), got {len(s)}")
    if not np.isfinite(s).all():
        raise ShapeError(f"{name}: the {what} {_fmt(s)} is not finite")
    if (s <= 0).any():
        bad = ", ".join(AXES[i] for i in np.flatnonzero(s <= 0))
        raise ShapeError(f"{name}: the {what} must be positive on every axis, got {_fmt(s)} "
                         f"(not positive along {bad})")
    return s


def target_from_scale(mesh: trimesh.Trimesh, factors: Sequence[float], name: str = "mesh") -> np.ndarray:
    """The target size for per-axis scale factors (`--scale 2 1 1`)."""
    f = _check_size(factors, name, "scale")
    return np.asarray(mesh.extents, dtype=np.float64) * f


def _fmt(v) -> str:
    return " x ".join(f"{float(x):.6g}" for x in v)


def _closed(mesh: trimesh.Trimesh) -> bool:
    return bool(mesh.is_watertight)


def _not_closed_message(mesh: trimesh.Trimesh, name: str) -> str:
    """Why the mesh is not closed, and the remedy that fits: boundary edges (an open surface)
    or edges shared by more than two faces (parts welded together where they touch)."""
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    boundary, shared = int((counts == 1).sum()), int((counts > 2).sum())
    head = (f"{name}: the mesh is not closed ({boundary} boundary edges, {shared} edges shared "
            "by more than two faces)")
    if shared:
        return (head + ": where parts touch along an edge they must stay separate meshes; give "
                "each part its own mesh (a node of a GLB/glTF file, an object of an OBJ file) or "
                "weld the parts into one closed solid first")
    return (head + ": the retargeter unites solid copies, which needs an inside; pass "
            "--open-surface (open_surface=True) to stitch its triangles as a surface instead "
            "(the output is then open as well)")


def _check_parts(mesh: trimesh.Trimesh, name: str) -> None:
    """Each part (connected by vertex index) must be a closed manifold solid; the ShapeError
    names the file and the part."""
    from grammarkit.geometry.convert import to_manifold

    from .stitch import part_face_sets

    sets = part_face_sets(mesh.faces, len(mesh.vertices))
    for i, faces in enumerate(sets):
        part = mesh.submesh([faces], append=True) if len(sets) > 1 else mesh
        to_manifold(part, what=name if len(sets) == 1 else f"{name}: part {i + 1} of {len(sets)}")


def scale_to(mesh: trimesh.Trimesh, size: Sequence[float]) -> trimesh.Trimesh:
    """Plain scaling to the bounding box `size`, about the bounding box's minimum corner."""
    lo = np.asarray(mesh.bounds[0], dtype=np.float64)
    ext = np.asarray(mesh.extents, dtype=np.float64)
    f = np.divide(np.asarray(size, dtype=np.float64), ext, out=np.ones(3), where=ext > 0)
    out = mesh.copy()
    out.vertices = (np.asarray(mesh.vertices) - lo) * f + lo
    return out


# ------------------------------------------------------------------------------------------
# The method
# ------------------------------------------------------------------------------------------
def retarget(mesh: Any, size: Sequence[float], **options) -> trimesh.Trimesh:
    """The mesh retargeted to bounding box `size`; see `retarget_report` for the options."""
    return retarget_report(mesh, size, **options).mesh


# long: the command's stages in order (checks, offsets, steps, labelling, solve, stitch, scale)
# with the timings and refusals that the report carries across all of them
def retarget_report(mesh: Any, size: Sequence[float], *, allow_scale: bool = False,
                    exact: bool = False, open_surface: bool = False,
                    offsets: Offsets | None = None, name: str = "mesh", seed: int = 0,
                    sampling: SamplingParams | None = None,
                    params: OffsetParams | None = None, seam: str = "geometry",
                    max_cycles: int = 8) -> RetargetReport:
    """Retarget `mesh` to the bounding box `size` and report how.

    allow_scale:  scale along axes no principal offset covers (and scale a mesh without any).
    exact:        scale the remainder so the bounding box is exactly `size`.
    open_surface: stitch an open mesh as a surface instead of refusing it.
    offsets:      principal offsets computed before (`principal_offsets(mesh)`), to reuse.
    seed:         seed of the surface samples (same seed, same output).
    seam:         the seam cost: "geometry" (default) or "descriptor" (the paper's Hausdorff
                  distance of SHOT descriptor sets); see `labelling.SeamCost`.
    """
    t_start = time.perf_counter()
    mesh = prepare_mesh(mesh, name)
    target = _check_size(size, name)
    closed = _closed(mesh)
    if not closed and not open_surface:
        raise ShapeError(_not_closed_message(mesh, name))
    if closed:
        _check_parts(mesh, name)
    input_size = np.asarray(mesh.extents, dtype=np.float64)
    colors = (np.asarray(mesh.visual.face_colors, dtype=np.uint8)
              if mesh.visual.kind in ("face", "vertex") else None)

    t0 = time.perf_counter()
    if offsets is None:
        sampling = sampling or SamplingParams(seed=seed)
        offsets = principal_offsets(mesh, sampling=sampling, params=params or OffsetParams())
    t_offsets = time.perf_counter() - t0
    stats: dict[str, Any] = {"seconds": {"offsets": round(t_offsets, 4)}}

    def finish(out_mesh, method, steps, scale, **extra) -> RetargetReport:
        stats["seconds"]["total"] = round(time.perf_counter() - t_start, 4)
        return RetargetReport(mesh=out_mesh, method=method, requested=target,
                              size=np.asarray(out_mesh.extents, dtype=np.float64),
                              input_size=input_size, steps=steps, scale=scale,
                              offsets=offsets, closed=closed, stats=stats, input_mesh=mesh,
                              **extra)

    if len(offsets) == 0:
        if not allow_scale:
            checked = offsets.stats.get("overlap_checked") or {}
            why = (f"the strongest offsets map at most {100 * max(checked.values()):.1f}% of the "
                   f"surface onto itself, {100 * offsets.params.min_overlap:.0f}% needed"
                   if checked else "no histogram peak")
            raise ShapeError(
                f"{name}: no principal offset found: the mesh shows no repetitive structure the "
                f"retargeter can stitch ({offsets.stats.get('matched', 0)} feature matches; {why}); "
                "pass --allow-scale (allow_scale=True) to scale it instead")
        f = target / input_size
        return finish(scale_to(mesh, target), "scale", np.zeros(3, np.int64), f)

    frame = offsets.frame
    mesh_n = trimesh.Trimesh(frame.to_normalised(mesh.vertices), mesh.faces, process=False)
    gens_n = offsets.generators_normalised
    lattice = build_lattice(mesh_n.vertices, gens_n, offsets.structured)
    covered = _covered_axes(gens_n, offsets.structured)
    tol = 1e-3 * input_size + 1e-9 * float(input_size.max())
    fixed_axes = [a for a in range(3) if not covered[a] and abs(target[a] - input_size[a]) > tol[a]]
    if fixed_axes and not allow_scale:
        along = ", ".join(AXES[a] for a in fixed_axes)
        have = ", ".join(f"({', '.join(f'{x:.4g}' for x in g)})" for g in offsets.principal)
        raise ShapeError(
            f"{name}: no principal offset runs along {along}, so the size along {along} cannot be "
            f"retargeted (requested {_fmt(target)}, the mesh is {_fmt(input_size)}; principal "
            f"offsets: {have}); keep that size or pass --allow-scale (allow_scale=True) to scale "
            f"along {along}")
    k = steps_for_target(input_size * frame.scale, target * frame.scale, lattice, covered)
    k, fixed_axes = _drop_unjoinable_growth(k, lattice, gens_n, offsets, fixed_axes, target,
                                            input_size, tol, allow_scale, name)
    stats["lattice"] = {"input_voxels": lattice.n_in.astype(int).tolist(),
                        "voxel": np.round(np.linalg.norm(gens_n, axis=1) / frame.scale, 6).tolist()}

    if not k.any():
        out = mesh.copy()
        method, labelling, solution, grid = "unchanged", None, None, None
    else:
        t1 = time.perf_counter()
        try:
            content = voxel_content(lattice, offsets.cloud, mesh_n, closed=closed)
            labelling = build_problem(lattice, content, k, offsets.cloud, mesh_n, seam=seam)
        except ValueError as exc:
            raise ShapeError(f"{name}: cannot retarget to {_fmt(target)}: {exc}") from None
        init = initial_labels(labelling)
        if init is None:
            raise ShapeError(
                f"{name}: cannot retarget to {_fmt(target)}: no arrangement of translated copies "
                f"fills {labelling.dims.astype(int).tolist()} voxels (the input has "
                f"{lattice.n_in.astype(int).tolist()}) with seams where the copies agree; "
                "choose a size closer to the input's")
        t2 = time.perf_counter()
        solution = alpha_expansion(labelling.problem, init, max_cycles=max_cycles)
        t3 = time.perf_counter()
        grid = solution.labels.reshape(tuple(labelling.dims))
        try:
            stitcher = stitch_solid if closed else stitch_surface
            stitched = stitcher(mesh_n, lattice, grid, labelling.labels, colors)
        except ValueError as exc:
            raise ShapeError(f"{name}: stitching failed: {exc}") from None
        t4 = time.perf_counter()
        out = stitched.mesh
        out.vertices = frame.to_world(out.vertices)
        method = "retarget"
        stats.update({"nodes": labelling.n_nodes, "labels": labelling.n_labels,
                      "edges": int(len(labelling.problem.edges)),
                      "solver": solution.stats(), "pieces": stitched.pieces,
                      "boxes": stitched.boxes})
        stats["seconds"].update({"graph": round(t2 - t1, 4), "solve": round(t3 - t2, 4),
                                 "stitch": round(t4 - t3, 4)})

    # scaling: along axes no offset covers (allow_scale), or the remainder (exact)
    current = np.asarray(out.extents, dtype=np.float64)
    factors = np.ones(3)
    for a in range(3):
        if (exact or (a in fixed_axes)) and current[a] > 0:
            factors[a] = target[a] / current[a]
    if not np.allclose(factors, 1.0, rtol=0, atol=1e-12):
        lo = np.asarray(out.bounds[0], dtype=np.float64)
        out.vertices = (np.asarray(out.vertices) - lo) * factors + lo
    return finish(out, method, k, factors, labelling=labelling, solution=solution, label_grid=grid)


def _drop_unjoinable_growth(k: np.ndarray, lattice: Any, gens_n: np.ndarray, offsets: Offsets,
                            fixed_axes: list[int], target: np.ndarray, input_size: np.ndarray,
                            tol: np.ndarray, allow_scale: bool, name: str) -> tuple[np.ndarray, list[int]]:
    """Growth along an offset the mesh spans in fewer than 3 voxels is impossible: a copy is
    joined where both copies have the voxels on both sides of the seam (the pairwise energy is
    infinite where one side is empty), which takes 3 voxels of the input along the offset (a
    staircase's two stringers 0.95 apart are such an offset). Such steps are refused with that
    reason, or with `allow_scale` dropped and the axes they would grow scaled instead."""
    short = [i for i in range(3) if lattice.structured[i] and k[i] > 0 and lattice.n_in[i] < 3]
    if not short:
        return k, fixed_axes
    axes = sorted({a for i in short for a in range(3)
                   if abs(gens_n[i][a]) >= 0.5 * np.linalg.norm(gens_n[i])})
    if not allow_scale:
        along = ", ".join(AXES[a] for a in axes)
        which = ", ".join(f"({', '.join(f'{x:.4g}' for x in offsets.generators[i])})" for i in short)
        raise ShapeError(
            f"{name}: cannot grow along {along}: the principal offset {which} repeats only once in the "
            f"mesh (it spans {int(lattice.n_in[short[0]])} of its voxels; a copy is joined only where two "
            f"copies overlap, which needs 3), so no copy can be added along it (requested "
            f"{_fmt(target)}, the mesh is {_fmt(input_size)}); keep that size or pass --allow-scale "
            f"(allow_scale=True) to scale along {along}")
    k = k.copy()
    k[short] = 0
    extra = [a for a in axes if a not in fixed_axes and abs(target[a] - input_size[a]) > tol[a]]
    return k, sorted(fixed_axes + extra)


def _covered_axes(gens_n: np.ndarray, structured: np.ndarray) -> np.ndarray:
    """World axes along which some principal offset runs (its component on the axis is at
    least half its length)."""
    covered = np.zeros(3, dtype=bool)
    for g, s in zip(gens_n, structured):
        if s:
            covered |= np.abs(g) >= 0.5 * np.linalg.norm(g)
    return covered
