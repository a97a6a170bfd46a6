"""The engine side of CityEngine's semantics (issue 26): asset lookup through `asset_dir`,
taper, surface-only models, extrude/offset on volumes, rotate(), texture operations on
inserted assets. Each checked against closed forms or CGA's documented behaviour."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grammarkit.dsl import load
from grammarkit.errors import DerivationError
from grammarkit.split import derive

CUBE_OBJ = """v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1
f 1/1 4/4 3/3 2/2\nf 5/1 6/2 7/3 8/4\nf 1/1 2/2 6/3 5/4\nf 2/1 3/2 7/3 6/4\nf 3/1 4/2 8/3 7/4\nf 4/1 1/2 5/3 8/4
"""


def _with_asset_dirs(grammar, dirs):
    """The grammar as the dsl's `asset_dir "..."` statements make it (Grammar.asset_dirs)."""
    from grammarkit.ir import AssetDir

    return grammar.model_copy(update={"statements": (*grammar.statements, *(AssetDir.of(d) for d in dirs))})


# -- asset lookup: the grammar's folder, then each asset_dir ------------------------------------
def _project(tmp_path: Path) -> Path:
    (tmp_path / "assets" / "parts").mkdir(parents=True)
    (tmp_path / "assets" / "parts" / "box.obj").write_text(CUBE_OBJ)
    (tmp_path / "rules").mkdir()
    return tmp_path / "rules"


@pytest.mark.parametrize("insert", ['i("parts/box.obj")', "i(asset)", 'i(folder + "box.obj")'])
def test_i_finds_literal_and_computed_names_in_the_asset_dirs(tmp_path, insert):
    rules = _project(tmp_path)
    g = rules / "house.grammar"
    g.write_text('attr asset = "parts/box.obj"\nconst folder = "parts/"\n'
                 f"Lot --> footprint(rect(4, 2)) extrude(3) Box\nBox --> {insert} Part.\n")
    grammar = load(g)
    with pytest.raises(DerivationError, match="mesh file not found"):
        derive(grammar)  # not beside the grammar, and no asset_dir says where
    m = derive(_with_asset_dirs(grammar, ["../assets"]))
    assert m.mesh.is_watertight
    assert np.allclose(m.mesh.bounds, [[0, 0, 0], [4, 2, 3]], atol=0.01)


def test_a_file_beside_the_grammar_wins_over_the_asset_dirs(tmp_path):
    rules = _project(tmp_path)
    (rules / "parts").mkdir()
    (rules / "parts" / "box.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n")  # an open triangle
    g = rules / "house.grammar"
    g.write_text('Lot --> footprint(rect(4, 2)) extrude(3) i("parts/box.obj") Part.\n')
    m = derive(_with_asset_dirs(load(g), ["../assets"]), surfaces="cga")
    assert m.solid_triangle_count == 0 and m.surface_triangle_count == 1  # the grammar's own file
    closed = derive(_with_asset_dirs(load(g), ["../assets"]))  # the default: the triangle, 1 cm thick
    assert closed.surface_triangle_count == 0 and closed.mesh.is_watertight
    assert closed.mesh.extents == pytest.approx([4, 2, 0.01], abs=0.003)


# -- taper: CGA's pyramid over the face ------------------------------------------------------
def test_taper_is_an_engine_operation_with_cgas_pyramid():
    m = derive("Lot --> footprint(rect(6, 4)) taper(3) Roof.\n")
    assert m.mesh.is_watertight
    # a pyramid: base x height / 3 (solids are grown by 1 mm so touching ones fuse: grammarkit.split.engine.WELD)
    assert m.mesh.volume == pytest.approx(6 * 4 * 3 / 3, rel=5e-3)
    top = m.mesh.vertices[np.argmax(m.mesh.vertices[:, 2])]
    assert top == pytest.approx([3, 2, 3], abs=0.01)  # the apex over the face's centre


# -- a model without a solid -----------------------------------------------------------------
def test_a_surface_only_model_has_an_empty_copyable_mesh_and_counts_its_layers():
    m = derive("Lot --> footprint(rect(2, 2)) Ground.\n", surfaces="cga")  # CGA's open faces
    assert m.mesh.copy().faces.shape == (0, 3)
    assert m.solid_triangle_count == 0 and m.surface_triangle_count == len(m.surface_mesh.faces) == 2
    assert m.triangle_count == 2
    solid = derive("Lot --> footprint(rect(2, 2)) extrude(2) Mass.\n")
    assert solid.solid_triangle_count == len(solid.mesh.faces) == solid.triangle_count == 12


# -- rotate(mode, system, x, y, z) ---------------------------------------------------------
def _axes(body: str) -> np.ndarray:
    m = derive(f"Lot --> footprint(rect(4, 2)) extrude(3) {body} Box.\n")
    return np.array(m.parts[0].axes)


def test_rotate_rel_scope_is_r():
    assert np.allclose(_axes("rotate(rel, scope, 10, 20, 30)"), _axes("r(10, 20, 30)"))


def test_rotate_abs_world_sets_the_orientation_whatever_it_was():
    assert np.allclose(_axes("r(0, 0, 37) rotate(abs, world, 0, 0, 0)"), np.eye(3))
    # CGA's example: rotate(abs, world, 0, 90, 0) turns the scope's x to the world's -z
    assert np.allclose(_axes("r(10, 0, 50) rotate(abs, world, 0, 90, 0)"), [[0, 0, -1], [0, 1, 0], [1, 0, 0]])
    assert np.allclose(_axes("r(0, 0, 37) rotate(abs, object, 0, 0, 0)"), np.eye(3))


def test_rotate_rel_world_turns_about_the_worlds_axes_not_the_scopes():
    # after r(90, 0, 0) the scope is x=(1,0,0), y=(0,0,1), z=(0,-1,0); 90 degrees about the world's z
    # maps (a, b, c) to (-b, a, c), about the scope's z (the world's -y) it would not
    assert np.allclose(_axes("r(90, 0, 0) rotate(rel, world, 0, 0, 90)"), [[0, 1, 0], [0, 0, 1], [1, 0, 0]])
    assert np.allclose(_axes("r(90, 0, 0) rotate(rel, scope, 0, 0, 90)"), [[0, 0, 1], [-1, 0, 0], [0, -1, 0]])


def test_rotate_turns_about_the_scope_origin_and_keeps_the_solid_closed():
    m = derive("Lot --> footprint(rect(4, 2)) extrude(3) rotate(rel, world, 0, 0, 90) Box.\n")
    assert m.mesh.is_watertight
    assert np.allclose(m.mesh.bounds, [[-2, 0, 0], [0, 4, 3]], atol=0.01)


def test_rotate_rejects_an_unknown_system_with_the_choices():
    from grammarkit.errors import GrammarError

    with pytest.raises(GrammarError, match="scope|pivot|object|world"):
        derive("Lot --> footprint(rect(4, 2)) rotate(rel, local, 0, 0, 9) X.\n")


# -- extrude / offset on a volume: per face, as CGA ------------------------------------------
BOX = "Lot --> footprint(rect(4, 2)) extrude(3) "  # faces 4 x 2 (twice), 4 x 3 (twice), 2 x 3 (twice)


def test_extrude_on_a_volume_extrudes_every_face_along_its_normal():
    m = derive(BOX + "extrude(1) Shell.\n")
    assert m.mesh.is_watertight
    # six 1 m slabs on the faces: 2 x (8 + 12 + 6) m³, around the (empty) box
    assert m.mesh.volume == pytest.approx(52.0, rel=5e-3)
    assert np.allclose(m.mesh.bounds, [[-1, -1, -1], [5, 3, 4]], atol=0.01)


def test_extrude_of_a_volume_inwards_leaves_the_hollow_inside():
    m = derive(BOX + "extrude(-0.5) Walls.\n")
    assert m.mesh.is_watertight
    assert m.mesh.volume == pytest.approx(4 * 2 * 3 - 3 * 1 * 2, rel=5e-3)  # the box minus its 3 x 1 x 2 core
    assert np.allclose(m.mesh.bounds, [[0, 0, 0], [4, 2, 3]], atol=0.01)


def test_offset_on_a_volume_offsets_every_face_in_its_plane():
    inside = derive(BOX + "offset(-0.5) Inside.\n", surfaces="cga")  # CGA's open faces
    assert inside.solid_triangle_count == 0
    assert inside.surface_mesh.area == pytest.approx(2 * (3 * 1 + 3 * 2 + 1 * 2))
    both = derive(BOX + "offset(-0.5) { inside: I. | border: B. }\n", surfaces="cga")
    assert [p.name for p in both.parts] == ["I", "B"]
    assert both.surface_mesh.area == pytest.approx(2 * (4 * 2 + 4 * 3 + 2 * 3))  # inside + border: every face


def test_offset_faces_of_a_volume_can_be_extruded_into_panels():
    m = derive(BOX + "offset(-0.5) { inside: extrude(0.2) Panel. | border: Frame. }\n", surfaces="cga")
    assert m.mesh.is_watertight
    assert m.mesh.volume == pytest.approx(0.2 * 2 * (3 * 1 + 3 * 2 + 1 * 2), rel=2e-2)
