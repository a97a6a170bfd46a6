"""The built-in split operations: one module per family, each operation's spec (its
`@operation(...)` registration, ShapeML's REGISTER_SHAPE_OP) written above its body.

The contract is the plugins' one (grammarkit.hookspecs: OperationContext, ShapeView,
BlockSlot), and these functions use nothing else: `apply(ctx, shape, args, block)` where
`ctx` is the derivation's OperationContext, `args` the evaluated arguments in the spec's
parameter order (defaults filled in; variadic extras appended), and `block` the compiled block
slots or None. A non-block operation returns the (new or modified) shape to continue with, or
None to delete it. A block operation returns a list of `(child_shape, slot)`; each child then
runs its slot's body (the engine numbers them: `split.index`, `split.total`). Raise
ValueError for bad arguments: the engine turns it into a DerivationError naming the rule and
the call's source position.

Layers inside the package: `helpers` and `layout` at the bottom (they import no operation),
`faces` (comp(f)'s decomposition, shared by comp, comp_edges and the scope operations), then
the operation modules. Importing the package stays light (no numpy, no manifold3d): the
geometry libraries are imported on first use (helpers.lazy_module).
"""
from __future__ import annotations

from typing import Any, Callable

from ...registry import OperationSpec
from .area_split import op_split_area
from .comp import op_comp
from .convexify import op_convexify
from .create import op_extrude, op_footprint, op_recess, op_taper
from .envelope import op_envelope, op_envelope_per_edge
from .insert import op_insert
from .label import op_label
from .lots import op_inner_rectangle, op_setback, op_setback_per_edge, op_setback_to_area, op_shape_l, op_shape_o, op_shape_u
from .roofs import op_roof_gable, op_roof_hip, op_roof_mansard, op_roof_pyramid, op_roof_shed
from .scatter import op_scatter
from .scope_ops import op_align_scope_to_axes, op_align_scope_to_geometry, op_mirror, op_mirror_scope, op_reverse_normals, op_rotate_scope
from .splitting import op_offset, op_repeat, op_split
from .tags import op_color, op_material, op_print, op_report, op_set, op_trim
from .texturing import op_delete_uv, op_normalize_uv, op_project_uv, op_rotate_uv, op_scale_uv, op_setup_projection, op_texture, op_tile_uv, op_translate_uv
from .transforms import op_center, op_r, op_rotate, op_s, op_t
from .insert import fitted_size  # noqa: F401 - public (grammarkit.split.ops.fitted_size)
from .layout import layout  # noqa: F401 - public (tests, docs/operations.md)

# the table, in the order `grammarkit check` and the docs list the operations
BUILTIN_OPERATIONS: tuple[Callable[..., Any], ...] = (
    op_footprint,
    op_extrude,
    op_taper,
    op_comp,
    op_split,
    op_repeat,
    op_offset,
    op_roof_gable,
    op_roof_hip,
    op_roof_pyramid,
    op_roof_shed,
    op_roof_mansard,
    op_recess,
    op_t,
    op_r,
    op_rotate,
    op_s,
    op_center,
    op_insert,
    op_color,
    op_material,
    op_align_scope_to_geometry,
    op_align_scope_to_axes,
    op_reverse_normals,
    op_rotate_scope,
    op_mirror_scope,
    op_mirror,
    op_trim,
    op_report,
    op_print,
    op_set,
    op_setback,
    op_setback_per_edge,
    op_setback_to_area,
    op_shape_l,
    op_shape_u,
    op_shape_o,
    op_inner_rectangle,
    op_split_area,
    op_envelope,
    op_envelope_per_edge,
    op_scatter,
    op_convexify,
    op_label,
    op_setup_projection,
    op_project_uv,
    op_texture,
    op_translate_uv,
    op_scale_uv,
    op_rotate_uv,
    op_delete_uv,
    op_tile_uv,
    op_normalize_uv,
)
SPECS: tuple[OperationSpec, ...] = tuple(fn.spec for fn in BUILTIN_OPERATIONS)  # type: ignore[attr-defined]
BUILTIN_APPLY: dict[str, Callable[..., Any]] = {fn.spec.name: fn for fn in BUILTIN_OPERATIONS}  # type: ignore[attr-defined]
