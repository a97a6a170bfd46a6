"""Geometry-free descriptions of what plugins provide, shared by the checker and the engines.

The DSL checker validates operation calls against `OperationSpec`s (names, arity,
argument types, block kind) without knowing what an operation does; the split engine
calls the spec's `apply`. Likewise for global constraints and expression functions.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Literal

# number, string: a value of that type; color: a string '#rrggbb' or '#rgb' (checked when
# constant); axis, selector: a bare name among `choices`; name: a bare name of the registry kind
# `names` (e.g. a fit); any, expr: whatever the operation makes of it.
ArgType = Literal["number", "string", "color", "axis", "selector", "name", "any", "expr"]
BlockKind = Literal["none", "sizes", "selectors", "optional-selectors", "optional-sizes"]


@dataclass(frozen=True)
class Param:
    name: str
    type: ArgType = "number"
    required: bool = True
    default: Any = None
    choices: tuple[str, ...] = ()  # for axis/selector-like parameters
    doc: str = ""
    names: str = ""  # for type "name": the Registries kind the name must be in ("fits")


@dataclass(frozen=True)
class OperationSpec:
    """A split operation as the language sees it.

    `block` says what may follow in `{ }`: nothing, split sizes, or selectors (whose
    names are in `selectors`). `apply(context, shape, args, block)` is engine-defined;
    the DSL never calls it.
    """

    name: str
    params: tuple[Param, ...] = ()
    block: BlockKind = "none"
    selectors: tuple[str, ...] = ()
    doc: str = ""
    apply: Callable[..., Any] | None = field(default=None, compare=False, repr=False)
    variadic: bool = False  # accepts any number of extra positional arguments
    plugin: str = ""  # filled in by the plugin manager


@dataclass(frozen=True)
class FunctionSpec:
    """A built-in expression function (`rand`, `min`, `rect`, ...)."""

    name: str
    min_args: int
    max_args: int | None
    doc: str = ""
    impl: Callable[..., Any] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class ConstraintSpec:
    """A global constraint of tiling grammars (`connected`, `grounded`, `path`, `count`).

    `check(graph, args, context) -> list[str]` returns violation messages (empty: satisfied).
    """

    name: str
    params: tuple[Param, ...] = ()
    doc: str = ""
    check: Callable[..., list[str]] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class ExporterSpec:
    """A model writer for a file format (`glb`, `obj`, `stl`, `ply`, ...).

    `encode(model) -> bytes` turns a split `Model`, a tiling `Assembly`, a trimesh Scene or
    Trimesh into the file's bytes; it never touches the file system (the run layer's writer
    writes atomically and checks the bytes first). `check(data) -> str | None` optionally
    says what is wrong with bytes that cannot be a valid file of this format.
    """

    format: str
    suffixes: tuple[str, ...]
    doc: str = ""
    encode: Callable[[Any], bytes] | None = field(default=None, compare=False, repr=False)
    check: Callable[[bytes], "str | None"] | None = field(default=None, compare=False, repr=False)
    plugin: str = ""


@dataclass(frozen=True)
class FitSpec:
    """A way to fit an inserted asset into a scope: `i("fence.glb", fit=NAME)` in split grammars.

    `fit(mesh, size) -> mesh` receives the asset as a trimesh.Trimesh normalised to its bounding
    box's minimum corner at the origin, and the scope size (sx, sy, sz); it returns the mesh to
    insert (same frame, bounding box of `size`). The built-in behaviour (`fit=scale`, the
    default) scales the asset; e.g. the retargeter plugin provides `fit=retarget`.
    """

    name: str
    doc: str = ""
    fit: Callable[[Any, tuple[float, float, float]], Any] | None = field(default=None, compare=False,
                                                                          repr=False)
    plugin: str = ""


# The back-end contract lives with the run layer; re-exported here with the other specs.
from .run.backend import BackendSpec  # noqa: E402


class Registries:
    """What plugins provide, by kind, as the core receives it (never the global manager).

    Each kind is a name -> spec mapping computed on first access (so a command that needs no
    exporters never runs exporter hooks). Build one from explicit mappings for tests, or get
    the plugin manager's with `grammarkit.plugins.get_plugin_manager().registries()`.
    """

    KINDS = ("operations", "functions", "constraints", "exporters", "backends", "fits")

    def __init__(self, loaders: dict[str, Callable[[], dict]] | None = None, *,
                 installed: bool = False, **mappings: dict):
        # installed: these are exactly what a fresh process's plugin manager provides (the
        # entry points, under the same environment), so a worker process rebuilds them
        # instead of receiving them (see __reduce__)
        self.installed = installed
        self._loaders = dict(loaders or {})
        self._values: dict[str, dict] = {}
        for kind, mapping in mappings.items():
            if kind not in self.KINDS:
                raise TypeError(f"Registries: unknown kind {kind!r}")
            self._values[kind] = dict(mapping)

    def __reduce__(self) -> Any:
        """Pickled by reference when they are the installed plugins' (a worker process
        rebuilds its own from the entry points); other registries hold functions that need
        not pickle, so they refuse, and the executor keeps such work in the calling process."""
        if not self.installed:
            import pickle

            raise pickle.PicklingError("these registries were built in this process (plugins "
                                       "registered at run time or given by hand)")
        return (_installed_registries, ())

    def _get(self, kind: str) -> dict:
        value = self._values.get(kind)
        if value is None:
            loader = self._loaders.get(kind)
            value = dict(loader()) if loader is not None else {}
            self._values[kind] = value
        return value

    @property
    def operations(self) -> dict[str, OperationSpec]:
        return self._get("operations")

    @property
    def functions(self) -> dict[str, FunctionSpec]:
        return self._get("functions")

    @property
    def constraints(self) -> dict[str, ConstraintSpec]:
        return self._get("constraints")

    @property
    def exporters(self) -> dict[str, ExporterSpec]:
        return self._get("exporters")

    @property
    def backends(self) -> dict[str, BackendSpec]:
        return self._get("backends")

    @property
    def fits(self) -> dict[str, FitSpec]:
        return self._get("fits")


def _installed_registries() -> "Registries":
    """A worker process's own registries of the installed plugins (unpickling target)."""
    from .plugins import default_registries

    return default_registries()
