"""Training sets: snippet instances with parameters drawn uniformly in their ranges, derived on
their stage and drawn in sketch style (Nishida et al. 2016, s. 5.3), cached on disk.

Every sample's randomness (its parameters and its pen) comes from
`default_rng([seed, type index, snippet index, sample index])`, so a set is the same whatever
the number of worker processes, and a cached set is reused only when everything it depends on
is unchanged (the cache key hashes the library hash, the stages, the style, the sizes and the
generator's version).

Two analyses run before training, both by comparing exact (plain-style) drawings:
- *drawing-identical snippets*: two snippets of a type whose drawings coincide for shared
  parameter values (in grammars/library.grammar, `mass_box` and `mass_rowhouse` both extrude the
  lot; they differ only in which faces become facades) are one class for the classifier: no
  drawing can tell them apart.
- *invisible parameters*: a parameter whose value never changes the drawing is not regressed
  (e.g. `floor_balcony.bal_every`, which needs the whole facade to show).
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from .drawing import DrawStyle, draw, test_style, training_style
from .image import RES, level, resize, to_input
from .library import SnippetLibrary
from .stages import StageDeriver, StageSpec

GENERATOR_VERSION = 6
DEFAULT_CACHE = Path(os.environ.get("GRAMMARKIT_SKETCH_CACHE",
                                    Path.home() / ".cache" / "grammarkit" / "sketch"))
MAX_ATTEMPTS = 20  # parameter draws per sample before giving up on a snippet

Progress = Callable[[int], None]


@dataclass
class SampleSet:
    """Rendered samples of one object type."""

    object_type: str
    snippets: list[str]  # snippet index -> name
    x: np.ndarray  # (N, RES, RES) uint8 ink
    snippet: np.ndarray  # (N,) int16 index into `snippets`
    u: np.ndarray  # (N, P) float32 normalised parameters (NaN past the snippet's count)
    failures: int = 0

    def __len__(self) -> int:
        return len(self.snippet)

    def inputs(self, idx: Any = slice(None)) -> np.ndarray:
        return self.x[idx].astype(np.float32) / 255.0


def stage_view(stage: StageSpec, model: Any, size: tuple[int, int] | None = None,
               style: DrawStyle | None = None):  # noqa: ANN201
    """The view a stage model is drawn through (fit framing: framed on the model itself)."""
    cam_stage = stage
    if style is not None and (style.pitch_offset or style.yaw_offset):
        from dataclasses import replace

        cam_stage = replace(stage, pitch=stage.pitch + style.pitch_offset, yaw=stage.yaw + style.yaw_offset)
    size = size or stage.canvas_size()
    if stage.framing == "fit":
        return cam_stage.camera().resolve(model.vertices, size)
    return cam_stage.camera().resolve(stage.frame_points(), size)


def render_input(stage: StageSpec, model: Any, style: DrawStyle, size: tuple[int, int] | None = None,
                 supersample: int = 2) -> np.ndarray:
    """The network input (RES x RES float) of a stage model drawn in `style`."""
    ink = draw(model, stage_view(stage, model, size, style), style, stage.host_box(), supersample=supersample)
    return to_input(ink, stage.framing)


def quick_size(stage: StageSpec, short: int = RES) -> tuple[int, int]:
    """The canvas of the refinement score: shorter side `short` pixels (an elongated canvas
    keeps its long side's detail, which the square network input squeezes). Proposals are
    drawn at this size without supersampling, cheaper than a training render."""
    if stage.framing == "fit":
        return (short, short)
    w, h = stage.canvas_size()
    k = short / min(w, h)
    return max(short, int(round(w * k))), max(short, int(round(h * k)))


def score_image(ink: np.ndarray, stage: StageSpec, short: int = RES) -> np.ndarray:
    """The sketch (or a proposal's drawing) at the score canvas size (anchor framing) or
    normalised like the network input (fit framing), as grey ink."""
    if stage.framing == "fit":
        return to_input(ink, "fit", short)
    return level(resize(ink, quick_size(stage, short)))


def line_mask(ink: np.ndarray, stage: StageSpec, short: int = RES) -> np.ndarray:
    """The line pixels of a drawing at the score canvas (bool).

    Lines are found at the drawing's own resolution, then pooled: a score pixel is a line pixel
    when a line covers a fifth of it. (Thresholding the resized grey image instead loses thin
    lines: a 1 px pen on a 184 px canvas is 0.7 px at 128 px, grey, and breaks into dashes
    below 0.5, which made sketches drawn with a fine pen score near 0 against their own model.)
    """
    mask = (level(ink) > 0.5).astype(np.float32)
    if stage.framing == "fit":
        return to_input(mask, "fit", short) > 0.2
    size = quick_size(stage, short)
    if mask.shape[::-1] == tuple(size):
        return mask > 0.5
    return resize(mask, size) > 0.2


# ------------------------------------------------------------------------------------------
def sample_drawing(deriver: StageDeriver, info: Any, rng: np.random.Generator, style_kind: str,
                   test_kind: str | None) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """One sample of a snippet: (network input, normalised parameters, the drawing on the full
    stage canvas), or None when MAX_ATTEMPTS parameter draws build nothing visible. The canvas
    drawing is what a user's image is: the refinement's target (benchmarks/bench_sketch.py)."""
    from grammarkit.errors import GrammarkitError

    stage = deriver.stage
    for _ in range(MAX_ATTEMPTS):
        u = rng.random(len(info.params))
        values = {p.name: p.value(x) for p, x in zip(info.params, u)}
        try:
            model = deriver.derive(info.name, values)
        except GrammarkitError:
            continue  # a parameter combination the snippet cannot build: draw again
        style = test_style(test_kind, rng) if test_kind else training_style(rng, style_kind)
        ink = draw(model, stage_view(stage, model, None, style), style, stage.host_box())
        x = to_input(ink, stage.framing)  # = render_input(stage, model, style)
        if (x > 0.5).sum() < 8:
            continue  # nothing visible (e.g. everything hidden): not a usable sketch
        return x, u.astype(np.float32), ink
    return None


def _sample_one(deriver: StageDeriver, info: Any, rng: np.random.Generator, style_kind: str,
                test_kind: str | None) -> tuple[np.ndarray, np.ndarray] | None:
    got = sample_drawing(deriver, info, rng, style_kind, test_kind)
    return None if got is None else (got[0], got[1])


def _init_state(library_src: Any, stage_dict: dict) -> StageDeriver:
    """Executor session state: the library and the stage grammar compiled once per process."""
    from .library import load_library

    return StageDeriver(load_library(library_src), StageSpec.from_dict(stage_dict))


def _render_task(deriver: StageDeriver, task: tuple) -> tuple:
    """One sample: (snippet index, sample index, input image or None, parameters or None)."""
    ti, si, name, i, seed, style_kind, test_kind = task
    rng = np.random.default_rng([seed, ti, si, i])
    got = _sample_one(deriver, deriver.library.snippets[name], rng, style_kind, test_kind)
    if got is None:
        return si, i, None, None
    img = np.clip(np.round(got[0] * 255.0), 0, 255).astype(np.uint8)
    return si, i, img, got[1]


def cache_key(library: SnippetLibrary, stage: StageSpec, n: int, seed: int, style: str,
              test_kind: str | None) -> str:
    blob = json.dumps({"lib": library.hash, "stage": stage.to_dict(), "n": n, "seed": seed,
                       "style": style, "test": test_kind, "res": RES, "v": GENERATOR_VERSION},
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def generate(library: SnippetLibrary, stage: StageSpec, n: int, *, seed: int = 0,
             style: str = "sketchy", test_kind: str | None = None, cache: Path | None = DEFAULT_CACHE,
             workers: int = 1, progress: Progress | None = None) -> SampleSet:
    """`n` samples per snippet of the stage's type (from the cache when it has them)."""
    t = stage.object_type
    infos = library.snippets_of(t)
    names = [s.name for s in infos]
    ti = library.types.index(t)
    path = None
    if cache is not None:
        key = cache_key(library, stage, n, seed, style, test_kind)
        path = Path(cache) / f"{library.name}-{t}-{style}-{test_kind or 'train'}-{n}-{key}.npz"
        if path.is_file():
            try:
                with np.load(path) as z:
                    got = SampleSet(t, names, z["x"], z["snippet"], z["u"], int(z["failures"]))
                if progress:
                    progress(len(names) * n)
                return got
            except (OSError, KeyError, ValueError):
                pass  # unreadable cache entry: regenerate it
    tasks = [(ti, si, name, i, seed, style, test_kind) for si, name in enumerate(names) for i in range(n)]
    # The project's executor: results come back in task order whatever the number of workers
    # (and workers start only when the work repays their start-up).
    from grammarkit.run import LocalExecutor

    src = library.path if library.path else library.grammar
    results: list = []
    failures = 0
    with LocalExecutor(max(1, int(workers))) as ex:
        with ex.session(_init_state, src, stage.to_dict()) as session:
            for si, i, img, u in session.map(_render_task, tasks):
                if img is None:
                    failures += 1
                else:
                    results.append((si, i, img, u))
                if progress:
                    progress(1)
    results.sort(key=lambda r: (r[0], r[1]))
    P = max((len(s.params) for s in infos), default=0)
    x = np.zeros((len(results), RES, RES), dtype=np.uint8)
    sn = np.zeros(len(results), dtype=np.int16)
    u = np.full((len(results), max(P, 1)), np.nan, dtype=np.float32)
    for k, (si, _i, img, uu) in enumerate(results):
        x[k] = img
        sn[k] = si
        u[k, :len(uu)] = uu
    out = SampleSet(t, names, x, sn, u, failures)
    if path is not None:
        from grammarkit.fileio import atomic_output

        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, x=x, snippet=sn, u=u, failures=np.array(failures))
    return out


# ------------------------------------------------------------------------------------------
EXACT = DrawStyle(sketchy=False, width=2.0)


def _exact(deriver: StageDeriver, snippet: str, values: dict) -> np.ndarray | None:
    from grammarkit.errors import GrammarkitError

    try:
        model = deriver.derive(snippet, values)
    except GrammarkitError:
        return None
    return render_input(deriver.stage, model, EXACT)


def _same(a: np.ndarray | None, b: np.ndarray | None, tol: float = 0.004) -> bool:
    return a is not None and b is not None and float(np.abs(a - b).mean()) < tol


def identical_groups(library: SnippetLibrary, stage: StageSpec, trials: int = 4, seed: int = 0) -> list[list[str]]:
    """Snippet classes of a type: snippets whose drawings coincide (for the parameter values
    they share, within both ranges) form one group; the library's default snippet, or else the
    first in library order, represents it."""
    deriver = StageDeriver(library, stage)
    infos = library.snippets_of(stage.object_type)
    rng = np.random.default_rng(seed)
    parent = list(range(len(infos)))

    def find(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for a in range(len(infos)):
        for b in range(a + 1, len(infos)):
            A, B = infos[a], infos[b]
            if set(A.param_names) != set(B.param_names):
                continue  # different parameters: some value of one shows differently
            compared = 0
            equal = True
            for _ in range(trials * 3):
                if compared >= trials:
                    break
                vals = {}
                for p in A.params:
                    q = next(q for q in B.params if q.name == p.name)
                    lo, hi = max(p.lo, q.lo), min(p.hi, q.hi)
                    if hi <= lo:
                        break
                    vals[p.name] = float(rng.uniform(lo, hi))
                else:
                    ia, ib = _exact(deriver, A.name, vals), _exact(deriver, B.name, vals)
                    if ia is None or ib is None:
                        continue
                    compared += 1
                    if not _same(ia, ib):
                        equal = False
                        break
                    continue
                equal = False
                break
            if equal and compared >= 2:
                parent[find(b)] = find(a)
    groups: dict[int, list[str]] = {}
    for i, s in enumerate(infos):
        groups.setdefault(find(i), []).append(s.name)
    default = library.defaults.get(stage.object_type)
    out = []
    for members in groups.values():
        if default in members:
            members = [default] + [m for m in members if m != default]
        out.append(members)
    return out


def visible_params(library: SnippetLibrary, stage: StageSpec, snippet: str, trials: int = 6,
                   seed: int = 0) -> tuple[list[str], list[str]]:
    """(visible, hidden) parameter names of a snippet: a parameter is hidden when moving it
    across its range changes no drawing of `trials` random instances."""
    deriver = StageDeriver(library, stage)
    info = library.snippets[snippet]
    rng = np.random.default_rng([seed, 77])
    visible, hidden = [], []
    for j, p in enumerate(info.params):
        seen = False
        for _ in range(trials):
            u = rng.random(len(info.params))
            vals = {q.name: q.value(x) for q, x in zip(info.params, u)}
            lo = _exact(deriver, snippet, {**vals, p.name: p.value(0.05)})
            hi = _exact(deriver, snippet, {**vals, p.name: p.value(0.95)})
            if lo is not None and hi is not None and not _same(lo, hi, 1e-4):
                seen = True
                break
        (visible if seen else hidden).append(p.name)
    return visible, hidden


def equivalence_interval(deriver: StageDeriver, snippet: str, values: dict, name: str,
                         lo: float, hi: float, iters: int = 9) -> tuple[float, float]:
    """The interval of values of `name` (others fixed) that derive the same geometry as
    `values[name]`: a floor height only changes a facade when the number of floors changes.
    Found by bisection on the derived vertices (exact, no drawing)."""
    from grammarkit.errors import GrammarkitError

    def key(v: float) -> bytes | None:
        try:
            m = deriver.derive(snippet, {**values, name: v})
        except GrammarkitError:
            return None
        verts = np.round(np.asarray(m.vertices), 4)
        verts = verts[np.lexsort(verts.T[::-1])]
        return verts.tobytes()

    v0 = float(values[name])
    k0 = key(v0)
    ends = []
    for end in (lo, hi):
        if key(end) == k0:
            ends.append(end)
            continue
        a, b = v0, end  # same at a, different at b
        for _ in range(iters):
            mid = (a + b) / 2
            if key(mid) == k0:
                a = mid
            else:
                b = mid
        ends.append(a)
    return min(ends), max(ends)


def iter_batches(n: int, batch: int, rng: np.random.Generator) -> Iterable[np.ndarray]:
    order = rng.permutation(n)
    for k in range(0, n, batch):
        yield order[k:k + batch]


def split_indices(n: int, val_share: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng([seed, 991])
    order = rng.permutation(n)
    k = int(round(n * val_share))
    return np.sort(order[k:]), np.sort(order[:k])


def names_of(sets: Sequence[SampleSet]) -> list[str]:
    return [s.object_type for s in sets]
