"""A third-party plugin installed for real is used with no change to grammarkit; broken ones are
reported by name and do not break unrelated commands."""
from __future__ import annotations

import base64
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
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


def _build_wheel(src: Path, out: Path) -> Path:
    """A wheel of the fixture straight from its pyproject.toml (name, version, entry points,
    packages): lets pip install it offline when no build backend with `wheel` is available."""
    meta = tomllib.loads((src / "pyproject.toml").read_text())
    project = meta["project"]
    name, version = project["name"], project["version"]
    dist = f"{name.replace('-', '_')}-{version}"
    files: dict[str, bytes] = {}
    for package in meta["tool"]["setuptools"]["packages"]:
        for f in sorted((src / package).rglob("*.py")):
            files[f.relative_to(src).as_posix()] = f.read_bytes()
    files[f"{dist}.dist-info/METADATA"] = (
        f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n").encode()
    files[f"{dist}.dist-info/WHEEL"] = (
        b"Wheel-Version: 1.0\nGenerator: grammarkit-tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n")
    eps = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items())
                  for group, entries in project.get("entry-points", {}).items())
    files[f"{dist}.dist-info/entry_points.txt"] = eps.encode()
    record = []
    for path, data in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{path},sha256={digest},{len(data)}")
    record.append(f"{dist}.dist-info/RECORD,,")
    files[f"{dist}.dist-info/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = out / f"{dist}-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as zf:
        for path, data in files.items():
            zf.writestr(path, data)
    return wheel


def _pip_install(src: Path, target: Path) -> None:
    base = [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index",
            "--disable-pip-version-check", "--quiet", "--target", str(target)]
    # 1. the package's own build backend, without build isolation (needs setuptools + wheel);
    # 2. otherwise a wheel made from its pyproject.toml (offline, no backend needed).
    outputs = []
    r = subprocess.run(base + ["--no-build-isolation", str(src)], capture_output=True, text=True,
                       timeout=240)
    if r.returncode == 0:
        return
    outputs.append(r.stdout + r.stderr)
    shutil.rmtree(target, ignore_errors=True)
    wheel = _build_wheel(src, src.parent)
    r = subprocess.run(base + [str(wheel)], capture_output=True, text=True, timeout=240)
    if r.returncode == 0:
        return
    outputs.append(r.stdout + r.stderr)
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


def test_broken_plugins_are_reported_and_do_not_break_commands(site):
    r = gk(["plugins", "--json"], site / "site", site / "broken", cwd=site)
    assert r.returncode == 0, r.stderr
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    imp = infos["broken-import"]
    assert not imp["ok"] and imp["distribution"] == "broken-gk"
    assert "RuntimeError: this plugin is broken" in imp["errors"][0]
    assert "hook exploded" in infos["broken-hook"]["errors"][0]
    assert infos["thirdparty"]["ok"] and infos["split-operations"]["ok"]
    g = site / "ok.grammar"
    g.write_text(GRAMMAR)
    r = gk(["check", str(g)], site / "site", site / "broken", cwd=site)
    assert r.returncode == 0, r.stdout + r.stderr
