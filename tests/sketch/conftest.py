"""Shared fixtures of the sketch recognizer tests: the library, stages, synthetic sketches."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
LIBRARY = ROOT / "grammars" / "library.grammar"


@pytest.fixture(scope="session")
def library():
    from grammarkit_sketch.library import load_library

    return load_library(LIBRARY)


@pytest.fixture(scope="session")
def stages(library):
    from grammarkit_sketch.stages import default_stage

    return {t: default_stage(library, t) for t in library.types}


def sketch_of(library, stage, snippet, u, seed=0, kind="sketchy", size=None):
    """A synthetic sketch (PIL image, dark lines on white) of a snippet instance and its values."""
    from PIL import Image

    from grammarkit_sketch.dataset import stage_view
    from grammarkit_sketch.drawing import draw, test_style
    from grammarkit_sketch.stages import StageDeriver

    info = library.snippets[snippet]
    values = {p.name: p.value(x) for p, x in zip(info.params, u)}
    model = StageDeriver(library, stage).derive(snippet, values)
    style = test_style(kind, np.random.default_rng(seed))
    ink = draw(model, stage_view(stage, model, size or stage.canvas_size(), style), style, stage.host_box())
    return Image.fromarray((255 - ink * 255).astype(np.uint8), "L"), values


@pytest.fixture(scope="session")
def torch_or_skip():
    return pytest.importorskip("torch")
