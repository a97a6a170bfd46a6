"""The trained recognizer of one library: stages, snippet classes, network weights, and checks.

Saved with `torch.save` as plain dicts, lists, numbers, strings and tensors only, so that
loading uses `torch.load(weights_only=True)` (no code runs on load). Weights are stored as
float16 (half the size; recognition runs in float32). The file records the format version and
the hash of the library it was trained on: a library changed since training (a rule, a range,
a part mesh) is refused with a message saying to retrain.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from grammarkit.errors import GrammarkitError

from .library import SnippetLibrary
from .nets import build_classifier, build_regressor, require_torch
from .stages import StageSpec

FORMAT = "grammarkit-sketch-models"
VERSION = 1
SHIPPED = Path(__file__).with_name("weights") / "library.sketch.pt"


class ModelFileError(GrammarkitError):
    """A models file that cannot be used: names the file and says why (and what to do)."""


@dataclass
class RegressorModel:
    params: list[str]  # the visible parameters it estimates, in output order
    hidden: list[str]  # parameters a drawing does not show (kept at their defaults)
    state: dict
    width: int = 16
    net: Any = field(default=None, repr=False)
    source: str = field(default="", repr=False)  # the models file, for error messages

    def network(self) -> Any:
        if self.net is None:
            self.net = _load_net(build_regressor(len(self.params), self.width), self.state,
                                 self.source)
        return self.net


@dataclass
class TypeModel:
    """Everything recognised for one object type."""

    stage: StageSpec
    classes: list[list[str]]  # snippet groups; a group draws identically (first = representative)
    classifier: dict
    regressors: dict[str, RegressorModel]
    width: int = 16
    metrics: dict = field(default_factory=dict)
    net: Any = field(default=None, repr=False)
    source: str = field(default="", repr=False)  # the models file, for error messages

    def network(self) -> Any:
        if self.net is None:
            self.net = _load_net(build_classifier(len(self.classes), self.width), self.classifier,
                                 self.source)
        return self.net


@dataclass
class SketchModels:
    library_hash: str
    library_name: str
    types: dict[str, TypeModel]
    meta: dict = field(default_factory=dict)
    path: str | None = None
    library_files: dict[str, bytes] = field(default_factory=dict)  # see embedded.py

    def type_model(self, object_type: str) -> TypeModel:
        for t, m in self.types.items():
            if t.lower() == str(object_type).lower():
                return m
        have = ", ".join(self.types) or "none"
        raise ModelFileError(f"{self.path or 'the models'}: no trained model for object type "
                             f"{object_type!r}; models exist for: {have}", None,
                             hint="train one with `grammarkit train sketch --library ... -o ...`",
                             code="sketch-no-model")

    def check_library(self, library: SnippetLibrary) -> None:
        if library.hash != self.library_hash and library.missing_assets:
            files = ", ".join(str(m) for m in library.missing_assets)
            raise ModelFileError(
                f"{library.path or library.name}: part mesh file(s) missing: {files} (inserted by "
                f"the library's snippets); restore them next to the library (the models file "
                f"{self.path or ''} was trained with them)", None, code="sketch-missing-part")
        if library.hash != self.library_hash:
            raise ModelFileError(
                f"{self.path or 'the models'}: trained on a different version of library "
                f"{self.library_name!r} than {library.path or library.name!r} (the snippets, ranges "
                "or part meshes changed); retrain: grammarkit train sketch --library "
                f"{library.path or 'LIBRARY'} -o MODELS", None, code="sketch-retrain")


def _half(state: Mapping[str, Any]) -> dict:
    out = {}
    for k, v in state.items():
        out[k] = v.detach().to("cpu").half() if v.is_floating_point() else v.detach().to("cpu")
    return out


def _load_net(net: Any, state: Mapping[str, Any], source: str = "") -> Any:
    try:
        net.load_state_dict({k: (v.float() if v.is_floating_point() else v) for k, v in state.items()})
    except (RuntimeError, AttributeError) as exc:
        where = f"{source}: " if source else ""
        raise ModelFileError(f"{where}the models file holds networks of another layout than this grammarkit "
                             f"builds ({str(exc).splitlines()[0]}); retrain with grammarkit train sketch",
                             None, code="sketch-retrain") from None
    net.eval()
    for p in net.parameters():
        p.requires_grad_(False)
    return net


def _plain(value: Any) -> Any:
    """Only plain JSON-like values go into the file (weights_only loading refuses others)."""
    from grammarkit.jsonable import to_jsonable

    return to_jsonable(value)


def to_payload(models: SketchModels) -> dict:
    types = {}
    for t, m in models.types.items():
        types[t] = {
            "stage": m.stage.to_dict(), "classes": [list(c) for c in m.classes], "width": m.width,
            "classifier": _half(m.classifier), "metrics": _plain(m.metrics),
            "regressors": {s: {"params": list(r.params), "hidden": list(r.hidden), "width": r.width,
                               "state": _half(r.state)} for s, r in m.regressors.items()},
        }
    torch = require_torch()
    files = {rel: torch.frombuffer(bytearray(data), dtype=torch.uint8).clone()
             for rel, data in models.library_files.items()}
    return {"format": FORMAT, "version": VERSION, "library_hash": models.library_hash,
            "library_name": models.library_name, "meta": _plain(models.meta), "types": types,
            "library_files": files}


def save_models(models: SketchModels, path: str | Path) -> Path:
    """Write atomically (a temporary file, then a rename)."""
    from grammarkit.fileio import atomic_output

    torch = require_torch()
    path = Path(path)
    with atomic_output(path) as tmp:
        torch.save(to_payload(models), tmp)
    return path


def _unreadable(p: Path, exc: BaseException) -> str:
    """Why torch could not read `p`, in grammarkit's words: torch's own message for a file
    with pickled objects advises loading with weights_only=False, which would run the file's
    code, so it is never repeated."""
    import pickle

    text = str(exc)
    if isinstance(exc, pickle.UnpicklingError) or "weights_only" in text or "Weights only" in text:
        return (f"{p}: refused: the file holds pickled Python objects (code that would run when "
                "it is loaded), and a sketch models file holds only tensors and plain values; "
                "use a file written by `grammarkit train sketch`")
    first = text.splitlines()[0] if text else ""
    return f"{p}: not a sketch models file ({exc.__class__.__name__}: {first[:200]})"


def load_models(path: str | Path | None = None, library: SnippetLibrary | None = None) -> SketchModels:
    """Load a models file (default: the weights shipped for grammars/library.grammar), check its
    format version and, given a library, that it was trained on exactly that library."""
    torch = require_torch()
    p = Path(path) if path is not None else SHIPPED
    if not p.is_file():
        if path is None:
            raise ModelFileError(f"{p}: the shipped sketch models are missing from this install", None,
                                 hint="reinstall grammarkit, or train: grammarkit train sketch",
                                 code="sketch-no-models")
        raise ModelFileError(f"{p}: models file not found", None, code="sketch-no-models")
    try:
        data = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unpickling failure means "not our file"
        raise ModelFileError(_unreadable(p, exc), None, code="sketch-bad-models") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ModelFileError(f"{p}: not a sketch models file (no {FORMAT!r} header)", None,
                             code="sketch-bad-models")
    if data.get("version") != VERSION:
        raise ModelFileError(f"{p}: models file format version {data.get('version')!r}; this "
                             f"grammarkit reads version {VERSION}; retrain with grammarkit train sketch",
                             None, code="sketch-retrain")
    try:
        types = {}
        for t, d in data["types"].items():
            regs = {s: RegressorModel(list(r["params"]), list(r["hidden"]), r["state"], int(r["width"]),
                                      source=str(p))
                    for s, r in d["regressors"].items()}
            types[t] = TypeModel(StageSpec.from_dict(d["stage"]), [list(c) for c in d["classes"]],
                                 d["classifier"], regs, int(d["width"]), dict(d.get("metrics", {})),
                                 source=str(p))
        files = {str(rel): bytes(t.numpy().tobytes()) for rel, t in data.get("library_files", {}).items()}
        models = SketchModels(str(data["library_hash"]), str(data["library_name"]), types,
                              dict(data.get("meta", {})), str(p), files)
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{p}: damaged sketch models file ({exc.__class__.__name__}: {exc})",
                             None, code="sketch-bad-models") from None
    if library is not None:
        models.check_library(library)
    return models


def merge_models(parts: list[SketchModels]) -> SketchModels:
    """One models file from files trained on the same library for different object types
    (e.g. one process per type). Per-type training depends only on the type, the settings and
    the seed, so the merge equals a single run over all the types."""
    if not parts:
        raise ModelFileError("nothing to merge", None, code="sketch-bad-models")
    first = parts[0]
    types: dict[str, TypeModel] = {}
    for m in parts:
        if m.library_hash != first.library_hash:
            raise ModelFileError(f"{m.path or 'a models file'} was trained on another library than "
                                 f"{first.path or 'the first one'}; cannot merge", None, code="sketch-retrain")
        if (m.meta.get("config") or {}) != (first.meta.get("config") or {}):
            raise ModelFileError(f"{m.path or 'a models file'} was trained with other settings than "
                                 f"{first.path or 'the first one'}; cannot merge", None, code="sketch-bad-models")
        for t, tm in m.types.items():
            if t in types:
                raise ModelFileError(f"object type {t!r} is in two of the files to merge", None,
                                     code="sketch-bad-models")
            types[t] = tm
    meta = dict(first.meta)
    meta["seconds"] = round(sum(float(m.meta.get("seconds", 0.0)) for m in parts), 1)
    return SketchModels(first.library_hash, first.library_name, types, meta, None, dict(first.library_files))


def graft_regressors(classifiers: SketchModels, regressors: SketchModels) -> SketchModels:
    """The classifiers of one models file with the parameter regressors of another, trained on
    the same library with the same stages and classes (e.g. classifiers retrained on augmented
    drawings over regressors trained on many sketchy ones: train_shipped.py). The regressors'
    validation metrics come along; `meta["regressors_from"]` records their training settings."""
    if classifiers.library_hash != regressors.library_hash:
        raise ModelFileError(f"{regressors.path or 'the regressors'} were trained on another library than "
                             f"{classifiers.path or 'the classifiers'}; cannot combine them", None,
                             code="sketch-retrain")
    types: dict[str, TypeModel] = {}
    for t, tm in classifiers.types.items():
        src = regressors.types.get(t)
        if src is None or src.stage != tm.stage or src.classes != tm.classes:
            raise ModelFileError(f"{regressors.path or 'the regressors'}: object type {t!r} is missing or "
                                 f"has other stages or classes than in {classifiers.path or 'the classifiers'}",
                                 None, code="sketch-bad-models")
        metrics = {k: v for k, v in tm.metrics.items() if not k.startswith("val_rmse.")}
        metrics.update({k: v for k, v in src.metrics.items() if k.startswith("val_rmse.")})
        types[t] = TypeModel(tm.stage, tm.classes, tm.classifier, dict(src.regressors), tm.width, metrics)
    meta = dict(classifiers.meta)
    meta["regressors_from"] = {"config": regressors.meta.get("config"),
                               "seconds": regressors.meta.get("seconds")}
    return SketchModels(classifiers.library_hash, classifiers.library_name, types, meta, None,
                        dict(classifiers.library_files))
