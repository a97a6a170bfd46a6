"""A third-party plugin installed for real is used with no change to grammarkit; broken ones are
reported by name and do not break unrelated commands."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "third_party_plugin"

GRAMMAR = """\
attr t = 0.5 @range(0, 1)
Lot --> footprint(rect(10, 8)) extrude(lerp(3, 9, t)) twist(30, axis=x) Mass.
"""
TILING = """\
part Tower = box(2, 2, 6)
constraint symmetric(axis=x)
"""


def _pip_install(src: Path, target: Path) -> None:
    base = [sys.executable, "-m", "pip", "install", "--no-deps", "--disable-pip-version-check",
            "--quiet", "--target", str(target)]
    # Fast path without build isolation (needs setuptools + wheel here); otherwise let pip
    # fetch the build backend into an isolated environment.
    attempts = [base + ["--no-build-isolation", str(src)], base + [str(src)]]
    outputs = []
    for cmd in attempts:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
        if r.returncode == 0:
            return
        outputs.append(r.stdout + r.stderr)
        shutil.rmtree(target, ignore_errors=True)
    pytest.fail("could not install the fixture plugin:\n" + "\n---\n".join(outputs))


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("plugin")
    src = root / "src"
    shutil.copytree(FIXTURE, src)  # pip builds in-tree: keep the fixture folder clean
    target = root / "site"
    _pip_install(src, target)
    assert (target / "gk_thirdparty" / "plugin.py").is_file()
    # A broken plugin: its entry point names a module that raises on import, and another
    # plugin whose hook raises. Both are plain installed metadata, as pip would write it.
    broken = root / "broken"
    (broken / "broken_gk-1.0.dist-info").mkdir(parents=True)
    (broken / "broken_gk-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: broken-gk\nVersion: 1.0\n")
    (broken / "broken_gk-1.0.dist-info" / "entry_points.txt").write_text(
        "[grammarkit]\nbroken-import = broken_gk_import\nbroken-hook = broken_gk_hook\n")
    (broken / "broken_gk_import.py").write_text("raise RuntimeError('this plugin is broken')\n")
    (broken / "broken_gk_hook.py").write_text(
        "from grammarkit import hookimpl\n\n@hookimpl\ndef grammarkit_operations():\n"
        "    raise ValueError('hook exploded')\n")
    return root


def gk(args: list[str], *paths: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(str(p) for p in paths)
    return subprocess.run([sys.executable, "-c", "from grammarkit.cli import main; main()", *args],
                          capture_output=True, text=True, env=env, cwd=cwd, timeout=120)


def test_third_party_plugin_is_used_without_changes(site):
    g = site / "plugin.grammar"
    g.write_text(GRAMMAR)
    t = site / "tiling.grammar"
    t.write_text(TILING)
    # without the plugin, its operation and function are unknown ...
    r = gk(["check", str(g)], cwd=site)
    assert r.returncode == 1
    assert "unknown operation 'twist'" in r.stdout and "unknown function 'lerp'" in r.stdout
    # ... installed, they are checked like built-ins (named argument, axis choices included)
    r = gk(["check", str(g), str(t)], site / "site", cwd=site)
    assert r.returncode == 0, r.stdout + r.stderr
    bad = site / "bad.grammar"
    bad.write_text("Lot --> twist(30, axis=w) twist(1, spin=2) Mass.\nconstraint symmetric(axs=x)\n")
    r = gk(["check", str(bad)], site / "site", cwd=site)
    assert r.returncode == 1
    assert "argument 'axis' of twist must be x|y|z" in r.stdout
    assert "twist has no argument named 'spin'" in r.stdout
    assert "constraint symmetric has no argument named 'axs'" in r.stdout


def test_plugins_command_and_plugin_cli_command(site):
    r = gk(["plugins", "--json"], site / "site", cwd=site)
    assert r.returncode == 0, r.stderr
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    tp = infos["thirdparty"]
    assert (tp["distribution"], tp["version"], tp["ok"]) == ("gk-thirdparty", "0.3.1", True)
    assert tp["provides"] == {"operation": ["twist"], "function": ["lerp"],
                              "constraint": ["symmetric"], "command": ["hello-plugin"]}
    r = gk(["plugins"], site / "site", cwd=site)
    assert r.returncode == 0 and "thirdparty" in r.stdout and "gk-thirdparty" in r.stdout
    r = gk(["hello-plugin", "grammarkit"], site / "site", cwd=site)
    assert r.returncode == 0 and r.stdout.strip() == "hello grammarkit from gk-thirdparty"
    r = gk(["--help"], site / "site", cwd=site)
    assert "hello-plugin" in r.stdout


def test_broken_plugins_are_reported_and_do_not_break_commands(site):
    r = gk(["plugins", "--json"], site / "site", site / "broken", cwd=site)
    assert r.returncode == 0, r.stderr
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    imp = infos["broken-import"]
    assert not imp["ok"] and imp["distribution"] == "broken-gk"
    assert "RuntimeError: this plugin is broken" in imp["errors"][0]
    assert "hook exploded" in infos["broken-hook"]["errors"][0]
    assert infos["thirdparty"]["ok"] and infos["split-operations"]["ok"]
    r = gk(["plugins"], site / "site", site / "broken", cwd=site)
    assert r.returncode == 0 and "broken-import" in r.stdout and "problems" in r.stderr
    g = site / "ok.grammar"
    g.write_text(GRAMMAR)
    r = gk(["check", str(g)], site / "site", site / "broken", cwd=site)
    assert r.returncode == 0, r.stdout + r.stderr
