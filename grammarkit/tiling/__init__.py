"""Tiling grammars: segmented models, shape graphs, learned rules, validation and docking.

Public API (signatures are stable; the graph sampler builds on them):

    read_assembly(path, *, grammar=None, name=None) -> Assembly     # GLB/glTF/OBJ/folder
    write_assembly(assembly, path) -> Path                          # atomic; reads back the same
    load_examples(grammar) -> list[Assembly]                        # the grammar's `example`s
    part_prototype(grammar, type_name) -> trimesh.Trimesh           # `part T = box(...)|mesh(...)`
    shape_graph(assembly, tolerance=None) -> networkx.Graph          # nodes: part ids (type, centroid)
    rules_from_grammar(grammar) -> Rules
    validate(grammar_or_rules, assembly, *, tolerance=None, graph=None, docks=True) -> Report
    learn(assemblies, name="learned", *, example_paths=None, bandwidth=0.1, docks=True) -> Grammar
    mean_shift(points, bandwidth) -> (modes, labels)                 # learn's flat-kernel Mean Shift
    example_count_ranges(examples) -> {type: (fewest, most)}         # the examples' part counts
    ANGLE_SCALE_DEG                          # learn: a rotation this large weighs like one bandwidth
    dock(a_points, b_points) -> (4x4 rigid transform, rms residual)  # Kabsch, det +1
    local_frame(part) -> 4x4                                        # Kalojanov's diagonal frame
    symmetry_offsets(vertices, faces) -> [4x4]      # rotations S: F @ S is the same part's frame too
    up_vector(axis) -> (3,) or None                 # "+z" ... "-x" as a unit vector; None for `up none`
    contacts(assembly_or_parts, tolerance=None, *, geom=None, pairs=None) -> list[Contact]
    prepare(parts) -> PartGeometry       # per-part bounds/centroids, reusable across contacts()
    surface_centroid(vertices, faces) -> (3,) area-weighted centroid

Shape-graph machinery for back ends that edit shapes (index-based graphs and parts):

    adjacency_from_edges, induced_edges, replace_subgraph, random_connected_subgraph,
    Cut, cut_layers, match_boundary, kept_region, distance_matrix, histogram_key   # .graphops
    moved_mesh, bounds_of, PartCache, part_key, contacts_involving, ForbiddenContact,
    edit_violations, full_check, graph_of                                           # .incremental

See docs/tiling.md.
"""
from __future__ import annotations

import sys
import types
from importlib import import_module
from typing import TYPE_CHECKING, Any

# Submodules are imported on first use: loading the `core-constraints` plugin (every
# `grammarkit` command does) must not pull in trimesh and scipy.
_EXPORTS = {
    "Assembly": "assembly", "Part": "assembly",
    "DEFAULT_RELATIVE_TOLERANCE": "contacts", "default_tolerance": "contacts",
    "Contact": "contacts", "PartGeometry": "contacts", "contacts": "contacts", "prepare": "contacts",
    "surface_centroid": "frames",
    "dock": "dock",
    "local_frame": "frames", "relative_placement": "frames", "symmetry_offsets": "frames",
    "up_vector": "orientation",
    "shape_graph": "graph",
    "Cut": "graphops", "adjacency_from_edges": "graphops", "cut_layers": "graphops",
    "distance_matrix": "graphops", "histogram_key": "graphops", "induced_edges": "graphops",
    "kept_region": "graphops", "match_boundary": "graphops",
    "random_connected_subgraph": "graphops", "replace_subgraph": "graphops",
    "ForbiddenContact": "incremental", "PartCache": "incremental", "bounds_of": "incremental",
    "contacts_involving": "incremental", "edit_violations": "incremental",
    "full_check": "incremental", "graph_of": "incremental", "moved_mesh": "incremental",
    "part_key": "incremental",
    "ShapeWarning": "io", "load_examples": "io", "part_prototype": "io", "read_assembly": "io",
    "type_from_name": "io", "write_assembly": "io",
    "learn": "learn", "mean_shift": "learn", "ANGLE_SCALE_DEG": "learn",
    "example_count_ranges": "learn_stats",
    "DockPlacement": "rules", "Rules": "rules", "rules_from_grammar": "rules",
    "Report": "validate", "Violation": "validate", "validate": "validate",
}


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'grammarkit.tiling' has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))


class _TilingModule(types.ModuleType):
    """Keeps `dock`, `learn` and `validate` bound to the functions.

    Importing a submodule makes Python set it as an attribute of its package, so importing
    `grammarkit.tiling.dock` would replace the function `dock` with the module of that name.
    The eager `from .dock import dock` used to undo that by running afterwards; with lazy
    loading, this refuses the overwrite instead (the module stays in sys.modules)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and _EXPORTS.get(name) == name:
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _TilingModule


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .assembly import Assembly, Part
    from .contacts import (
        DEFAULT_RELATIVE_TOLERANCE, Contact, PartGeometry, contacts, default_tolerance, prepare,
    )
    from .dock import dock
    from .frames import local_frame, relative_placement, surface_centroid, symmetry_offsets
    from .graph import shape_graph
    from .graphops import (
        Cut, adjacency_from_edges, cut_layers, distance_matrix, histogram_key, induced_edges,
        kept_region, match_boundary, random_connected_subgraph, replace_subgraph,
    )
    from .incremental import (
        ForbiddenContact, PartCache, bounds_of, contacts_involving, edit_violations, full_check,
        graph_of, moved_mesh, part_key,
    )
    from .io import ShapeWarning, load_examples, part_prototype, read_assembly, type_from_name, write_assembly
    from .learn import ANGLE_SCALE_DEG, learn, mean_shift
    from .learn_stats import example_count_ranges
    from .orientation import up_vector
    from .rules import DockPlacement, Rules, rules_from_grammar
    from .validate import Report, Violation, validate

__all__ = [
    "Contact", "PartGeometry", "contacts", "prepare", "surface_centroid",
    "ANGLE_SCALE_DEG", "DEFAULT_RELATIVE_TOLERANCE", "Assembly", "DockPlacement", "Part", "Report", "Rules", "ShapeWarning",
    "Violation", "default_tolerance", "dock", "learn", "load_examples", "local_frame", "mean_shift", "part_prototype",
    "example_count_ranges", "read_assembly", "relative_placement", "rules_from_grammar", "shape_graph", "symmetry_offsets", "type_from_name",
    "up_vector", "validate", "write_assembly",
    # shape-graph machinery for back ends (graphops, incremental)
    "Cut", "adjacency_from_edges", "cut_layers", "distance_matrix", "histogram_key", "induced_edges",
    "kept_region", "match_boundary", "random_connected_subgraph", "replace_subgraph",
    "ForbiddenContact", "PartCache", "bounds_of", "contacts_involving", "edit_violations",
    "full_check", "graph_of", "moved_mesh", "part_key",
]
