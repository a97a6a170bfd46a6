"""Writing sampled variants: one GLB per variant (parts as typed nodes) and `manifest.jsonl`.

GLBs go through `grammarkit.tiling.write_assembly`, so they read back with `read_assembly`,
`grammarkit validate` and `grammarkit learn`. The manifest has one JSON object per variant:
file, iteration, node-type histogram, graph (part ids, types, edge list), parents and the
operation that made it (donor/recipient, which subgraph replaced which parts, the docking
transform and residual), and the dedupe mode used. It is rewritten atomically (temporary file
+ rename) after every iteration and at the end, so it always lists exactly the files written.
"""
from __future__ import annotations

import json
from pathlib import Path

MODEL_SUFFIXES = frozenset({".glb", ".gltf", ".obj", ".stl", ".ply"})


class VariantWriter:
    def __init__(self, out: Path, *, dedupe: str, seed: int):
        self.out = Path(out)
        if self.out.exists() and not self.out.is_dir():
            raise FileExistsError(f"{self.out}: exists and is not a folder (the graph sampler writes "
                                  "a folder of .glb files and manifest.jsonl)")
        if not self.out.exists() and self.out.suffix.lower() in MODEL_SUFFIXES:
            # `-o castle.glb` almost certainly means one file, but the output is many variants:
            # refuse rather than create a folder that looks like a mesh file.
            raise FileExistsError(f"{self.out}: the graph sampler writes a folder of variants "
                                  f"(.glb files and manifest.jsonl); give a folder name, e.g. "
                                  f"-o {self.out.with_suffix('')}/")
        self.out.mkdir(parents=True, exist_ok=True)
        self.dedupe = dedupe
        self.seed = seed
        self.lines: list[str] = []
        self.files: list[Path] = []

    def write(self, sampler, shape) -> Path:
        from grammarkit.tiling import write_assembly

        assembly = sampler.to_assembly(shape)
        path = self.out / f"{shape.key}.glb"
        write_assembly(assembly, path)
        record = {
            "id": shape.key,
            "file": path.name,
            "iteration": shape.iteration,
            "parts": len(shape),
            "histogram": shape.histogram(),
            "graph": {"nodes": [{"id": i, "type": t} for i, t in zip(shape.ids, shape.types)],
                      "edges": [[shape.ids[a], shape.ids[b]] for a, b in shape.edges]},
            "parents": list(shape.parents),
            "operation": assembly.meta["graph_sampler"]["operation"],
            "dedupe": self.dedupe,
            "seed": self.seed,
        }
        self.lines.append(json.dumps(record, sort_keys=True))
        self.files.append(path)
        return path

    def flush(self) -> Path:
        from grammarkit.fileio import atomic_output

        path = self.out / "manifest.jsonl"
        with atomic_output(path) as tmp:  # temp + rename, usual permissions, errors name the path
            tmp.write_text("".join(line + "\n" for line in self.lines), encoding="utf-8")
        return path
