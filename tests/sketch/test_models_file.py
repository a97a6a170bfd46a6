"""The models file: plain data loaded with weights_only, format version, library hash, damage."""
from __future__ import annotations

import pytest

from grammarkit.errors import GrammarkitError

from .conftest import LIBRARY

pytestmark = pytest.mark.usefixtures("torch_or_skip")


@pytest.fixture()
def small(library, stages):
    """Untrained networks in a models file's structure (enough to test the file itself)."""
    from grammarkit_sketch.embedded import library_files
    from grammarkit_sketch.models import RegressorModel, SketchModels, TypeModel
    from grammarkit_sketch.nets import build_classifier, build_regressor

    tm = TypeModel(stages["Ledge"], [["ledge_slab"], ["ledge_cornice"], ["ledge_balcony"]],
                   build_classifier(3).state_dict(),
                   {"ledge_slab": RegressorModel(["ledge_d"], [], build_regressor(1).state_dict())},
                   metrics={"val_accuracy": 0.5})
    return SketchModels(library.hash, library.name, {"Ledge": tm}, {"library_file": "library.grammar"},
                        library_files=library_files(library))


def test_round_trip_with_weights_only_loading(small, tmp_path, monkeypatch):
    import torch

    from grammarkit_sketch.models import load_models, save_models

    p = save_models(small, tmp_path / "m.models")
    calls = []
    real = torch.load

    def spy(*a, **kw):
        calls.append(kw.get("weights_only"))
        return real(*a, **kw)
    monkeypatch.setattr(torch, "load", spy)
    m = load_models(p)
    assert calls == [True]
    assert m.types["Ledge"].classes == small.types["Ledge"].classes
    assert m.types["Ledge"].stage == small.types["Ledge"].stage
    assert m.types["Ledge"].regressors["ledge_slab"].params == ["ledge_d"]
    assert set(m.library_files) == {"library.grammar", "parts/chimney.glb", "parts/dormer.glb"}
    # the networks rebuild from the stored weights (float16 on disk, float32 in use)
    net = m.types["Ledge"].network()
    assert next(net.parameters()).dtype == torch.float32


def test_the_carried_library_is_written_out_and_checked(small, tmp_path):
    from grammarkit_sketch.embedded import content_hash, embedded_library

    lib = embedded_library(small, cache=tmp_path)
    assert lib.hash == small.library_hash
    # the folder is named after the carried files' content, not the hash the file claims
    folder = tmp_path / "libraries" / content_hash(small.library_files)[:20]
    assert (folder / "parts" / "chimney.glb").is_file()
    assert embedded_library(small, cache=tmp_path).path == lib.path  # written once, reused


def _payload_edit(small, tmp_path, **changes):
    import torch

    from grammarkit_sketch.models import to_payload

    data = to_payload(small)
    data.update(changes)
    p = tmp_path / "edited.models"
    torch.save(data, p)
    return p


def test_format_version_and_header_are_checked(small, tmp_path):
    from grammarkit_sketch.models import ModelFileError, load_models

    with pytest.raises(ModelFileError, match="format version 7.*retrain"):
        load_models(_payload_edit(small, tmp_path, version=7))
    with pytest.raises(ModelFileError, match="no 'grammarkit-sketch-models' header"):
        load_models(_payload_edit(small, tmp_path, format="other"))
    with pytest.raises(ModelFileError, match="damaged sketch models file"):
        load_models(_payload_edit(small, tmp_path, types={"Ledge": {"stage": {}}}))


def test_code_in_a_models_file_is_not_run(tmp_path):
    import pickle

    from grammarkit_sketch.models import ModelFileError, load_models

    class Evil:
        def __reduce__(self):
            return (print, ("owned",))

    p = tmp_path / "evil.models"
    p.write_bytes(pickle.dumps({"format": "grammarkit-sketch-models", "x": Evil()}, protocol=2))
    with pytest.raises(ModelFileError, match="refused: the file holds pickled Python objects"):
        load_models(p)


def test_a_changed_library_is_refused_with_retrain(small, tmp_path):
    from grammarkit_sketch.library import load_library
    from grammarkit_sketch.models import ModelFileError

    changed = tmp_path / "lib.grammar"
    changed.write_text(LIBRARY.read_text().replace("attr ledge_d = 0.3 @range(0.1, 0.6)",
                                                   "attr ledge_d = 0.3 @range(0.1, 0.7)"))
    (tmp_path / "parts").symlink_to(LIBRARY.parent / "parts")
    with pytest.raises(ModelFileError, match="retrain: grammarkit train sketch --library"):
        small.check_library(load_library(changed))


def test_unknown_type_lists_the_trained_ones(small):
    with pytest.raises(GrammarkitError, match="no trained model for object type 'Roof'; models exist for: Ledge"):
        small.type_model("Roof")
    assert small.type_model("ledge") is small.types["Ledge"]


def test_files_of_separate_types_merge_into_one(small, library, stages):
    from dataclasses import replace

    from grammarkit_sketch.models import ModelFileError, TypeModel, merge_models
    from grammarkit_sketch.nets import build_classifier

    window = TypeModel(stages["Window"], [["window_simple"], ["window_framed"]], build_classifier(2).state_dict(), {})
    other = replace(small, types={"Window": window}, meta={**small.meta, "seconds": 2.0})
    merged = merge_models([replace(small, meta={**small.meta, "seconds": 1.0}), other])
    assert list(merged.types) == ["Ledge", "Window"] and merged.library_hash == library.hash
    assert merged.meta["seconds"] == 3.0
    with pytest.raises(ModelFileError, match="two of the files"):
        merge_models([small, small])
    with pytest.raises(ModelFileError, match="another library"):
        merge_models([small, replace(other, library_hash="0" * 64)])
    with pytest.raises(ModelFileError, match="other settings"):
        merge_models([small, replace(other, meta={"config": {"samples": 3}})])
