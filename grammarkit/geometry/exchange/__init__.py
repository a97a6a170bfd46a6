"""The model writers, one module per format (as trimesh's `exchange/`), on one scene model.

- `scene`: the intermediate form every writer reads (`Scene` of `Solid`s with `Material`s)
  and `solids_of`, which makes it from a split Model, an assembly, a trimesh Scene or Trimesh;
- `gltf`: GLB and glTF (grammarkit's layout, docs/derive.md "Files");
- `obj`, `stl`, `ply`: the Z-up mesh formats.

`grammarkit.geometry.exporters` is the public face: it re-exports these and holds the
exporter lookup (`exporter_for`, `encode`, `export`).
"""
