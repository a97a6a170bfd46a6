"""The engine side of CityEngine's semantics (issue 26): asset lookup through `asset_dir`,
taper, surface-only models, extrude/offset on volumes, rotate(), texture operations on
inserted assets. Each checked against closed forms or CGA's documented behaviour."""
from __future__ import annotations

import math
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
    return grammar.model_copy(update={"asset_dirs": tuple(dirs)})


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
    m = derive(_with_asset_dirs(load(g), ["../assets"]))
    assert m.solid_triangle_count == 0 and m.surface_triangle_count == 1  # the grammar's own file


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
    m = derive("Lot --> footprint(rect(2, 2)) Ground.\n")
    assert m.mesh.copy().faces.shape == (0, 3)
    assert m.solid_triangle_count == 0 and m.surface_triangle_count == len(m.surface_mesh.faces) == 2
    assert m.triangle_count == 2
    solid = derive("Lot --> footprint(rect(2, 2)) extrude(2) Mass.\n")
    assert solid.solid_triangle_count == len(solid.mesh.faces) == solid.triangle_count == 12
