"""The run layer: every back end stands on it (see docs/architecture.md).

- `backend`:  the contract: `BackendSpec`, `Request` in, `Result`s yielded out.
- `options`:  `--option key=value` validated against a back end's pydantic options model.
- `executor`: the one executor for parallel work (local processes; pluggable).
- `writer`:   the one writer: atomic files, `run.json` + `manifest.jsonl`, resumable folders.
- `api`:      `run_backend(...)` (writes a folder) and `iter_results(...)` (in memory).

Importing this package is cheap; heavy modules load on first use.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

from .backend import BackendSpec, Request, Result

_LAZY = {
    "run_backend": "api", "iter_results": "api", "RunSummary": "api", "resolve_backend": "api",
    "encode_result": "api", "preview_png": "api",
    "parse_options": "options", "describe_options": "options", "OptionError": "options",
    "LocalExecutor": "executor", "Executor": "executor", "make_executor": "executor",
    "default_workers": "executor",
    "OutputFolder": "writer", "write_files": "writer", "check_outputs": "writer",
    "grammar_hash": "writer", "RunMismatch": "writer",
}

__all__ = ["BackendSpec", "Request", "Result", *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'grammarkit.run' has no attribute {name!r}")
