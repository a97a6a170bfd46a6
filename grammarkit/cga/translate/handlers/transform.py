"""Scope and geometry transforms: s, t, r, center, rotateScope, mirror, setPivot, alignScopeTo*."""
from __future__ import annotations

from typing import Any

from lark import Tree

from ....ir import (
    Arg,
    Binary,
    Bool,
    Num,
    OpCall,
    Ref,
    Str,
    Unary,
)
from ....ir.base import Span
from ... import frames
from ...expressions import Untranslatable, translate_expr
from ..context import (
    HandlerContext,
    axis_name,
    need,
    register,
    rel_or_abs,
)


def _is_rel_one(tree: Any) -> bool:
    return (isinstance(tree, Tree) and tree.data == "rel" and isinstance(tree.children[-1], Tree)
            and tree.children[-1].data == "number" and float(tree.children[-1].children[0].value) == 1)


@register("s")
def _h_s(h: HandlerContext):
    need(h.args, 3, 3, "s", h.span)
    sizes = [rel_or_abs(a, frames.scope_name(h.frame, "scope.s" + c), h.ctx) for a, c in zip(h.args, "xyz")]
    flipped = [_positive(v) for v in sizes]
    if not any(f is not None for f in flipped):
        return _sizes(sizes, h.frame, _is_rel_one(h.args[2]), h.span), None
    # CGA: "negative sizes result in mirroring along the corresponding axes". The geometry
    # then lies on the other side of the scope origin: s(|size|), the geometry mirrored across
    # the scope's mid-plane, and the scope moved back by |size| along that axis; the scope
    # itself stays right-handed (its origin is the low corner, not CGA's)
    pos = [f if f is not None else v for f, v in zip(flipped, sizes)]
    items = _sizes(pos, h.frame, _is_rel_one(h.args[2]), h.span)
    flags = [Bool(value=f is not None) for f in flipped]
    back = [Unary(op="-", operand=f) if f is not None and not isinstance(f, Num) else
            Num(value=-f.value) if f is not None else Num(value=0) for f in flipped]
    if h.frame == "Y":
        flags = [flags[0], flags[2], flags[1]]
        tz = back[2]
        back = [back[0], tz.operand if isinstance(tz, Unary) else Num(value=-tz.value), back[1]]
    items.append(OpCall(name="mirrorGeometry", args=tuple(Arg(value=f) for f in flags), span=h.span))
    items.append(OpCall(name="t", args=tuple(Arg(value=v) for v in back), span=h.span))
    return items, ("s:negative", ("s() with a negative size: the geometry is mirrored into place, "
                                  "the scope keeps its positive size (scope.s and the scope origin "
                                  "differ from CGA's)"))


def _positive(v: Any) -> Any:
    """|v| when the size v is a negative number or a negative multiple of a scope size, else None."""
    if isinstance(v, Num) and v.value < 0:
        return Num(value=-v.value)
    if (isinstance(v, Binary) and v.op == "*" and isinstance(v.left, Num) and v.left.value < 0
            and isinstance(v.right, Ref)):
        return v.model_copy(update={"left": Num(value=-v.left.value)})
    return None


def _sizes(sizes: list, frame: str, keeps_depth: bool, span: Span | None) -> list:
    cx, cy, cz = sizes
    if frame == "Z":
        return [OpCall(name="s", args=(Arg(value=cx), Arg(value=cy), Arg(value=cz)), span=span)]
    # Frame Y: CGA keeps its scope origin, at the back (z = 0 is grammarkit's y = sy); shift
    # grammarkit's origin so the back stays where it is when the depth changes.
    items = []
    if not keeps_depth:
        items.append(OpCall(name="t", args=(Arg(value=Num(value=0)), Arg(value=Binary(
            op="-", left=Ref(name="scope.sy"), right=cz)), Arg(value=Num(value=0))), span=span))
    items.append(OpCall(name="s", args=(Arg(value=cx), Arg(value=cz), Arg(value=cy)), span=span))
    return items


@register("t")
def _h_t(h: HandlerContext):
    need(h.args, 3, 3, "t", h.span)
    return _moved(h.args, h), None


def _moved(args: list, h: HandlerContext) -> list:
    cx, cy, cz = (rel_or_abs(a, frames.scope_name(h.frame, "scope.s" + c), h.ctx)
                  for a, c in zip(args, "xyz"))
    if h.frame == "Y":
        neg = cz.model_copy(update={"value": -cz.value}) if isinstance(cz, Num) else Unary(op="-", operand=cz)
        cy, cz = neg, cy
    return [OpCall(name="t", args=(Arg(value=cx), Arg(value=cy), Arg(value=cz)), span=h.span)]


@register("translate")
def _h_translate(h: HandlerContext):
    """CGA's translate(mode, coordSystem, x, y, z): `rel, scope` is t(x, y, z); moving to an
    absolute position or along the world's or the object's axes is reported."""
    need(h.args, 5, 5, "translate", h.span)
    mode, system = axis_name(h.args[0]), axis_name(h.args[1])
    if (mode, system) == ("rel", "world") and h.frame == "Y" and all(
            isinstance(e, Num) and e.value == 0 for e in (translate_expr(h.args[i], h.ctx) for i in (2, 4))):
        # straight up in the world (`translate(rel, world, 0, curbHeight, 0)` on a lot): a
        # lot-like scope's up axis is the world's, unless a turn of the scope tilted it
        up = translate_expr(h.args[3], h.ctx)
        return [OpCall(name="t", args=(Arg(value=Num(value=0)), Arg(value=Num(value=0)), Arg(value=up)),
                       span=h.span)], ("translate:rel.world", "moved along the scope's up axis, which is "
                                       "the world's on a lot and its volumes (not after a turn that tilts it)")
    if (mode, system) != ("rel", "scope"):
        raise Untranslatable(f"translate:{mode}.{system}", f"translate({mode}, {system}, ...): only "
                             "rel, scope (which is t()) and rel, world straight up on a lot are translated", h.span)
    return _moved(h.args[2:], h), None


@register("cleanupGeometry")
def _h_cleanup_geometry(h: HandlerContext):
    """CGA's cleanupGeometry(components, tolerance) merges vertices, edges and coplanar faces
    closer than the tolerance: the shape stays where it is, only its mesh is tidied."""
    need(h.args, 2, 2, "cleanupGeometry", h.span)
    return [], ("cleanupGeometry:mesh", ("nothing is done (the shape is the same; grammarkit "
                                         "welds and unites the mesh when the model is finished)"))


@register("r")
def _h_r(h: HandlerContext):
    args = h.args
    pivot = axis_name(args[0]) if len(args) == 4 else "scopeOrigin"
    if len(args) == 4:
        args = args[1:]
    need(args, 3, 3, "r", h.span)
    steps = _turns("r", [translate_expr(a, h.ctx) for a in args], h.frame, h.span)
    if pivot == "scopeOrigin":
        return steps, None
    if pivot == "scopeCenter":
        back = _back_to_center(steps, h.span)
        if back is not None:
            return steps + [back], None
        why = "with angles known only at derive time"
    else:
        why = f"about {pivot or 'a pivot'}"
    return steps, ("r:pivot", f"rotation {why} is made about the scope origin")


def _back_to_center(steps: list, span: Span | None) -> OpCall | None:
    """CGA's r(scopeCenter, ...) turns the shape about its scope's centre P. grammarkit's r
    turns about the origin (new axis j = sum_i R[i][j] old axis i, the geometry kept in scope
    coordinates), which moves the centre from P to R P (old axes); t(d) with d = R^T P - P
    (new axes) moves it back. P = scope size / 2, so d is linear in scope.sx, .sy, .sz with
    coefficients (R[j][i] - [i == j]) / 2. None when an angle is not a number."""
    from ....split.ops.helpers import rotation

    R = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    for op in steps:
        angles = [a.value for a in op.args]
        if not all(isinstance(v, Num) for v in angles):
            return None
        S = rotation(*(float(v.value) for v in angles))
        R = tuple(tuple(sum(R[i][k] * S[k][j] for k in range(3)) for j in range(3)) for i in range(3))
    parts = []
    for i in range(3):
        expr = None
        for j, c in enumerate("xyz"):
            coeff = round((R[j][i] - (1.0 if i == j else 0.0)) / 2.0, 12)
            if abs(coeff) < 1e-12:
                continue
            term = Binary(op="*", left=Num(value=coeff), right=Ref(name=f"scope.s{c}"))
            expr = term if expr is None else Binary(op="+", left=expr, right=term)
        parts.append(expr if expr is not None else Num(value=0))
    return OpCall(name="t", args=tuple(Arg(value=v) for v in parts), span=span)


def _turns(op: str, angles: list, frame: str, span: Span | None) -> list:
    """CGA's `op(x, y, z)` turn (r or rotateScope) as grammarkit operations. In frame Z the
    axes are the same; in frame Y CGA rotates about x, then its y (grammarkit z), then its z
    (grammarkit -y): one operation per non-zero angle, in that order."""
    rx, ry, rz = angles
    if frame == "Z":
        return [OpCall(name=op, args=(Arg(value=rx), Arg(value=ry), Arg(value=rz)), span=span)]
    zero = Num(value=0)
    steps = []
    for gk_axis, value in (("x", rx), ("z", ry), ("y", rz)):
        if isinstance(value, Num) and value.value == 0:
            continue
        if gk_axis == "y":
            value = Num(value=-value.value) if isinstance(value, Num) else Unary(op="-", operand=value)
        vec = [zero, zero, zero]
        vec["xyz".index(gk_axis)] = value
        steps.append(OpCall(name=op, args=tuple(Arg(value=v) for v in vec), span=span))
    return steps


@register("center")
def _h_center(h: HandlerContext):
    need(h.args, 1, 1, "center", h.span)
    axes = axis_name(h.args[0])
    mapped = frames.center_axes(h.frame, axes) if axes else None
    if mapped is None:
        raise Untranslatable("center:axes", f"center({axes})", h.span)
    return [OpCall(name="center", args=(Arg(value=Ref(name=mapped)),), span=h.span)], None



_FACE_SELECTORS = {"world.lowest": "lowest", "largest": "largest", "any": "any"}


@register("alignScopeToGeometry")
def _h_align_scope_to_geometry(h: HandlerContext):
    """alignScopeToGeometry(upAxis, faceIndex | world.lowest | largest | any, edgeIndex |
    longest | world.lowest): z along the face's normal and x along the edge (grammarkit's
    alignScopeToGeometry(edge, face)); the up axis says which CGA frame the shape is in
    afterwards (yUp: the normal is CGA's y, frame Y; zUp: its z, frame Z)."""
    need(h.args, 2, 3, "alignScopeToGeometry", h.span)
    up = axis_name(h.args[0])
    if up not in ("yUp", "zUp"):
        raise Untranslatable("alignScopeToGeometry:up", f"up axis {up!r}", h.span)
    # the rest of the rule is in the up axis's convention even where the alignment itself is
    # not translated (a located warning): the frame must follow CGA, or later splits go astray
    h.t.frame_change = "Y" if up == "yUp" else "Z"
    face_name = axis_name(h.args[1])
    face: Any
    if face_name in _FACE_SELECTORS:
        face = Str(value=_FACE_SELECTORS[face_name])
    elif face_name == "auto" or (face_name is not None and "." in face_name):
        raise Untranslatable("alignScopeToGeometry:face", f"face selector {face_name!r}", h.span)
    else:
        face = translate_expr(h.args[1], h.ctx)
    edge: Any = Num(value=0)
    if len(h.args) == 3:
        if axis_name(h.args[2]) == "longest":
            edge = Str(value="longest")
        elif axis_name(h.args[2]) == "world.lowest":
            edge = Str(value="lowest")
        elif axis_name(h.args[2]) is not None and "." in (axis_name(h.args[2]) or ""):
            raise Untranslatable("alignScopeToGeometry:orientation", f"edge orientation "
                                 f"{axis_name(h.args[2])!r}", h.span)
        else:
            edge = translate_expr(h.args[2], h.ctx)
    if isinstance(face, Str) and face.value == "any" and not isinstance(edge, Str):
        raise Untranslatable("alignScopeToGeometry:face", "face selector any with an edge index", h.span)
    call_args = (Arg(value=edge),) if isinstance(face, Num) and face.value == 0 else (Arg(value=edge), Arg(value=face))
    return [OpCall(name="alignScopeToGeometry", args=call_args, span=h.span)], None


_MAKES_VOLUME = {"extrude", "i", "taper", "roofGable", "roofHip", "roofPyramid", "roofShed", "roofMansard"}

# CGA alignScopeToAxes(axis) -> (grammarkit axis, the CGA frames it is exact in). Afterwards
# the CGA scope is y-up with its z towards the world's +z (south), which is frame Y: CGA's
# world.y (up) is grammarkit's z with x projected in both systems; world.z (south) is
# grammarkit's -y, x projected; world.x is x with CGA's z projected, which is grammarkit's -y
# only in frame Y.
_ALIGN_AXES = {None: ("xyz", "YZ"), "world.xyz": ("xyz", "YZ"), "xyz": ("xyz", "YZ"),
               "y": ("z", "YZ"), "world.y": ("z", "YZ"), "z": ("y", "YZ"), "world.z": ("y", "YZ"),
               "x": ("x", "Y"), "world.x": ("x", "Y")}


@register("alignScopeToAxes")
def _h_align_scope_to_axes(h: HandlerContext):
    need(h.args, 0, 1, "alignScopeToAxes", h.span)
    name = axis_name(h.args[0]) if h.args else None
    if h.args and name is None:
        raise Untranslatable("alignScopeToAxes:axis", "alignScopeToAxes() of a computed axis", h.span)
    mapped = _ALIGN_AXES.get(name)
    if h.frame == "Z" and not (h.out and isinstance(h.out[-1], OpCall) and h.out[-1].name in _MAKES_VOLUME):
        # a face of frame Z may be a facade (vertical: CGA's y up keeps it in its plane, which
        # grammarkit's z up does not) or a top (horizontal: the other way round); the importer
        # cannot tell them apart, so only a shape just made a volume (a balcony extruded from
        # a facade) is translated
        raise Untranslatable("alignScopeToAxes:face", "alignScopeToAxes() on a face of a volume "
                             "(a vertical face would leave its scope plane in grammarkit's y-up frame); "
                             "on a volume made in the same rule it is translated", h.span)
    if mapped is None or h.frame not in mapped[1]:
        raise Untranslatable("alignScopeToAxes:axis", f"alignScopeToAxes({name})"
                             + (" on a face's frame (CGA's z projected is not grammarkit's)" if mapped else ""),
                             h.span)
    h.t.frame_change = "Y"
    call_args = () if mapped[0] == "xyz" else (Arg(value=Str(value=mapped[0])),)
    return [OpCall(name="alignScopeToAxes", args=call_args, span=h.span)], None


@register("rotateScope")
def _h_rotate_scope(h: HandlerContext):
    """rotateScope(x, y, z): the scope turned about its axes, x first (as r()); in frame Y,
    CGA's y is grammarkit's z and its z grammarkit's -y (the steps of _h_r)."""
    need(h.args, 3, 3, "rotateScope", h.span)
    return _turns("rotateScope", [translate_expr(a, h.ctx) for a in h.args], h.frame, h.span), None


def _flag_args(args: list, frame: str, ctx: Any) -> list:
    """mirror flags (x, y, z) in CGA's axes -> grammarkit's axes (frame Y: y and z swap)."""
    flags = [translate_expr(a, ctx) for a in args]
    return flags if frame == "Z" else [flags[0], flags[2], flags[1]]


@register("mirrorScope")
def _h_mirror_scope(h: HandlerContext):
    need(h.args, 3, 3, "mirrorScope", h.span)
    flags = _flag_args(h.args, h.frame, h.ctx)
    if all(isinstance(f, Bool) for f in flags) and sum(f.value for f in flags) % 2:
        raise Untranslatable("mirrorScope:handedness", "reversing one or three scope axes makes a "
                             "left-handed scope, which grammarkit's shapes cannot carry", h.span)
    return [OpCall(name="mirrorScope", args=tuple(Arg(value=f) for f in flags), span=h.span)], None


@register("mirror")
def _h_mirror(h: HandlerContext):
    need(h.args, 3, 3, "mirror", h.span)
    flags = _flag_args(h.args, h.frame, h.ctx)
    return [OpCall(name="mirrorGeometry", args=tuple(Arg(value=f) for f in flags), span=h.span)], None


@register("setPivot")
def _h_set_pivot(h: HandlerContext):
    """setPivot(axes, corner): CGA's pivot is the frame that r() and rotateScope() turn about
    and that scope.r / convert(pivot) read. grammarkit turns about the scope's own axes and has
    no pivot, and CGA's r() turns about the scope origin whatever the pivot's corner: so
    setPivot(xyz, n) (the pivot's axes along the scope's) changes nothing; other orientations
    would change the axes of later rotations, which is approximated."""
    need(h.args, 2, 2, "setPivot", h.span)
    orientation = axis_name(h.args[0])
    if orientation == "xyz":
        return [], None
    return [], ("setPivot:orientation", f"setPivot({orientation}, ...): later rotations turn about "
                "the scope's axes, not the pivot's")



_ROTATE_SYSTEMS = ("scope", "pivot", "object", "world")


@register("rotate")
def _h_rotate(h: HandlerContext):
    """CGA's rotate(mode, coordSystem, x, y, z) -> the engine's rotate(mode, system, x, y, z)
    (INTERFACES.md item 2). Angles are about CGA's axes: in frame Z and for a face's scope they
    are grammarkit's; CGA's world and a lot-like scope (frame Y) are y-up, so about CGA's y is
    about grammarkit's z and about CGA's z about grammarkit's -y: one call per non-zero angle in
    CGA's order (x, y, z), as for r()."""
    need(h.args, 5, 5, "rotate", h.span)
    mode, system = axis_name(h.args[0]), axis_name(h.args[1])
    if mode not in ("abs", "rel"):
        raise Untranslatable("rotate:mode", f"rotate mode {mode!r}", h.span)
    if system not in _ROTATE_SYSTEMS:
        raise Untranslatable("rotate:system", f"rotate coordinate system {system!r}", h.span)
    if "rotate" not in h.t.operations:
        raise Untranslatable("op:rotate", "the engine has no rotate(mode, system, x, y, z) operation "
                             "(INTERFACES.md item 2)", h.span)
    angles = [translate_expr(a, h.ctx) for a in h.args[2:]]
    head = (Arg(value=Ref(name=mode)), Arg(value=Ref(name=system)))  # identifiers, as the engine's spec
    y_up = system == "world" or h.frame == "Y"
    if not y_up:
        return [OpCall(name="rotate", args=head + tuple(Arg(value=a) for a in angles), span=h.span)], None
    steps = [OpCall(name="rotate", args=head + s.args, span=h.span)
             for s in _turns("r", angles, "Y", h.span)]
    if not steps:
        steps = [OpCall(name="rotate", args=head + tuple(Arg(value=Num(value=0)) for _ in range(3)),
                        span=h.span)]
    if mode == "abs" and len(steps) > 1:
        # absolute angles about several axes: set the first, then turn on by the others
        rel = (Arg(value=Ref(name="rel")), Arg(value=Ref(name=system)))
        steps = steps[:1] + [s.model_copy(update={"args": rel + s.args[2:]}) for s in steps[1:]]
    return steps, None
