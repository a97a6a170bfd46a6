"""The plugin as grammarkit sees it, and `grammarkit train sketch` end to end (tiny sizes)."""
from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from grammarkit.cli import main

from .conftest import LIBRARY


def test_entry_point_registers_the_commands():
    from grammarkit.plugins import PluginManager

    pm = PluginManager()
    info = {i.name: i for i in pm.plugins()}["sketch"]
    assert info.ok and info.module == "grammarkit_sketch.plugin"
    assert info.provides == {"command": ["recognize", "sketch-session"], "train command": ["sketch"]}
    res = CliRunner().invoke(main, ["train", "--help"])
    assert res.exit_code == 0 and "sketch" in res.output


def test_importing_the_plugin_and_help_stay_light():
    code = ("import sys, grammarkit_sketch.plugin, grammarkit_sketch; "
            "from grammarkit.cli import main\n"
            "try:\n    main(['recognize', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m in ('torch', 'scipy') or m.startswith('grammarkit_sketch.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    # (numpy and trimesh come with grammarkit's own plugins; torch, scipy and our modules must not)
    assert out.strip().splitlines()[-1] == "['grammarkit_sketch.cli', 'grammarkit_sketch.plugin']"


def test_without_torch_the_commands_say_how_to_install_it(tmp_path):
    code = ("import sys; sys.modules['torch'] = None\n"
            "from grammarkit.cli import main\n"
            f"main(['recognize', {str(tmp_path / 'x.png')!r}, '--type', 'Roof'])")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 1
    assert "needs torch" in res.stderr and 'pip install "grammarkit[learning]"' in res.stderr
    assert "Traceback" not in res.stderr


def _train(tmp_path, name, *extra):
    out = tmp_path / name
    res = CliRunner().invoke(main, ["train", "sketch", "--library", str(LIBRARY), "-o", str(out),
                                    "--types", "Window", "--samples", "24", "--classifier-epochs", "2",
                                    "--regressor-epochs", "1", "--no-cache", *extra])
    assert res.exit_code == 0, res.output
    return out, res.output


def test_train_writes_a_loadable_deterministic_models_file(tmp_path, torch_or_skip):
    torch = torch_or_skip
    from grammarkit_sketch.models import load_models
    from grammarkit_sketch.recognizer import get_recognizer

    a, output = _train(tmp_path, "a.models")
    assert "Window: 4 classes" in output and "wrote" in output
    b, _ = _train(tmp_path, "b.models")
    ma, mb = load_models(a), load_models(b)
    assert list(ma.types) == ["Window"]
    wa, wb = ma.types["Window"], mb.types["Window"]
    assert wa.classes == [["window_simple"], ["window_framed"], ["window_mullion"], ["window_sill"]]
    for k, v in wa.classifier.items():
        assert torch.equal(v, wb.classifier[k]), k  # same seed, same weights
    assert set(wa.regressors) == {"window_simple", "window_framed", "window_mullion", "window_sill"}
    rec = get_recognizer(a, LIBRARY)
    with pytest.raises(Exception, match="no trained model for object type 'Roof'; models exist for: Window"):
        rec.models.type_model("Roof")
    # the file carries its library: no library path needed to use it
    assert get_recognizer(a).library.hash == rec.library.hash
    raw = torch.load(a, weights_only=True)  # plain data only: loads without running code
    assert raw["format"] == "grammarkit-sketch-models" and raw["version"] == 1


def test_train_refuses_bad_arguments(tmp_path):
    res = CliRunner().invoke(main, ["train", "sketch", "--library", str(tmp_path / "none.grammar"),
                                    "-o", str(tmp_path / "m"), "--samples", "24"])
    assert res.exit_code != 0 and "library file not found" in res.output
    res = CliRunner().invoke(main, ["train", "sketch", "--library", str(LIBRARY), "-o", str(tmp_path / "m"),
                                    "--types", "Chimney", "--samples", "24"])
    assert res.exit_code != 0 and "unknown object type 'Chimney'" in res.output
