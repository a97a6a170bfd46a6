"""Issues 30 and 31: bad images, pickle-bearing and tampered models files, a missing part-mesh
folder, and the training script's safe defaults. Every error names the file, no traceback."""
from __future__ import annotations

import importlib.util
import shutil

import pytest
from click.testing import CliRunner

from grammarkit.cli import main

from .conftest import LIBRARY, ROOT


def _recognize(*args):
    return CliRunner().invoke(main, ["recognize", *map(str, args)])


@pytest.fixture(scope="module")
def huge_png(tmp_path_factory):
    from PIL import Image

    p = tmp_path_factory.mktemp("img") / "huge.png"
    Image.new("1", (20_000, 20_000), 1).save(p)  # 400 megapixels, a few KB on disk
    return p


def test_a_huge_png_is_refused_naming_the_file(huge_png):
    r = _recognize(huge_png, "--type", "Roof")
    assert r.exit_code == 1 and "Traceback" not in r.output
    assert f"{huge_png}: image is 400 megapixels; a sketch may have at most 40 megapixels" in r.output


def test_a_large_image_below_pils_guard_is_refused_before_decoding(tmp_path):
    from PIL import Image

    from grammarkit_sketch.image import SketchError, load_ink

    p = tmp_path / "big.png"
    Image.new("1", (7_000, 7_000), 1).save(p)
    with pytest.raises(SketchError, match=r"big.png: image is 7000x7000 pixels \(49 megapixels\)"):
        load_ink(p)
    import numpy as np

    with pytest.raises(SketchError, match="<sketch>: image is 8000x6000 pixels"):
        load_ink(np.zeros((6000, 8000), np.uint8))


@pytest.mark.parametrize("damage", ["truncated", "garbled", "text", "empty"])
def test_damaged_images_are_clear_errors(tmp_path, damage):
    from PIL import Image

    ok = tmp_path / "ok.png"
    Image.new("L", (200, 200), 255).save(ok)
    data = ok.read_bytes()
    bad = tmp_path / f"{damage}.png"
    bad.write_bytes({"truncated": data[:90], "garbled": data[:60] + b"x" * 40 + data[100:],
                     "text": b"not an image at all\n", "empty": b""}[damage])
    r = _recognize(bad, "--type", "Roof")
    assert r.exit_code == 1 and "Traceback" not in r.output
    assert str(bad) in r.output and "image" in r.output


def test_a_pickle_bearing_models_file_is_refused_without_torchs_advice(tmp_path):
    pytest.importorskip("torch")
    import pickle

    from grammarkit_sketch.models import ModelFileError, load_models

    class Evil:
        def __reduce__(self):
            return (print, ("owned",))

    p = tmp_path / "evil.models"
    p.write_bytes(pickle.dumps({"format": "grammarkit-sketch-models", "x": Evil()}, protocol=2))
    with pytest.raises(ModelFileError) as info:
        load_models(p)
    text = str(info.value)
    assert text.startswith(f"{p}: refused: the file holds pickled Python objects")
    assert "weights_only" not in text and "trust" not in text
    r = _recognize(ROOT / "docs" / "images" / "sketch_roof.png", "--type", "Roof", "--models", p)
    assert r.exit_code == 1 and "weights_only" not in r.output and "Traceback" not in r.output


def test_a_missing_part_mesh_folder_is_named_not_called_a_changed_library(tmp_path):
    pytest.importorskip("torch")
    from grammarkit_sketch.library import load_library
    from grammarkit_sketch.models import ModelFileError, load_models

    lib = tmp_path / "library.grammar"
    shutil.copy(LIBRARY, lib)  # no parts/ folder beside it
    with pytest.raises(ModelFileError) as info:
        load_models(None, load_library(lib))
    text = str(info.value)
    assert "part mesh file(s) missing" in text and "parts/chimney.glb" in text
    assert "different version" not in text


def _tampered(tmp_path, edit):
    import torch

    from grammarkit_sketch.models import SHIPPED

    data = torch.load(SHIPPED, map_location="cpu", weights_only=True)
    edit(data)
    p = tmp_path / "tampered.models"
    torch.save(data, p)
    return p


def test_a_tampered_library_cannot_overwrite_the_shared_cached_copy(tmp_path):
    torch = pytest.importorskip("torch")
    from grammarkit_sketch.embedded import content_hash, embedded_library
    from grammarkit_sketch.models import ModelFileError, load_models

    cache = tmp_path / "cache"
    genuine = load_models()
    lib = embedded_library(genuine, cache=cache)
    shared = cache / "libraries" / content_hash(genuine.library_files)[:20]
    before = {p: p.read_bytes() for p in shared.rglob("*") if p.is_file()}
    assert lib.path and str(shared) in str(lib.path)

    def swap(data):  # same claimed hash, other bytes: a grammar that does not parse
        data["library_files"]["library.grammar"] = torch.frombuffer(
            bytearray(b"grammar broken\nStart --> ((\n"), dtype=torch.uint8).clone()

    bad = load_models(_tampered(tmp_path, swap))
    assert bad.library_hash == genuine.library_hash
    with pytest.raises(ModelFileError, match="the library carried in the models file is damaged"):
        embedded_library(bad, cache=cache)
    after = {p: p.read_bytes() for p in shared.rglob("*") if p.is_file()}
    assert after == before  # the shared copy is untouched


def _script():
    path = ROOT / "plugins" / "sketch" / "scripts" / "train_shipped.py"
    spec = importlib.util.spec_from_file_location("train_shipped", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_train_shipped_needs_an_output_and_never_defaults_to_the_shipped_file(tmp_path, capsys):
    script = _script()
    with pytest.raises(SystemExit):
        script.parse([])  # -o is required
    assert "-o/--output" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.parse(["-o", str(script.SHIPPED)])
    assert "--replace-shipped" in capsys.readouterr().err
    args = script.parse(["-o", str(script.SHIPPED), "--replace-shipped"])
    assert args.output == script.SHIPPED


def test_train_shipped_quick_settings_and_overrides(tmp_path):
    script = _script()
    quick = script.settings_of(script.parse(["-o", str(tmp_path / "m.pt"), "--quick"]))
    assert quick == script.QUICK and quick["samples"] < script.SAMPLES
    full = script.settings_of(script.parse(["-o", str(tmp_path / "m.pt"), "--samples", "300",
                                            "--cls-epochs", "5"]))
    assert full == {"samples": 300, "classifier_epochs": script.CLASSIFIER_EPOCHS,
                    "regressor_epochs": script.REGRESSOR_EPOCHS, "cls_samples": script.CLS_SAMPLES,
                    "cls_epochs": 5}
    cmd = script.train_args(tmp_path / "m.pt", 1, 1, quick, "Roof")
    assert cmd[cmd.index("--samples") + 1] == "200" and cmd[-2:] == ["--types", "Roof"]
    assert "--classifiers-only" not in cmd
    # step 2: the classifiers alone, on augmented drawings, reading what CLS_INPUT says
    cmd = script.train_args(tmp_path / "m.pt", 1, 1, quick, "Roof", classifiers=True)
    assert cmd[cmd.index("--samples") + 1] == str(script.QUICK["cls_samples"])
    assert cmd[cmd.index("--style") + 1] == "augmented" and "--classifiers-only" in cmd
    assert cmd[cmd.index("--classifier-input") + 1] == script.CLS_INPUT


def test_train_shipped_regressors_from_must_exist(tmp_path, capsys):
    script = _script()
    with pytest.raises(SystemExit):
        script.parse(["-o", str(tmp_path / "m.pt"), "--regressors-from", str(tmp_path / "none.pt")])
    assert "no such models file" in capsys.readouterr().err


def test_train_shipped_streams_progress_lines(capsys):
    import sys

    script = _script()
    code = script.run_streaming([sys.executable, "-c", "print('epoch 1'); print('epoch 2')"], "Roof")
    out = capsys.readouterr().out.splitlines()
    assert code == 0 and out[0].endswith("Roof: started") and out[-1].endswith("Roof: finished (exit 0)")
    assert any(line.endswith("Roof: epoch 1") for line in out)


def test_swapped_network_weights_name_the_file(tmp_path):
    pytest.importorskip("torch")
    from grammarkit_sketch.models import ModelFileError, load_models
    from grammarkit_sketch.recognizer import get_recognizer

    def swap(data):  # Roof's classifier (more classes) in Ledge's place
        data["types"]["Ledge"]["classifier"] = data["types"]["Roof"]["classifier"]

    p = _tampered(tmp_path, swap)
    rec = get_recognizer(p)
    r = _recognize(ROOT / "docs" / "images" / "sketch_roof.png", "--type", "Ledge", "--models", p)
    assert r.exit_code == 1 and "Traceback" not in r.output
    with pytest.raises(ModelFileError, match=f"{p}: the models file holds networks of another layout"):
        rec.logits(load_models(p).types["Ledge"], __import__("numpy").zeros((128, 128), "float32"))
