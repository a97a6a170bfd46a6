import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from grammarkit.cli import GrammarkitGroup
from grammarkit.cli.render import render
from grammarkit.geometry.exporters import export


@pytest.fixture
def cli():
    group = GrammarkitGroup(name="grammarkit", commands={"render": render})
    group._plugins_added = True  # only the command under test
    runner = CliRunner()
    return lambda *args: runner.invoke(group, ["render", *map(str, args)])


def test_render_mesh_file(tmp_path, building, cli):
    model = export(building, tmp_path / "b.glb")
    out = tmp_path / "b.png"
    result = cli(model, "-o", out, "--size", "200x120", "--style", "lines", "--yaw", "-30")
    assert result.exit_code == 0, result.output
    assert "wrote" in result.output
    img = Image.open(out)
    assert img.size == (200, 120)
    gray = np.asarray(img.convert("L"))
    assert (gray < 100).sum() > 200 and gray[0, 0] == 255


def test_render_options_transparent_ortho_sketchy(tmp_path, building, cli):
    model = export(building, tmp_path / "b.ply")
    out = tmp_path / "b.png"
    result = cli(model, "-o", out, "--size", "96", "--ortho", "--sketchy", "--seed", "3",
                 "--background", "none", "--line-color", "#ff0000")
    assert result.exit_code == 0, result.output
    arr = np.asarray(Image.open(out))
    assert arr.shape == (96, 96, 4) and arr[0, 0, 3] == 0
    red = (arr[..., 0] > 200) & (arr[..., 1] < 60) & (arr[..., 3] > 200)
    assert red.sum() > 20


def test_render_errors(tmp_path, building, cli):
    result = cli(tmp_path / "missing.glb", "-o", tmp_path / "x.png")
    assert result.exit_code == 1 and "missing.glb: mesh file not found" in result.output
    model = export(building, tmp_path / "b.stl")
    for args, message in [(["--size", "12by4"], "WIDTHxHEIGHT"),
                          (["--fov", "0"], "fov"),
                          (["--background", "notacolour"], "not a colour")]:
        result = cli(model, "-o", tmp_path / "x.png", *args)
        assert result.exit_code == 2 and message in result.output, result.output
    result = cli(model, "-o", tmp_path / "x.nope")
    assert result.exit_code == 2 and "unknown image format" in result.output
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.nope").exists()
