"""Issue 19, tiling items: paths of an imported tiling grammar resolve against its own file;
round, finely tessellated parts are analysed on a bounded sample (no hang)."""
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from grammarkit.dsl import load
from grammarkit.tiling import Assembly, Part, learn, load_examples, rules_from_grammar, validate
from grammarkit.tiling.frames import MAX_TIE_PAIRS, symmetry_offsets

sys.path.insert(0, str(Path(__file__).parent))
from _tiling_helpers import EXAMPLES  # noqa: E402


def test_imported_tiling_grammar_resolves_mesh_and_assembly_against_its_own_file(tmp_path):
    lib, main = tmp_path / "lib", tmp_path / "project" / "main"
    lib.mkdir()
    main.mkdir(parents=True)
    for f in ("tiles.glb", "coast_6x5_h2_r0.glb"):
        shutil.copy(EXAMPLES / "wfc" / f, lib / f)
    text = (EXAMPLES / "wfc" / "coast.grammar").read_text()
    body = "\n".join(line for line in text.splitlines()
                     if not line.startswith(("grammar ", "example ")))
    (lib / "tiles.grammar").write_text(body + '\nexample c = assembly("coast_6x5_h2_r0.glb")\n')
    (main / "main.grammar").write_text('grammar main\nimport "../../lib/tiles.grammar"\n')
    # a file of the same name beside the importing grammar must not be picked up instead
    (main / "tiles.glb").write_bytes(b"not a mesh")
    g = load(main / "main.grammar")
    rules = rules_from_grammar(g)  # reads mesh("tiles.glb") from lib/
    assert set(rules.parts) == {"Grass", "Water", "Shore"}
    (example,) = load_examples(g)  # assembly("coast_6x5_h2_r0.glb") from lib/
    assert len(example) == 30 and validate(g, example).ok


def _two_balls(subdivisions: int) -> Assembly:
    a = trimesh.creation.icosphere(subdivisions=subdivisions)
    b = a.copy()
    b.apply_translation((2, 0, 0))
    return Assembly([Part("Ball.0", "Ball", a, np.eye(4)), Part("Ball.1", "Ball", b, np.eye(4))], name="two")


def test_round_parts_do_not_hang_symmetry_search():
    ball = trimesh.creation.icosphere(subdivisions=5)  # 20,480 triangles, every vertex tied
    t = time.perf_counter()
    syms = symmetry_offsets(np.asarray(ball.vertices), np.asarray(ball.faces))
    assert time.perf_counter() - t < 20  # was minutes: every tie triple walked
    assert 1 <= len(syms) <= 64
    for S in syms:  # each one a true symmetry (rotation mapping the sphere onto itself)
        R = S[:3, :3]
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0
    assert MAX_TIE_PAIRS >= 1


def test_learn_and_validate_two_fine_spheres():
    asm = _two_balls(5)
    g = learn([asm], name="balls", neighbors="none")
    assert validate(g, asm).ok
