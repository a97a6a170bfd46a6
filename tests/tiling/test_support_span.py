"""Support that means carried (issue 28): sideways runs bounded by `max_span`, learned from the
examples, and support verdicts that are monotone in the contact tolerance."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import trimesh

from grammarkit.dsl import parse
from grammarkit.printer import print_grammar
from grammarkit.tiling import Assembly, Part, learn, validate

_spec = importlib.util.spec_from_file_location("_tiling_helpers", Path(__file__).with_name("_tiling_helpers.py"))
_helpers = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_helpers)
box_part, EXAMPLES = _helpers.box_part, _helpers.EXAMPLES

GRAMMAR = """grammar bridge
part Post = box(1, 1, 2)
part Beam = box(1, 1, 0.5)
dock Post -- Beam
dock Beam -- Beam
constraint grounded(ground=0, sideways=true{span})
"""


def _bridge(left: bool, right: bool, beams: int) -> Assembly:
    """Beams in a row at height 2..2.5, on a post at the left end and/or the right end."""
    parts = []
    if left:
        parts.append(box_part("Post.0", "Post", (0, 0, 1), (1, 1, 2)))
    for i in range(beams):
        parts.append(box_part(f"Beam.{i}", "Beam", (i, 0, 2.25), (1, 1, 0.5)))
    if right:
        parts.append(box_part("Post.1", "Post", (beams - 1, 0, 1), (1, 1, 2)))
    return Assembly(parts, name="bridge")


def _grounded(grammar: str, asm: Assembly, tolerance: float = 1e-3) -> list[str]:
    report = validate(parse(grammar), asm, tolerance=tolerance)
    return [v.message for v in report.violations if v.rule == "constraint grounded"]


def test_max_span_bounds_the_run_held_only_sideways():
    g3 = GRAMMAR.format(span=", max_span=3")
    # a cantilever: one post under the first beam, then beams held by their neighbours only
    assert not _grounded(g3, _bridge(True, False, 4))  # beams 1..3: a run of 3
    msgs = _grounded(g3, _bridge(True, False, 5))  # a run of 4
    assert msgs and "max_span=3" in msgs[0] and "Beam.4" in msgs[0], msgs
    # a bridge of 7 beams between two posts: the 5 middle ones are one run
    assert _grounded(g3, _bridge(True, True, 7))
    assert not _grounded(GRAMMAR.format(span=", max_span=5"), _bridge(True, True, 7))
    # without max_span any chain of side contacts carries (the old behaviour, still available)
    assert not _grounded(GRAMMAR.format(span=""), _bridge(True, False, 12))
    # and without a post nothing is carried, whatever the span
    assert _grounded(GRAMMAR.format(span=", max_span=9"), _bridge(False, False, 3))


def test_learn_writes_the_examples_longest_sideways_run():
    files = [EXAMPLES / "balltrack" / f for f in ("track_short.glb", "track_long.glb")]
    notes: list[str] = []
    text = print_grammar(learn(files, name="b", notes=notes))
    assert "constraint grounded(ground=0, sideways=true, max_span=3)" in text
    assert any("max_span=3" in n for n in notes), notes
    # learned from boxes: a cantilever of 2 gives max_span=2, and a run of 3 is then rejected
    g = learn([_bridge(True, False, 3)], name="c")
    learned = print_grammar(g)
    assert "max_span=2" in learned, learned
    assert _grounded(learned, _bridge(True, False, 4))


def _wedge_and_block(gap: float) -> Assembly:
    """A wedge standing on the ground whose sloped face is 75 degrees steep, and a block lying
    against that face `gap` away from it, touching nothing else (its bottom is off the ground)."""
    h = np.tan(np.radians(75.0))
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, h], [0, 1, 0], [1, 1, 0], [0, 1, h]], float)
    wedge = trimesh.convex.convex_hull(pts)
    normal = np.array([np.sin(np.radians(75.0)), 0.0, np.cos(np.radians(75.0))])  # out of the slope
    T = trimesh.transformations.rotation_matrix(np.radians(75.0), (0, 1, 0))  # its +z face on the slope
    block = trimesh.creation.box(extents=(0.3, 0.3, 0.3))
    on_slope = np.array([1.0, 0.5, 0.0]) + 0.5 * np.array([-np.cos(np.radians(75.0)), 0, np.sin(np.radians(75.0))]) * h
    T[:3, 3] = on_slope + normal * (0.15 + gap)
    block.apply_transform(T)
    return Assembly([Part("Wedge.0", "Wedge", wedge), Part("Block.0", "Block", block, T)], name="lean")


@pytest.mark.parametrize("sideways", [False, True])
def test_support_is_monotone_in_the_tolerance(sideways):
    """Before issue 28 the lift test moved the part by 3 tolerances and asked for a gap of one:
    this block read as resting on the slope at tolerances 0.0022-0.008 and as a side contact
    from 0.01 on, so strict support passed and then failed as the tolerance grew."""
    asm = _wedge_and_block(0.002)
    text = ("grammar lean\npart Wedge = box(1, 1, 1) up(any)\npart Block = box(0.3, 0.3, 0.3) up(any)\n"
            f"constraint grounded(ground=0{', sideways=true' if sideways else ''})\n")
    tolerances = [0.0022, 0.003, 0.005, 0.008, 0.01, 0.02, 0.05, 0.1]
    ok = [not _grounded(text, asm, t) for t in tolerances]
    assert ok == sorted(ok), list(zip(tolerances, ok))  # once carried, carried at every larger tolerance
    # a 75-degree slope holds nothing from below: the block hangs on it (sideways: it is carried
    # only through a side contact with the wedge, which stands on the ground)
    assert ok == [sideways] * len(tolerances)


def test_a_gentle_slope_carries_at_every_tolerance():
    asm = _wedge_and_block(0.002)
    # the same block on a 30-degree slope rests on it
    h = np.tan(np.radians(30.0))
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, h], [0, 1, 0], [1, 1, 0], [0, 1, h]], float)
    wedge = trimesh.convex.convex_hull(pts)
    normal = np.array([np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))])
    T = trimesh.transformations.rotation_matrix(np.radians(30.0), (0, 1, 0))
    block = trimesh.creation.box(extents=(0.3, 0.3, 0.3))
    mid = np.array([0.5, 0.5, h / 2])
    T[:3, 3] = mid + normal * (0.15 + 0.002)
    block.apply_transform(T)
    asm = Assembly([Part("Wedge.0", "Wedge", wedge), Part("Block.0", "Block", block, T)], name="gentle")
    text = ("grammar lean\npart Wedge = box(1, 1, 1) up(any)\npart Block = box(0.3, 0.3, 0.3) up(any)\n"
            "constraint grounded(ground=0)\n")
    assert all(not _grounded(text, asm, t) for t in (0.0025, 0.005, 0.01, 0.05))
