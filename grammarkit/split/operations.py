"""The built-in split operations, registered through the `grammarkit_operations` hook.

Specs (names, parameters, block kinds) are the language contract that `grammarkit check`
validates against. Each spec's `apply` is bound to its implementation in
`grammarkit.split.ops`, imported on first use so that `grammarkit check` stays light.
"""
from __future__ import annotations

from dataclasses import replace
from importlib import import_module
from typing import Any, Iterable

from ..hookspecs import hookimpl
from ..registry import FitSpec, OperationSpec, Param

AXES = ("x", "y", "z")
FACE_SELECTORS = ("top", "bottom", "side", "front", "back", "left", "right", "all")
# comp's selectors (grammarkit/split/comp.py); "<index>" stands for the integer selectors 0, 1, ...
# setupProjection's axes (the same list as grammarkit.split.texturing.AXES; kept here so that
# `grammarkit check` does not import the engine)
PROJECTION_AXES = tuple(f"{o}.{a}" for o in ("scope", "world") for a in ("xy", "xz", "yx", "yz", "zx", "zy"))
# setback's edge selectors (grammarkit/split/lots.py)
SETBACK_SELECTORS = ("front", "back", "left", "right", "top", "bottom", "side", "south", "north", "west", "east",
                     "all", "remainder", "<index>")
COMP_SELECTORS = FACE_SELECTORS + ("vertical", "horizontal", "aslant", "nutant", "volume", "<index>",
                                   # comp(e) / comp(v) (grammarkit/split/comp_edges.py)
                                   "border", "inside", "eave", "ridge", "hip", "valley")

class LazyApply:
    """`apply` of a built-in operation: imports grammarkit.split.ops when first called.

    The split compiler unwraps it (`.target()`) so the hot loop calls the function directly.
    """

    def __init__(self, op: str):
        self.op = op
        self._fn = None

    def target(self):  # noqa: ANN201
        if self._fn is None:
            self._fn = import_module("grammarkit.split.ops").BUILTIN_APPLY[self.op]
        return self._fn

    def __call__(self, ctx: Any, shape: Any, args: Any, block: Any) -> Any:
        return self.target()(ctx, shape, args, block)


_SPECS: tuple[OperationSpec, ...] = (
    OperationSpec("footprint", (Param("shape", "any", doc="rect(w, d), lshape(...), polygon(...)"),),
                  doc="Replace the scope's geometry by a planar footprint polygon (xy plane)."),
    OperationSpec("extrude", (Param("height"),), doc="Extrude a face along its normal into a volume."),
    OperationSpec("taper", (Param("height"), Param("top_scale", required=False, default=0.0)),
                  doc="Extrude a face, scaling the top about the centroid (0: to a point)."),
    OperationSpec("comp", (Param("mode", "axis", choices=("f", "e", "fe", "v")),), block="selectors",
                  selectors=COMP_SELECTORS,
                  doc="Decompose a shape into its faces (f), edges (e), face edges (fe) or vertices (v) (the shape is "
                      "consumed unless `volume:` keeps it); selectors by orientation, `all`, an index, "
                      "`volume`; for edges also `border`, `inside`, `eave`, `ridge`, `hip`, `valley`."),
    OperationSpec("split", (Param("axis", "axis", choices=AXES),), block="sizes",
                  doc="Split the scope along an axis into absolute, relative and floating parts."),
    OperationSpec("repeat", (Param("axis", "axis", choices=AXES), Param("size"),
                             Param("separator", required=False, default=0.0)),
                  doc="Repetition sugar: `repeat(x, 2) (A)*` or `repeat(x, 2, 0.3) (A B)* A`."),
    OperationSpec("offset", (Param("distance"),), block="optional-selectors",
                  selectors=("inside", "border"), doc="Inset (negative) a face; inside/border parts."),
    OperationSpec("roofGable", (Param("angle", doc="the roof planes' angle (degrees), or their height with value_type=byHeight"),
                                Param("overhang", required=False, default=0.0,
                                      doc="at the eaves, across the ridge (CGA's overhangX)"),
                                Param("ridge", "axis", required=False, default="x", choices=("x", "y", "auto"),
                                      doc="the scope axis the ridge runs along, or auto: along the longest "
                                          "edge (CGA's automatic orientation on rectangles)"),
                                Param("overhang_y", required=False, default=None,
                                      doc="at the gable ends, along the ridge (CGA's overhangY; may be "
                                          "negative); not given: the overhang all round"),
                                Param("index", required=False, default=None,
                                      doc="the ridge runs along this edge of the face (CGA's index)"),
                                Param("value_type", "axis", required=False, default="byAngle",
                                      choices=("byAngle", "byHeight")),
                                Param("even", "any", required=False, default=False,
                                      doc="CGA's even: planes from every eave edge, the ridge level "
                                          "(non-planar faces where the eaves are not parallel)")),
                  doc="Gable roof over a footprint face; ridge along the given scope axis or edge index."),
    OperationSpec("roofHip", (Param("angle", doc="degrees, or the height with value_type=byHeight"),
                              Param("overhang", required=False, default=0.0),
                              Param("value_type", "axis", required=False, default="byAngle",
                                    choices=("byAngle", "byHeight")),
                              Param("even", "any", required=False, default=False,
                                    doc="CGA's even: the ridge level at the skeleton nodes' average "
                                        "height (non-planar faces)")),
                  doc="Hip roof: every edge slopes at the angle (or up to the height)."),
    OperationSpec("roofPyramid", (Param("angle"), Param("overhang", required=False, default=0.0)),
                  doc="Pyramid roof with its apex over the face centroid."),
    OperationSpec("roofShed", (Param("angle", doc="degrees, or the height with value_type=byHeight"),
                               Param("overhang", required=False, default=0.0),
                               Param("ridge", "axis", required=False, default="x", choices=("x", "y")),
                               Param("index", required=False, default=None,
                                     doc="the roof rises from this edge of the face (CGA's index)"),
                               Param("value_type", "axis", required=False, default="byAngle",
                                     choices=("byAngle", "byHeight"))),
                  doc="Shed (mono-pitch) roof rising towards +ridge-normal, or from edge `index`."),
    OperationSpec("roofMansard", (Param("angle"), Param("height"),
                                  Param("top_angle", required=False, default=15.0),
                                  Param("overhang", required=False, default=0.0)),
                  doc="Mansard roof: steep hip sides up to `height`, then a shallow hip on top."),
    OperationSpec("recess", (Param("depth"),),
                  doc="Cut the face `depth` into the solid below it (windows, doors); the face "
                      "moves to the bottom of the recess."),
    OperationSpec("t", (Param("x"), Param("y"), Param("z")), doc="Translate the scope (scope axes)."),
    OperationSpec("r", (Param("x"), Param("y"), Param("z")), doc="Rotate the scope (degrees, XYZ)."),
    OperationSpec("s", (Param("x"), Param("y"), Param("z")), doc="Set the scope size."),
    OperationSpec("center", (Param("axes", "axis", required=False, default="xyz",
                                  choices=("x", "y", "z", "xy", "xz", "yz", "xyz")),),
                  doc="Center the scope in its parent's scope along the given axes."),
    OperationSpec("i", (Param("path", "string"),
                        Param("fit", "name", required=False, default="scale", names="fits",
                              doc="how the asset is fitted to the scope (a fit from the registry)")),
                  doc="Insert a mesh file fitted to the scope (`fit=scale`: scaled to it)."),
    OperationSpec("color", (Param("value", "color"),), doc="Tag the shape with a colour (#rrggbb)."),
    OperationSpec("material", (Param("name", "string"),), doc="Tag the shape with a material name."),
    OperationSpec("alignScopeToGeometry", (Param("edge", "any", required=False, default=0),
                                           Param("face", "any", required=False, default=0)),
                  doc="Turn the scope so z is the normal of a face of the geometry (face: an index, "
                      "\"largest\", \"lowest\", \"any\"; a face shape: itself) and x runs along "
                      "an edge of it (an index, \"longest\", \"lowest\"); the geometry stays."),
    OperationSpec("alignScopeToAxes", (Param("axis", "any", required=False, default="xyz"),),
                  doc="Turn the scope so its axes (\"xyz\", the default) or one of them (\"x\", "
                      "\"y\", \"z\") are parallel to the world's; the geometry stays."),
    OperationSpec("reverseNormals", (),
                  doc="Turn a face (or an open mesh) to look the other way; a closed volume keeps its outside."),
    OperationSpec("rotateScope", (Param("x"), Param("y"), Param("z")),
                  doc="Turn the scope (not the geometry) by x, y, z degrees about its own axes, x "
                      "first; the scope becomes the geometry's bounding box in the turned axes."),
    OperationSpec("mirrorScope", (Param("x", "any"), Param("y", "any"), Param("z", "any")),
                  doc="Reverse the flagged scope axes (two of them: scopes stay right-handed), the "
                      "origin moved to the other side; the geometry stays."),
    OperationSpec("mirrorGeometry", (Param("x", "any"), Param("y", "any"), Param("z", "any")),
                  doc="Reflect the geometry across the scope's mid-planes along the flagged axes "
                      "(CGA's mirror); the scope stays (a solid stays watertight)."),
    OperationSpec("trim", (Param("enabled", "any"),),
                  doc="Whether i() clips inserts by the trim planes of comp(f) side faces (CGA's trim.vertical)."),
    OperationSpec("report", (Param("key", "string"), Param("value", "any")),
                  doc="Collect a value under a report key (Model.reports; the model's metadata)."),
    OperationSpec("print", (Param("value", "any"),),
                  doc="A message of the derivation (CGA's print): `Rule: value` on Model.messages, "
                      "printed by `grammarkit derive`; the shape is unchanged."),
    OperationSpec("set", (Param("attr", "name"), Param("value", "any")),
                  doc="Change an attr for this shape and everything derived from it (CGA's set); "
                      "`set(material.opacity, 0.5)` and the other CGA material attributes too."),
    # lots and massing (grammarkit/split/lots.py; docs/operations.md "Setbacks")
    OperationSpec("setback", (Param("distance"),), block="selectors", selectors=SETBACK_SELECTORS,
                  doc="Move the selected edges of a face inwards: a face per edge, and the remainder."),
    OperationSpec("setbackPerEdge", (Param("distance", "expr"),), block="selectors", selectors=SETBACK_SELECTORS,
                  doc="setback() with the distance evaluated on every edge (comp.index: the edge's index, "
                      "comp.sel: its side), or an array of one distance per edge."),
    OperationSpec("setbackToArea", (Param("area"),), block="selectors", selectors=SETBACK_SELECTORS,
                  doc="setback() with the distance that leaves a remainder of the given area."),
    OperationSpec("shapeL", (Param("front_width"), Param("left_width")), block="selectors",
                  selectors=("shape", "remainder"), doc="An L-shaped footprint: front and left wings."),
    OperationSpec("shapeU", (Param("front_width"), Param("right_width"), Param("left_width")), block="selectors",
                  selectors=("shape", "remainder"), doc="A U-shaped footprint: front, right and left wings."),
    OperationSpec("shapeO", (Param("front_width"), Param("right_width"), Param("back_width"), Param("left_width")),
                  block="selectors", selectors=("shape", "remainder"),
                  doc="An O-shaped footprint: wings along all four sides around a court."),
    OperationSpec("innerRectangle", (Param("align", "axis", required=False, default="scope",
                                           choices=("scope", "edge")),),
                  block="selectors", selectors=("shape", "remainder"),
                  doc="The largest rectangle in a face (aligned to the scope or to an edge), and the rest."),
    # CGA's splitArea and envelope (grammarkit/split/area_split.py, envelope.py)
    OperationSpec("splitArea", (Param("axis", "axis", choices=("x", "y")),
                                Param("adjust_mode", "axis", required=False, default="adjust",
                                      choices=("adjust", "noAdjust"),
                                      doc="adjust: each part's scope fits its geometry; noAdjust: the "
                                          "parts' scopes tile the parent's")),
                  block="sizes",
                  doc="Split a face along an axis into parts of the given areas (absolute, 'relative, "
                      "~floating, repeat groups: split's sizes, in area units)."),
    OperationSpec("envelope", (Param("direction", "axis", choices=("normal", "worldUp")), Param("max_height"),
                               Param("front_base"), Param("front_angle"),
                               Param("back_base", required=False, default=0.0),
                               Param("back_angle", required=False, default=90.0),
                               Param("right_base", required=False, default=0.0),
                               Param("right_angle", required=False, default=90.0),
                               Param("left_base", required=False, default=0.0),
                               Param("left_angle", required=False, default=90.0)),
                  doc="The zoning envelope of a face: extruded to max_height, each side vertical up to "
                      "its base height, then leaning inwards at its angle (degrees; 90: vertical)."),
    OperationSpec("envelopePerEdge", (Param("direction", "axis", choices=("normal", "worldUp")), Param("max_height"),
                                      Param("base_height", "expr",
                                            doc="evaluated on every edge (comp.index, comp.sel, scope.sx), "
                                                "or an array of one value per edge"),
                                      Param("angle", "expr", doc="likewise, degrees (90: vertical)")),
                  doc="envelope() with the base height and angle given per edge (CGA's "
                      "envelope(direction, maxHeight, baseHeights, angles))."),
    # scatter (grammarkit/split/scatter.py; docs/operations.md "Scatter"); the choices are the
    # same lists as grammarkit.split.scatter's (kept here so that `grammarkit check` stays light)
    OperationSpec("scatter", (Param("domain", "axis", choices=("surface", "volume", "scope")), Param("count"),
                              Param("distribution", "axis", choices=("uniform", "gaussian")),
                              Param("mean", "axis", required=False, default="center",
                                    choices=("center", "front", "back", "left", "right", "top", "bottom")),
                              Param("stddev", required=False, default=0.16,
                                    doc="times the scope's size on each axis (CGA's '0.16)")),
                  block="selectors", selectors=("all",),
                  doc="Random point shapes (zero-size scopes) on the surface, in the volume or in the "
                      "scope of the shape, uniform or gaussian; `{ all: Rule }` derives each point."),
    OperationSpec("convexify", (Param("max_length", required=False, default=0.0,
                                      doc="keep only split lines shorter than this (0: all)"),),
                  doc="Split a face's geometry into convex faces (Hertel-Mehlhorn); comp(f) hands "
                      "them out one by one."),
    OperationSpec("label", (Param("name", "string"),),
                  doc="Make the shape (as it is now) an occluder with this label for inside(), "
                      "overlaps() and touches() of shapes derived later."),
    # texturing (grammarkit/split/texturing.py; docs/cga.md "Texturing")
    OperationSpec("setupProjection", (Param("uvset"), Param("axes", "axis", choices=PROJECTION_AXES),
                                      Param("width"), Param("height"),
                                      Param("width_offset", required=False, default=0.0),
                                      Param("height_offset", required=False, default=0.0)),
                  doc="A planar texture projection for a uv set: origin and u/v axes of the scope or "
                      "the world, a texture tile of width x height world units."),
    OperationSpec("projectUV", (Param("uvset"),),
                  doc="Bake the uv set's projection into the shape's texture coordinates."),
    OperationSpec("texture", (Param("path", "string"),),
                  doc="The colour texture (CGA's material.colormap) of the shape; makes no UVs."),
    OperationSpec("translateUV", (Param("uvset"), Param("u"), Param("v")),
                  doc="Shift the texture coordinates of a uv set (texture units)."),
    OperationSpec("scaleUV", (Param("uvset"), Param("u"), Param("v")),
                  doc="Scale the texture coordinates of a uv set."),
    OperationSpec("rotateUV", (Param("uvset"), Param("angle")),
                  doc="Turn the texture coordinates of a uv set about the uv origin (degrees)."),
    OperationSpec("deleteUV", (Param("uvset"),), doc="Remove the texture coordinates of a uv set."),
    OperationSpec("tileUV", (Param("uvset"), Param("width"), Param("height")),
                  doc="Rescale the texture coordinates so a texture tile spans width x height world "
                      "units (negative: mirrored; 0: the axis is left as it is)."),
    OperationSpec("normalizeUV", (Param("uvset"), Param("axes", "axis", choices=("uv", "u", "v")),
                                  Param("mode", "axis", choices=("separatePerFace", "collectiveAllFaces"))),
                  doc="Shift and scale the texture coordinates to span [0, 1] over the shape."),
)


SPECS: tuple[OperationSpec, ...] = tuple(replace(spec, apply=LazyApply(spec.name)) for spec in _SPECS)


@hookimpl
def grammarkit_operations() -> Iterable[OperationSpec]:
    return SPECS


def fit_scale(mesh: Any, size: tuple[float, float, float]) -> Any:
    """The built-in fit: the asset scaled (per axis) so its bounding box is `size`."""
    import numpy as np

    ext = mesh.extents
    scale = [s / e if e > 1e-12 else 1.0 for s, e in zip(size, ext)]
    out = mesh.copy()
    out.apply_transform(np.diag([*scale, 1.0]))
    return out


FITS: tuple[FitSpec, ...] = (
    FitSpec("scale", "scale the asset to the scope (a zero scope size keeps its proportion)", fit_scale),
)


@hookimpl
def grammarkit_insert_fits() -> Iterable[FitSpec]:
    return FITS


@hookimpl
def grammarkit_functions() -> Iterable[Any]:
    """CGA's string and list functions (grammarkit/split/strings.py; pure Python, light)."""
    from ..registry import FunctionSpec
    from .strings import STRING_FUNCTIONS

    # CGA's occlusion queries: the split compiler binds them to the shape they are evaluated on
    # (grammarkit/split/occlusion.py), so they have no value-only implementation here
    occlusion = tuple(FunctionSpec(name, 0, 2, f"CGA's {name}(target = \"intra\", label): a query against the "
                                   "model derived so far (split grammars)") for name in ("inside", "overlaps", "touches"))
    return (*STRING_FUNCTIONS, *occlusion)
