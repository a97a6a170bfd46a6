"""Issue 28: every placed part is a rigid copy of its prototype unless its type is declared
deformable; a squashed gate is no gate."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from grammarkit.dsl import load, parse
from grammarkit.printer import print_grammar
from grammarkit.tiling import Assembly, Part, load_examples, validate

EXAMPLES = Path(__file__).resolve().parents[2] / "grammars" / "tiling"


def _squashed(asm: Assembly, pid: str, factor: float) -> Assembly:
    out = []
    for p in asm.parts:
        if p.id == pid:
            v = np.asarray(p.mesh.vertices, dtype=np.float64).copy()
            top = v[:, 2].max()
            v[:, 2] = top - (top - v[:, 2]) * factor  # about its top, as the substructure repair did
            mesh = p.mesh.copy()
            mesh.vertices = v
            p = Part(p.id, p.type, mesh, p.transform.copy(), dict(p.meta))
        out.append(p)
    return Assembly(out, name=f"{asm.name}-{pid}-x{factor:g}")


def test_a_squashed_part_is_reported_and_a_rigid_copy_is_not():
    g = load(EXAMPLES / "castle" / "castle.grammar")
    ex = load_examples(g)[1]
    assert validate(g, ex).ok
    gate = next(p.id for p in ex.parts if p.type == "Gate")
    r = validate(g, _squashed(ex, gate, 0.948))  # a 5.00 m gate squashed to 4.74 m
    rigid = [v for v in r.violations if v.rule == "rigid"]
    assert [v.part_id for v in rigid] == [gate], r.format()
    assert "not a rigid copy" in rigid[0].message and "deformable(Gate)" in rigid[0].message
    # within 0.1% of the diagonal: still rigid (float noise, rounding in files)
    assert not [v for v in validate(g, _squashed(ex, gate, 0.99999)).violations if v.rule == "rigid"]
    off = validate(g, _squashed(ex, gate, 0.948), rigid=False)  # (its bottom left the ground: grounded)
    assert "rigid" not in {v.rule for v in off.violations}


def test_a_declared_deformable_type_is_not_checked():
    g = load(EXAMPLES / "castle" / "castle.grammar")
    text = print_grammar(g) + "constraint deformable(Gate)\n"
    g2 = parse(text).model_copy(update={"source_path": g.source_path})
    ex = load_examples(g)[1]
    gate = next(p.id for p in ex.parts if p.type == "Gate")
    wall = next(p.id for p in ex.parts if p.type == "Wall")
    r = validate(g2, _squashed(ex, gate, 0.948))
    assert not [v for v in r.violations if v.rule == "rigid"], r.format()
    r = validate(g2, _squashed(ex, wall, 0.9))
    assert [v.part_id for v in r.violations if v.rule == "rigid"] == [wall]
