"""grammarkit: procedural and example-based 3D shape modeling.

Public API (every name is imported on first use, so `import grammarkit` and
`grammarkit --version` stay as fast as a bare Python start):

    grammarkit.parse(text_or_path) -> Grammar         # .grammar text -> IR
    grammarkit.check(text_or_path) -> list[Diagnostic] # every problem at once
    grammarkit.format(text_or_path_or_grammar) -> str  # canonical text
    grammarkit.derive(grammar, seed=0, attrs={}) -> Model  # split grammar -> mesh
    grammarkit.tiling                                   # shape graphs, learn, validate, dock

The functions above use the installed plugins' registries unless given `registries=`
(a `grammarkit.registry.Registries`); the core below them never reads the plugin manager.
"""
from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from .errors import (
    DerivationError, Diagnostic, GrammarError, GrammarkitError, LimitError, PluginError, ShapeError,
)

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
    "hookimpl": ("grammarkit.hookspecs", "hookimpl"),
    "Grammar": ("grammarkit.ir", "Grammar"),
    "Registries": ("grammarkit.registry", "Registries"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module_name, attr = _LAZY[name]
        module = import_module(module_name)
        value = module if attr is None else getattr(module, attr)
        if attr is not None:
            globals()[name] = value  # later lookups are plain attribute reads
        return value
    raise AttributeError(f"module 'grammarkit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .dsl import check, parse
    from .hookspecs import hookimpl
    from .ir import Grammar
    from .printer import format_grammar as format
    from .printer import print_grammar
    from .registry import Registries
    from .split import Model, derive

__all__ = [
    "DerivationError", "Diagnostic", "GrammarError", "GrammarkitError", "LimitError",
    "PluginError", "ShapeError", *_LAZY,
]
