"""grammarkit sketch recognizer (Nishida et al. 2016): a line drawing in, a snippet with its
parameters out, and a whole building sketched stage by stage written back as one grammar.

Python API::

    from grammarkit_sketch import recognize, Session
    r = recognize("roof.png", "Roof")          # -> Recognition (snippet, top 3, values, score)
    s = Session()                              # shipped models and library
    s.add_strokes("Mass", strokes, canvas=(512, 512))
    print(s.grammar_text())

CLI: ``grammarkit recognize``, ``grammarkit sketch-session``, ``grammarkit train sketch``.
Needs the `learning` extra (torch). See docs/sketch.md.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

_LAZY = {
    "recognize": "recognizer", "Recognition": "recognizer", "Recognizer": "recognizer",
    "Candidate": "recognizer", "get_recognizer": "recognizer",
    "Session": "session", "StageCanvas": "session",
    "load_library": "library", "SnippetLibrary": "library",
    "load_models": "models", "save_models": "models", "SketchModels": "models",
    "train": "training", "TrainConfig": "training",
    "StageSpec": "stages", "default_stage": "stages",
}
__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    # Imported on first use: the plugin manager imports `.plugin` (and so this package) for
    # every `grammarkit` command, which must not pay for numpy, scipy or torch.
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{_LAZY[name]}"), name)
    globals()[name] = value
    return value
