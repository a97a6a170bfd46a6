"""The back-end contract: a typed request in, results yielded out; no files touched.

Every back end (the built-in `split` engine, the graph sampler, and third-party ones) is a
`BackendSpec` returned by the `grammarkit_backends` hook. Its `run(request)` is a generator:

    def run(request: Request) -> Iterator[Result]:
        for index in range(request.start, request.n):
            model = ...                                   # a Model, an Assembly, a Scene
            yield Result(id=f"variant_{index:05d}", index=index, seed=..., model=model)

The run layer (`grammarkit.run.run_backend`) validates options, opens the output folder, hands
the results to the one writer (files + manifest.jsonl) and reports shortfalls. A back end
never writes files, never starts processes of its own (it asks `request.executor`), and
never reads the global plugin manager (`request.registries` has what it needs).

Determinism: a result must depend only on (request.seed, its index) and the grammar, never
on the number of workers or on how the run was split up.
"""
from __future__ import annotations

# The contract itself lives beside the other specs (grammarkit.registry), so that the registry
# and the hooks need not import the run layer; this is its documented import path.
from ..registry import BackendSpec, Request, Result, RunFunction

__all__ = ["BackendSpec", "Request", "Result", "RunFunction"]
