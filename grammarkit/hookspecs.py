"""The plugin author's contract: every hook grammarkit calls, with what it receives and returns.

A plugin is a module (or object) with functions decorated by `grammarkit.hookimpl` and named
like the specifications below. Register it with an entry point in group ``grammarkit``::

    [project.entry-points.grammarkit]
    my-plugin = "my_package.plugin"

grammarkit's own features (the split operations, the tiling constraints, the exporters,
the graph sampler) are registered exactly this way. Every hook is optional. Hooks are
called once, lazily, the first time the plugin manager needs that kind of thing; results
are cached for the process.

- Order: implementations are called in pluggy's call order (`@hookimpl(tryfirst=True)` /
  `trylast=True`, otherwise the later registered first).
- Names are global: a name two plugins provide is an error naming both (the first in call
  order is used); a built-in (grammarkit's own entry points) is never replaced.
- Each returned item must have the hook's spec type; a wrong one is reported and dropped.
- A hook that raises is reported with the plugin's name and its contribution is skipped;
  other plugins and unrelated commands keep working.

What a split operation's `apply(ctx, shape, args, block)` receives is described by the
protocols at the end of this module: `OperationContext` (ctx), `ShapeView` (shape and the
shapes it makes) and `BlockSlot` (the entries of `block`). Operations use nothing else; the
built-in ones (grammarkit/split/ops.py) are written against exactly these.
See docs/plugins.md for complete examples.
"""
from __future__ import annotations

import random
from typing import TYPE_CHECKING, Any, Callable, Iterable, Protocol

import pluggy

if TYPE_CHECKING:  # pragma: no cover - types only
    import click

    from .plugins import Application
    from .registry import BackendSpec, ConstraintSpec, ExporterSpec, FitSpec, FunctionSpec, OperationSpec, Registries

# Every hook receives `app`, the one grammarkit.plugins.Application of the process (created
# at the edge: the command line, the Python API): `app.registries` holds what the other
# plugins provide, `app.version` grammarkit's version. pluggy passes only the arguments an
# implementation names, so `def grammarkit_operations():` keeps working. Do not read, in a
# hook, the kind that hook is collecting (that would ask the hook for itself).
PROJECT = "grammarkit"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def grammarkit_operations(app: "Application") -> Iterable["OperationSpec"]:
    """Split operations this plugin provides (e.g. `extrude`, `split`, `roofGable`).

    Return `OperationSpec`s. The checker validates calls against `params`/`block`; the split
    engine calls `apply(ctx, shape, args, block)` with an `OperationContext`, a `ShapeView`,
    the evaluated arguments in parameter order (defaults filled in) and the block's
    `BlockSlot`s (or None). A name provided twice is an error reported with both plugins'
    names; a built-in operation is never replaced.
    """


@hookspec
def grammarkit_functions(app: "Application") -> Iterable["FunctionSpec"]:
    """Expression functions usable in grammar text (`rand(lo, hi)`, `min(a, b)`, ...)."""


@hookspec
def grammarkit_constraints(app: "Application") -> Iterable["ConstraintSpec"]:
    """Global constraints of tiling grammars (`constraint NAME(args)` in grammar text).

    `check(graph, args, context)` receives the shape graph (networkx, nodes with attribute
    `type`), the evaluated arguments as a dict, and a context with the assembly; it returns a
    list of human-readable violation messages, empty when the constraint holds.
    """


@hookspec
def grammarkit_backends(app: "Application") -> Iterable["BackendSpec"]:
    """Back ends for `grammarkit derive --backend NAME` and `grammarkit.run.run_backend`.

    Return `grammarkit.run.BackendSpec`s. A back end's `run(request)` is a generator that
    yields `grammarkit.run.Result`s and never writes files; its `options` is a pydantic model
    of its `--option key=value` settings. See grammarkit/run/backend.py and docs/plugins.md.
    """


@hookspec
def grammarkit_exporters(app: "Application") -> Iterable["ExporterSpec"]:
    """File formats models can be written in (`--format` / output suffix)."""


@hookspec
def grammarkit_cli_commands(app: "Application") -> Iterable["click.Command"]:
    """Extra `grammarkit` subcommands (click commands). Names must not clash with built-ins."""


@hookspec
def grammarkit_train_commands(app: "Application") -> Iterable["click.Command"]:
    """Subcommands of `grammarkit train` (click commands), one per trainable model kind, e.g.
    `grammarkit train string-vae DATASET -o model.vae`. Names must be unique across plugins."""


@hookspec
def grammarkit_insert_fits(app: "Application") -> Iterable["FitSpec"]:
    """Ways to fit an inserted asset into a scope, named in grammar text as
    `i("asset.glb", fit=NAME)`; see `grammarkit.registry.FitSpec`."""


# -- what operations receive -----------------------------------------------------------------
Vec = tuple[float, float, float]


class ShapeView(Protocol):
    """A shape of the split engine as operations see it (grammarkit.split.Shape implements it).

    The scope is an origin `o`, three orthonormal world axes `ax` (the scope's x, y, z) and a
    size `sz`. An operation may modify and return the shape it receives (it owns it for the
    call), or return new shapes made with `copy()` / `derived()`; never build a Shape from
    scratch (derived shapes carry the derivation's values and tags)."""

    o: Vec  # origin, world coordinates
    ax: tuple[Vec, Vec, Vec]  # the scope's x, y, z axes in world coordinates
    sz: Vec  # size along the scope's axes
    kind: str  # "F" (a face in the scope's xy plane) or "V" (a volume)
    poly: Any  # face/footprint contours in scope coordinates, None for the full rectangle
    solid: Any  # a manifold3d.Manifold in scope coordinates (roofs, inserted meshes), or None
    color: str | None  # "#rrggbb" tag
    material: str | None  # material tag
    params: tuple  # the current rule's arguments
    seed: int  # the shape's seed (run seed mixed with its derivation path)
    entry: tuple | None  # (o, ax, sz) when the current rule was entered
    # geometry id: copies keep it, derived shapes get a new one (see grammarkit/split/shape.py)
    gid: int
    # a face made by comp(f): (gid of the volume, its (o, ax, sz)); if that volume is emitted
    # as a solid unmoved, the face is a view of its surface, else a surface of its own. An
    # operation that moves a face off its plane sets it to None.
    on: tuple | None
    trims: tuple  # CGA trim planes ((world point, world normal), ...) that clip inserted meshes
    trim_on: bool  # whether i() clips by them (CGA's trim.vertical; the trim() operation)
    # CGA texturing state (grammarkit.split.texturing.Texturing: projections, baked UVs as affine
    # maps of the world position, material attributes) or None. An operation that moves a
    # shape's geometry calls grammarkit.split.texturing.moved so its UVs move along.
    tex: Any
    # the attr/const values the shape's expressions read, shared between shapes until an
    # operation (CGA's set()) gives one shape a changed copy
    values: dict

    @property
    def rule_name(self) -> str: ...  # the rule being applied (for messages)

    @property
    def rule_span(self) -> Any: ...  # where that rule is written (a Span, or None)

    @property
    def index(self) -> int: ...  # split.index: position among its parent block's children

    @property
    def total(self) -> int: ...  # split.total

    @property
    def is_face(self) -> bool: ...

    def rng(self) -> random.Random: ...  # the shape's own generator, seeded by `seed`

    def copy(self) -> "ShapeView": ...

    def derived(self, o: Vec, sz: Vec, poly: Any = None, kind: str | None = None,
                ax: tuple[Vec, Vec, Vec] | None = None, solid: Any = None) -> "ShapeView":
        """A new shape with a new scope/geometry that keeps this one's tags."""

    def world(self, x: float, y: float, z: float) -> Vec: ...  # scope coordinates -> world

    def contours(self) -> tuple: ...  # `poly`, or the scope rectangle when `poly` is None


class BlockSlot(Protocol):
    """One entry of an operation's `{ }` block, as `apply` receives it in `block`.

    A block operation returns `[(child_shape, slot), ...]`; each child then runs the slot's
    body (the engine gives each child its seed and `split.index`/`split.total`)."""

    mode: str  # "abs", "rel", "float" (split sizes), "sel" (a selector), "repeat" (a group)
    sel: str | None  # the selector name of a "sel" entry
    items: tuple  # the entries of a "repeat" group
    span: Any  # where the entry is written (for messages)

    def size(self, shape: ShapeView) -> Any: ...  # the entry's size expression, on `shape`


class OperationContext(Protocol):
    """What a derivation offers an operation (`ctx` in `apply(ctx, shape, args, block)`).
    One per derivation; derivations may run at once, so keep no state outside it."""

    limits: Any  # grammarkit.split.Limits of this derivation
    registries: "Registries"  # operations, functions, fits, ... in effect
    base_dir: str | None  # folder of the grammar file (relative asset paths)
    seed: int  # the run seed
    cache: dict  # per-derivation memo for operations (keys: tuples starting with your op's name)

    def attr(self, name: str) -> Any: ...  # an attr's or const's value in this derivation

    @property
    def attrs(self) -> dict: ...  # every attr and const value (a copy)

    def add_solid(self, shape: ShapeView, name: str | None = None) -> None:
        """Add a volume shape's solid to the model as a terminal, without ending the shape."""

    def add_body(self, shape: ShapeView) -> None:
        """Keep a volume that is decomposed into faces as the body its faces decorate."""

    def recess(self, face: ShapeView, depth: float) -> ShapeView:
        """Cut a face `depth` into the solid below it; returns the face at the recess bottom."""

    def terminal(self, shape: ShapeView, name: str) -> None:
        """Make `shape` a terminal named `name` (as `Name.` does)."""

    def warn(self, message: str) -> None: ...  # a warning listed on the model

    def report(self, key: str, value: Any) -> None: ...  # a value for Model.reports (CGA's report())

    def message(self, text: str) -> None: ...  # a message on Model.messages (CGA's print())


Apply = Callable[[OperationContext, ShapeView, list, "tuple[BlockSlot, ...] | None"], Any]
