"""grammarkit: procedural and example-based 3D shape modeling.

Public API (heavy modules are imported on first use):

    grammarkit.parse(text_or_path) -> Grammar         # .grammar text -> IR
    grammarkit.check(text_or_path) -> list[Diagnostic] # every problem at once
    grammarkit.format(text_or_path_or_grammar) -> str  # canonical text
    grammarkit.derive(grammar, seed=0, attrs={}) -> Model  # split grammar -> mesh
    grammarkit.tiling                                   # shape graphs, learn, validate, dock
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

from .errors import (
    DerivationError, Diagnostic, GrammarError, GrammarkitError, LimitError, PluginError, ShapeError,
)
from .hookspecs import hookimpl
from .ir import Grammar

__version__ = "0.1.0"

_LAZY = {
    "parse": ("grammarkit.dsl", "parse"),
    "check": ("grammarkit.dsl", "check"),
    "format": ("grammarkit.printer", "format_grammar"),
    "print_grammar": ("grammarkit.printer", "print_grammar"),
    "derive": ("grammarkit.split", "derive"),
    "Model": ("grammarkit.split", "Model"),
    "tiling": ("grammarkit.tiling", None),
    "get_plugin_manager": ("grammarkit.plugins", "get_plugin_manager"),
    "import_cga": ("grammarkit.cga", "import_cga"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module_name, attr = _LAZY[name]
        module = import_module(module_name)
        return module if attr is None else getattr(module, attr)
    raise AttributeError(f"module 'grammarkit' has no attribute {name!r}")


__all__ = [
    "DerivationError", "Diagnostic", "Grammar", "GrammarError", "GrammarkitError", "LimitError",
    "PluginError", "ShapeError", "hookimpl", *_LAZY,
]
