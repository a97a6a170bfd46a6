"""A derived model as the exporters' Scene (grammarkit.geometry.exporters): the solid and the
surface layer, triangles grouped by terminal name, a material per (material name, colour, CGA
material attributes), and per group the rules, source lines and semantic tags."""
from __future__ import annotations

import os
from dataclasses import replace
from typing import Any

import numpy as np

DEFAULT_COLOR = "#b8b4ac"
CUT_COLOR = "#3a4450"
# the group name of triangles no terminal claims (none in practice; kept so that every face has a label)
UNTAGGED = "untagged"


def rgba_of(hex_color: str | None, default: str) -> tuple[int, int, int, int]:
    h = (hex_color or default).lstrip("#")
    return (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16), 255)


def _material(name: str | None, rgba: tuple, cga: tuple) -> Any:
    """The exporters' Material for a terminal's name, colour and CGA material attributes
    (`set(material.*)`, `texture()`: grammarkit.split.ops.texturing)."""
    from ..geometry.exporters import Material

    if not cga:
        return Material(name, rgba)
    d = dict(cga)
    if "opacity" in d:
        rgba = (*rgba[:3], int(round(d.pop("opacity") * 255)))
    texture = d.pop("colormap", None)
    metallic, roughness = d.pop("metallic", None), d.pop("roughness", None)
    double_sided = bool(d.pop("doubleSided", False))
    return Material(name, rgba, double_sided=double_sided, texture=texture, metallic=metallic,
                    roughness=roughness, extras=tuple(sorted(d.items())))


def _tag_kinds(raw: list, nodes: list) -> tuple[dict[tuple, int], np.ndarray]:
    """The distinct tags (tags repeat: every window of a facade has its own) and the distinct
    tag of each tag; the last entry stands for triangles no terminal claims."""
    kind_of: dict[tuple, int] = {}
    tag_kind = np.empty(len(raw) + 1, dtype=np.int64)
    for i, t in enumerate(raw):
        span = nodes[t[5]][7] if 0 <= t[5] < len(nodes) else None
        key = (t[0], t[1], t[2], t[3], t[4], t[6], span.file if span else None, span.line if span else None,
               t[7].mat if t[7] is not None else ())
        k = kind_of.get(key)
        if k is None:
            k = kind_of[key] = len(kind_of)
        tag_kind[i] = k
    untagged = (UNTAGGED, None, None, None, None, "untagged", None, None, ())
    tag_kind[-1] = kind_of.setdefault(untagged, len(kind_of))
    return kind_of, tag_kind


def export_scene(model: Any) -> Any:
    """The building for the exporters (`grammarkit.geometry.exporters.Scene`): one solid,
    its triangles grouped by terminal name, a material per (material name, colour), and
    per group the rules, source lines and semantic tags (docs/derive.md, "Files")."""
    from ..geometry.exporters import Material, Scene, Solid

    raw = model._ctx.tags  # plain lists [name, rule, otype, color, material, node, role, texturing]
    group_of_name: dict[str, int] = {}
    material_index: dict[Material, int] = {}
    materials: list[Material] = []
    info: list[dict] = []
    kind_of, tag_kind = _tag_kinds(raw, model._ctx.nodes)
    kind_group = np.empty(len(kind_of), dtype=np.int64)
    kind_material = np.empty(len(kind_of), dtype=np.int64)
    for (name, rule, otype, color, mat_name, role, file, line, cga_mat), k in kind_of.items():
        # a textured terminal without a colour is white, as CGA's default: glTF multiplies the
        # texture by the base colour
        textured = color is None and any(k == "colormap" for k, _ in cga_mat)
        rgba = rgba_of(color, "#ffffff" if textured else CUT_COLOR if role == "cut" else DEFAULT_COLOR)
        g = group_of_name.get(name)
        if g is None:
            g = group_of_name[name] = len(info)
            info.append({"terminal": name, "rules": set(), "sources": set(), "object_types": set(),
                         "roles": set(), "materials": set()})
        mat = _material(mat_name, rgba, cga_mat)
        m = material_index.get(mat)
        if m is None:
            m = material_index[mat] = len(materials)
            materials.append(mat)
        kind_group[k], kind_material[k] = g, m
        if rule is not None:
            d = info[g]
            d["rules"].add(rule)
            d["roles"].add(role)
            d["materials"].add(mat.label)
            if otype:
                d["object_types"].add(otype)
            if line:
                d["sources"].add(f"{os.path.basename(file or model.name)}:{line}")
    tag_group, tag_material = kind_group[tag_kind], kind_material[tag_kind]
    name = model.name or "building"
    solids = []

    def group_list(face_group: np.ndarray, surface: bool) -> list:
        counts = np.bincount(face_group, minlength=len(info))
        out = []
        for g, d in enumerate(info):
            extras = {k: (sorted(v) if isinstance(v, set) else v) for k, v in d.items()}
            extras["triangles"] = int(counts[g])
            if surface:
                extras["surface"] = True
            out.append((d["terminal"], extras))
        return out
    if model.faces.shape[0]:
        tri_tags = model.triangle_tags  # -1 (untagged) picks the entry appended last
        face_group = tag_group[tri_tags]
        solids.append(Solid(name, model.vertices, model.faces, face_group, group_list(face_group, False),
                            tag_material[tri_tags], materials,
                            extras={"grammar": model.name, "seed": model.seed}, uv=model.triangle_uvs))
    if len(model.surface_faces):
        # the surface layer: its own node, flagged as a surface (no inside, not part of the
        # solid's watertight guarantee), double-sided materials (docs/language.md, "Solids and surfaces")
        stags = model.surface_tags
        face_group = tag_group[stags]
        used = np.unique(tag_material[stags])
        remap = np.zeros(len(materials), dtype=np.int64)
        remap[used] = np.arange(len(used))
        smats = [replace(materials[m], double_sided=True) for m in used.tolist()]
        solids.append(Solid(f"{name} surfaces", model.surface_vertices, model.surface_faces, face_group,
                            group_list(face_group, True), remap[tag_material[stags]], smats,
                            extras={"grammar": model.name, "seed": model.seed, "surface": True},
                            uv=model.surface_uvs))
    extras = {"grammar": model.name, "seed": model.seed,
              "attrs": {k: v for k, v in model.attrs.items() if isinstance(v, (int, float, str, bool))},
              "bindings": dict(model.bindings),
              "materials": sorted({t[4] for t in raw if t[4]})}
    if model._ctx.reports:
        extras["reports"] = model.reports  # CGA's reports, in the building node's extras
    # CityEngine's open-face output keeps CityEngine's textured look (docs/derive.md, "Files")
    return Scene(name, solids, extras, texture_seams=model._ctx.surfaces_mode == "cga")
