"""Training the recognizer of a library: per object type, one snippet classifier and one
parameter regressor per snippet (Nishida et al. 2016, s. 5), on CPU.

`train(library, ...)` builds (or reads from the cache) the training renders, finds the
drawing-identical snippet groups and the parameters a drawing does not show, trains every
network with Adam, keeps the epoch with the best validation score, and returns `SketchModels`
ready to save. Same library, settings and seed give the same weights.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .dataset import DEFAULT_CACHE, SampleSet, generate, identical_groups, split_indices, visible_params
from .library import SnippetLibrary, load_library
from .models import RegressorModel, SketchModels, TypeModel
from .nets import build_classifier, build_regressor, count_parameters, require_torch
from .stages import StageSpec, default_stage
from .strokes import classifier_input


@dataclass
class TrainConfig:
    samples: int = 1200  # training + validation renders per snippet
    val_share: float = 0.1
    classifier_epochs: int = 14
    regressor_epochs: int = 30
    batch: int = 64
    lr: float = 2e-3
    width: int = 16
    style: str = "sketchy"  # "sketchy" (the paper's) or "plain" (Table 3's comparison)
    seed: int = 0
    threads: int = 1
    workers: int = 1  # processes rendering the training set
    types: list[str] | None = None  # object types to train (default: all)
    regressors: bool = True  # False: classifiers only (e.g. to compare training styles)
    # what the classifiers read: "as-drawn" (the paper) or "centre-lines" (strokes.py: every
    # line thinned to one pixel, so the pen's width does not matter), for every type or per
    # type ({"Roof": "centre-lines"}; types not named read the drawing as drawn)
    classifier_input: str | dict[str, str] = "as-drawn"

    def input_of(self, object_type: str) -> str:
        """What the classifier of `object_type` reads."""
        if isinstance(self.classifier_input, dict):
            named = {k.lower(): v for k, v in self.classifier_input.items()}
            return named.get(object_type.lower(), "as-drawn")
        return self.classifier_input
    cache: Path | None = DEFAULT_CACHE
    stages: dict[str, StageSpec] = field(default_factory=dict)  # overrides of default_stage

    def to_dict(self) -> dict:
        return {"samples": self.samples, "val_share": self.val_share,
                "classifier_epochs": self.classifier_epochs, "regressor_epochs": self.regressor_epochs,
                "batch": self.batch, "lr": self.lr, "width": self.width, "style": self.style,
                "seed": self.seed, "regressors": self.regressors,
                "classifier_input": self.classifier_input}


class Reporter:
    """Progress callbacks: `task(description, total)` returns an `advance(n, info="")`."""

    def task(self, description: str, total: int) -> Callable[..., None]:
        return lambda n=1, info="": None

    def note(self, message: str) -> None:
        pass


def _train_net(net: Any, x: np.ndarray, target: np.ndarray, val: tuple[np.ndarray, np.ndarray],
               loss_kind: str, epochs: int, cfg: TrainConfig, advance: Callable[..., None],
               seed: int) -> tuple[dict, float]:
    """Adam with a cosine learning-rate decay; returns the best state on the validation set
    and its score (accuracy for classifiers, RMSE for regressors)."""
    torch = require_torch()
    torch.manual_seed(seed)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr, weight_decay=1e-5)
    steps = epochs * int(np.ceil(len(x) / cfg.batch))
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=cfg.lr, total_steps=max(steps, 1),
                                                pct_start=0.15)
    xt = torch.from_numpy(x)
    yt = torch.from_numpy(target)
    vx = torch.from_numpy(val[0])
    vy = torch.from_numpy(val[1])
    rng = np.random.default_rng([seed, 5])
    best_state, best = None, None
    for epoch in range(epochs):
        net.train()
        order = rng.permutation(len(x))
        for k in range(0, len(order), cfg.batch):
            idx = torch.from_numpy(order[k:k + cfg.batch])
            xb = xt[idx].float().div_(255.0).unsqueeze(1)
            out = net(xb)
            if loss_kind == "ce":
                loss = torch.nn.functional.cross_entropy(out, yt[idx].long())
            else:
                yb = yt[idx]
                mask = ~torch.isnan(yb)
                loss = ((out - torch.nan_to_num(yb)) ** 2)[mask].mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
        score = _evaluate(net, vx, vy, loss_kind)
        better = best is None or (score > best if loss_kind == "ce" else score < best)
        if better:
            best = score
            best_state = {k: v.detach().clone() for k, v in net.state_dict().items()}
        advance(1, f"{'acc' if loss_kind == 'ce' else 'rmse'} {score:.3f}")
    return best_state, float(best)


def _evaluate(net: Any, vx: Any, vy: Any, loss_kind: str) -> float:
    torch = require_torch()
    net.eval()
    outs = []
    with torch.no_grad():
        for k in range(0, len(vx), 256):
            outs.append(net(vx[k:k + 256].float().div(255.0).unsqueeze(1)))
    out = torch.cat(outs) if outs else torch.zeros((0, 1))
    if loss_kind == "ce":
        return float((out.argmax(1) == vy.long()).float().mean()) if len(vy) else 0.0
    mask = ~torch.isnan(vy)
    return float(torch.sqrt(((out - torch.nan_to_num(vy)) ** 2)[mask].mean())) if mask.any() else 0.0


def train_type(library: SnippetLibrary, stage: StageSpec, cfg: TrainConfig, reporter: Reporter,
               data: SampleSet | None = None) -> TypeModel:
    t = stage.object_type
    infos = library.snippets_of(t)
    if data is None:
        advance = reporter.task(f"{t}: rendering {len(infos)} x {cfg.samples} sketches",
                                len(infos) * cfg.samples)
        data = generate(library, stage, cfg.samples, seed=cfg.seed, style=cfg.style, cache=cfg.cache,
                        workers=cfg.workers, progress=lambda n: advance(n))
    if data.failures:
        reporter.note(f"{t}: {data.failures} sample(s) could not be derived after retries and were left out")
    groups = identical_groups(library, stage, seed=cfg.seed)
    for g in groups:
        if len(g) > 1:
            reporter.note(f"{t}: {', '.join(g)} draw identically: one class, recognised as {g[0]}")
    group_of = {name: gi for gi, g in enumerate(groups) for name in g}
    labels = np.array([group_of[data.snippets[i]] for i in data.snippet], dtype=np.int64)
    tr, va = split_indices(len(data), cfg.val_share, cfg.seed)
    metrics: dict[str, Any] = {"samples": len(data), "classes": len(groups),
                               "classifier_input": cfg.input_of(t)}
    xc = classifier_input(data.x, cfg.input_of(t))

    classifier_state: dict = {}
    torch = require_torch()
    if len(groups) > 1:
        torch.manual_seed(cfg.seed)  # initial weights from the seed: same seed, same networks
        net = build_classifier(len(groups), cfg.width)
        advance = reporter.task(f"{t}: classifier ({count_parameters(net):,} weights, "
                                f"{len(groups)} classes)", cfg.classifier_epochs)
        classifier_state, acc = _train_net(net, xc[tr], labels[tr], (xc[va], labels[va]), "ce",
                                           cfg.classifier_epochs, cfg, advance, cfg.seed)
        metrics["val_accuracy"] = round(acc, 4)
    else:  # one class: nothing to choose (the classifier still exists, so files look alike)
        classifier_state = build_classifier(1, cfg.width).state_dict()
        metrics["val_accuracy"] = 1.0

    regressors: dict[str, RegressorModel] = {}
    for si, info in enumerate(infos):
        if not info.params or not cfg.regressors:
            continue
        visible, hidden = visible_params(library, stage, info.name, seed=cfg.seed)
        if hidden:
            reporter.note(f"{info.name}: {', '.join(hidden)} never change(s) the drawing; kept at the default")
        if not visible:
            regressors[info.name] = RegressorModel([], hidden, {}, cfg.width)
            continue
        cols = [info.param_names.index(v) for v in visible]
        rows = np.flatnonzero(data.snippet == si)
        rtr = np.intersect1d(rows, tr)
        rva = np.intersect1d(rows, va)
        target = data.u[:, cols]
        torch.manual_seed(cfg.seed + si + 1)
        net = build_regressor(len(visible), cfg.width)
        advance = reporter.task(f"{t}: regressor {info.name} ({len(visible)} params)", cfg.regressor_epochs)
        state, rmse = _train_net(net, data.x[rtr], target[rtr], (data.x[rva], target[rva]), "mse",
                                 cfg.regressor_epochs, cfg, advance, cfg.seed + si + 1)
        regressors[info.name] = RegressorModel(visible, hidden, state, cfg.width)
        metrics[f"val_rmse.{info.name}"] = round(rmse, 4)
    return TypeModel(stage, groups, classifier_state, regressors, cfg.width, metrics)


def fine_tune_classifier(library: SnippetLibrary, tm: TypeModel, cfg: TrainConfig,
                         reporter: Reporter | None = None, input_kind: str | None = None) -> TypeModel:
    """The type's classifier trained further from its current weights on `cfg.samples` new
    renders per snippet in `cfg.style` (e.g. "augmented"), `cfg.classifier_epochs` epochs at
    learning rate `cfg.lr`; the epoch with the best validation accuracy is kept, unless
    the starting weights score better on those renders (then they stay). The regressors are not touched. A cheaper way to robustness than
    retraining from scratch (issue 30). `input_kind` ("as-drawn" or "centre-lines"): what the
    tuned classifier reads (default: what it read before); the trained weights are then only
    the starting point: they stay (with the input they read) if, reading their own input,
    they score better on the validation renders."""
    torch = require_torch()
    reporter = reporter or Reporter()
    if len(tm.classes) < 2:
        return tm
    t = tm.stage.object_type
    advance = reporter.task(f"{t}: rendering {cfg.samples} {cfg.style} sketches per snippet",
                            len(library.snippets_of(t)) * cfg.samples)
    data = generate(library, tm.stage, cfg.samples, seed=cfg.seed, style=cfg.style, cache=cfg.cache,
                    workers=cfg.workers, progress=lambda n: advance(n))
    group_of = {name: gi for gi, g in enumerate(tm.classes) for name in g}
    labels = np.array([group_of[data.snippets[i]] for i in data.snippet], dtype=np.int64)
    tr, va = split_indices(len(data), cfg.val_share, cfg.seed)
    before = tm.metrics.get("classifier_input", "as-drawn")
    kind = input_kind or before
    xc = classifier_input(data.x, kind)
    torch.manual_seed(cfg.seed)
    net = build_classifier(len(tm.classes), tm.width)
    net.load_state_dict({k: (v.float() if v.is_floating_point() else v) for k, v in tm.classifier.items()})
    vy = torch.from_numpy(labels[va])
    start = _evaluate(net, torch.from_numpy(classifier_input(data.x[va], before)), vy, "ce")
    advance = reporter.task(f"{t}: fine-tuning the classifier (start: acc {start:.3f})", cfg.classifier_epochs)
    state, acc = _train_net(net, xc[tr], labels[tr], (xc[va], labels[va]), "ce",
                            cfg.classifier_epochs, cfg, advance, cfg.seed)
    metrics = dict(tm.metrics)
    metrics["fine_tune"] = {"style": cfg.style, "samples": cfg.samples, "epochs": cfg.classifier_epochs,
                            "lr": cfg.lr, "seed": cfg.seed, "val_accuracy_before": round(start, 4),
                            "val_accuracy_after": round(max(acc, start), 4), "input": kind}
    if acc < start:  # a tie goes to the tuned weights: they have seen the perturbations
        metrics["fine_tune"]["input"] = before
        return replace(tm, metrics=metrics)
    metrics["classifier_input"] = kind
    return replace(tm, classifier=state, metrics=metrics, net=None)


def fine_tune_regressors(library: SnippetLibrary, tm: TypeModel, cfg: TrainConfig,
                         reporter: Reporter | None = None) -> TypeModel:
    """The type's parameter regressors trained further from their current weights on
    `cfg.samples` renders per snippet in `cfg.style` (the same renders, from the cache, as
    `fine_tune_classifier` with the same settings), `cfg.regressor_epochs` epochs at learning
    rate `cfg.lr` in batches of `cfg.batch`. Each regressor keeps the epoch with the best
    validation RMSE on those renders, or its starting weights when they score better (issue
    30: the regressors had only seen the training pen, upright and through the exact camera)."""
    torch = require_torch()
    reporter = reporter or Reporter()
    t = tm.stage.object_type
    infos = library.snippets_of(t)
    advance = reporter.task(f"{t}: rendering {cfg.samples} {cfg.style} sketches per snippet",
                            len(infos) * cfg.samples)
    data = generate(library, tm.stage, cfg.samples, seed=cfg.seed, style=cfg.style, cache=cfg.cache,
                    workers=cfg.workers, progress=lambda n: advance(n))
    tr, va = split_indices(len(data), cfg.val_share, cfg.seed)
    regressors, metrics, changed = dict(tm.regressors), dict(tm.metrics), []
    for si, info in enumerate(infos):
        reg = tm.regressors.get(info.name)
        if reg is None or not reg.params or info.name not in data.snippets:
            continue
        si_data = data.snippets.index(info.name)
        rows = np.flatnonzero(data.snippet == si_data)
        rtr, rva = np.intersect1d(rows, tr), np.intersect1d(rows, va)
        if len(rtr) == 0 or len(rva) == 0:
            continue
        target = data.u[:, [info.param_names.index(v) for v in reg.params]]
        torch.manual_seed(cfg.seed + si + 1)
        net = build_regressor(len(reg.params), reg.width)
        net.load_state_dict({k: (v.float() if v.is_floating_point() else v) for k, v in reg.state.items()})
        vx, vy = torch.from_numpy(data.x[rva]), torch.from_numpy(target[rva])
        start = _evaluate(net, vx, vy, "mse")
        step = reporter.task(f"{t}: fine-tuning regressor {info.name} (start: rmse {start:.3f})",
                             cfg.regressor_epochs)
        state, rmse = _train_net(net, data.x[rtr], target[rtr], (data.x[rva], target[rva]), "mse",
                                 cfg.regressor_epochs, cfg, step, cfg.seed + si + 1)
        metrics[f"fine_tune_rmse.{info.name}"] = [round(start, 4), round(min(rmse, start), 4)]
        if rmse < start:
            regressors[info.name] = replace(reg, state=state, net=None)
            changed.append(info.name)
    metrics["fine_tune_regressors"] = {"style": cfg.style, "samples": cfg.samples,
                                       "epochs": cfg.regressor_epochs, "lr": cfg.lr,
                                       "batch": cfg.batch, "seed": cfg.seed, "changed": changed}
    return replace(tm, regressors=regressors, metrics=metrics)


def train(library: Any, cfg: TrainConfig | None = None, reporter: Reporter | None = None) -> SketchModels:
    """Train the recognizer of every (or the chosen) object type of a library."""
    torch = require_torch()
    cfg = cfg or TrainConfig()
    reporter = reporter or Reporter()
    library = load_library(library)
    torch.set_num_threads(max(1, int(cfg.threads)))
    types = [library.check_type(t) for t in cfg.types] if cfg.types else list(library.types)
    t0 = time.perf_counter()
    out: dict[str, TypeModel] = {}
    for t in types:
        stage = cfg.stages.get(t) or default_stage(library, t)
        out[t] = train_type(library, stage, cfg, reporter)
    from .embedded import library_files

    files = library_files(library)
    meta = {"config": cfg.to_dict(), "seconds": round(time.perf_counter() - t0, 1),
            "torch": str(torch.__version__), "library_file": Path(library.path).name if files else None}
    return SketchModels(library.hash, library.name, out, meta, library_files=files)
