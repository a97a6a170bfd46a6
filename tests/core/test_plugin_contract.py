"""The plugin contract through pluggy (issue 8): call order, name clashes, built-ins never
replaced, results validated against the spec types, broken plugins isolated and reported,
plugins that print or exit, and turning plugins off."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from grammarkit import hookimpl
from grammarkit.errors import PluginError
from grammarkit.plugins import PluginManager
from grammarkit.registry import FunctionSpec, OperationSpec, Param

ROOT = Path(__file__).resolve().parents[2]
GRAMMAR = ROOT / "grammars" / "paris.grammar"


def _op(name: str = "twist") -> OperationSpec:
    return OperationSpec(name, (Param("angle"),), doc="test op", apply=lambda ctx, s, a, b: s)


class Plain:
    @hookimpl
    def grammarkit_operations(self):
        return [_op()]


class First:
    @hookimpl(tryfirst=True)
    def grammarkit_operations(self):
        return [_op()]


class Last:
    @hookimpl(trylast=True)
    def grammarkit_operations(self):
        return [_op()]


def test_pluggy_call_order_decides_between_plugins():
    pm = PluginManager(load_entry_points=False)
    pm.register(First(), "first")
    pm.register(Plain(), "plain")  # registered later: called before other plain ones, not before tryfirst
    pm.register(Last(), "last")
    assert pm.operations()["twist"].plugin == "first"
    pm = PluginManager(load_entry_points=False)
    pm.register(Last(), "last")
    pm.register(Plain(), "plain")
    assert pm.operations()["twist"].plugin == "plain"
    errors = {i.name: i.errors for i in pm.plugins()}
    assert any("'plain'" in e for e in errors["last"]) and any("'last'" in e for e in errors["plain"])


class ReplacesSplit:
    @hookimpl(tryfirst=True)
    def grammarkit_operations(self):
        return [_op("split"), _op("wobble")]


def test_a_builtin_is_never_replaced_whatever_the_order():
    pm = PluginManager()
    pm.register(ReplacesSplit(), "aaa-sneaky")
    ops = pm.operations()
    assert ops["split"].plugin == "split-operations"
    assert ops["wobble"].plugin == "aaa-sneaky"  # its other contributions are kept
    errors = {i.name: i.errors for i in pm.plugins()}["aaa-sneaky"]
    assert any("'split' is a built-in of grammarkit (plugin 'split-operations')" in e for e in errors)


class Mixed:
    @hookimpl
    def grammarkit_operations(self):
        return ["split", None, OperationSpec(5), FunctionSpec("lerp", 3, 3), _op("good"),
                OperationSpec("notcallable", apply=42)]


class Scalar:
    @hookimpl
    def grammarkit_operations(self):
        return _op("alone")  # a spec, not a list


class Text:
    @hookimpl
    def grammarkit_functions(self):
        return "rand"


def test_results_are_validated_against_the_spec_type():
    pm = PluginManager(load_entry_points=False)
    pm.register(Mixed(), "mixed")
    pm.register(Scalar(), "scalar")
    pm.register(Text(), "text")
    assert set(pm.operations()) == {"good"}
    assert pm.functions() == {}
    infos = {i.name: i for i in pm.plugins()}
    mixed = "\n".join(infos["mixed"].errors)
    assert "str 'split' where an OperationSpec belongs" in mixed
    assert "NoneType None where an OperationSpec belongs" in mixed
    assert "whose name is 5" in mixed
    assert "a FunctionSpec ('lerp') where an OperationSpec belongs" in mixed
    assert "whose apply is int 42, not a function" in mixed
    assert "not a list of specs" in infos["scalar"].errors[0]
    assert "not a list of specs" in infos["text"].errors[0]
    assert infos["mixed"].provides == {"operation": ["good"]}


class Exits:
    @hookimpl
    def grammarkit_operations(self):
        raise SystemExit(3)


class Interrupts:
    @hookimpl
    def grammarkit_operations(self):
        raise KeyboardInterrupt


def test_exits_in_hooks_are_reported_not_obeyed():
    pm = PluginManager(load_entry_points=False)
    pm.register(Exits(), "exits")
    pm.register(Plain(), "plain")
    assert set(pm.operations()) == {"twist"}
    assert "raised SystemExit" in {i.name: i for i in pm.plugins()}["exits"].errors[0]
    pm = PluginManager(load_entry_points=False)
    pm.register(Interrupts(), "interrupts")
    with pytest.raises(KeyboardInterrupt):  # the user's Ctrl-C is obeyed, not blamed on the plugin
        pm.operations()


# -- installed plugins, in a fresh process ------------------------------------------------------
def _dist(root: Path, name: str, entry_points: dict[str, str], modules: dict[str, str]) -> Path:
    site = root / name
    info = site / f"{name.replace('-', '_')}-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[grammarkit]\n" + "".join(f"{k} = {v}\n" for k, v in entry_points.items()))
    for module, text in modules.items():
        (site / f"{module}.py").write_text(text)
    return site


def gk(args: list[str], *paths: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    e = dict(os.environ)
    e.pop("GRAMMARKIT_NO_PLUGINS", None)
    e.pop("GRAMMARKIT_DISABLE_PLUGINS", None)
    e["PYTHONPATH"] = os.pathsep.join(str(p) for p in paths)
    e.update(env or {})
    return subprocess.run([sys.executable, "-c", "from grammarkit.cli import main; main()", *args],
                          capture_output=True, text=True, env=e, cwd=ROOT, timeout=180)


MARKER_PLUGIN = """\
import os, sys
from grammarkit import hookimpl
from grammarkit.registry import FunctionSpec
print("noisy plugin says hello")  # on stdout, at import
open(os.environ["GK_MARKER"], "a").write("imported\\n")

@hookimpl
def grammarkit_functions():
    print("noisy hook")
    return [FunctionSpec("lerp", 3, 3, "lerp(a, b, t)", lambda a, b, t: a + (b - a) * t)]
"""


@pytest.fixture(scope="module")
def sites(tmp_path_factory):
    root = tmp_path_factory.mktemp("plugins")
    return {
        "noisy": _dist(root, "gk-noisy", {"noisy": "gk_noisy"}, {"gk_noisy": MARKER_PLUGIN}),
        "exits": _dist(root, "gk-exits", {"exits": "gk_exits"}, {"gk_exits": "import sys\nsys.exit(2)\n"}),
    }


def test_a_plugin_printing_on_import_does_not_corrupt_json(sites, tmp_path):
    marker = tmp_path / "marker"
    g = tmp_path / "lerp.grammar"
    g.write_text("Lot --> footprint(rect(4, 4)) extrude(lerp(1, 3, 0.5)) X.\n")
    r = gk(["check", "--json", str(g)], sites["noisy"], env={"GK_MARKER": str(marker)})
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)  # nothing but the JSON document on stdout
    assert out["errors"] == 0
    assert "noisy plugin says hello" in r.stderr and "noisy hook" in r.stderr
    r = gk(["plugins", "--json"], sites["noisy"], env={"GK_MARKER": str(marker)})
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    assert infos["noisy"]["provides"] == {"function": ["lerp"]} and not infos["noisy"]["builtin"]
    assert infos["split-operations"]["builtin"]


def test_a_plugin_exiting_on_import_is_reported_and_the_command_goes_on(sites, tmp_path):
    r = gk(["check", str(GRAMMAR)], sites["exits"])
    assert r.returncode == 0, r.stdout + r.stderr
    assert "0 errors" in r.stderr
    # check of a grammar that needs no third-party plugin does not even import one (issue 19)
    assert "gk_exits" not in r.stderr
    r = gk(["derive", str(GRAMMAR), "-o", str(tmp_path / "o.glb")], sites["exits"])
    assert r.returncode == 0, r.stdout + r.stderr
    assert "warning: plugin 'exits': failed to load 'gk_exits': SystemExit: 2" in r.stderr
    r = gk(["plugins", "--json"], sites["exits"])
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    assert infos["exits"]["status"] == "error" and infos["split-operations"]["ok"]


def test_plugins_can_be_disabled_by_name_or_all_at_once(sites, tmp_path):
    marker = tmp_path / "marker"
    env = {"GK_MARKER": str(marker)}
    g = tmp_path / "lerp.grammar"
    g.write_text("Lot --> footprint(rect(4, 4)) extrude(lerp(1, 3, 0.5)) X.\n")
    r = gk(["--no-plugins", "check", str(g)], sites["noisy"], sites["exits"], env=env)
    assert r.returncode == 1 and "unknown function 'lerp'" in r.stdout
    assert not marker.exists() and "exits" not in r.stderr  # neither plugin was imported
    r = gk(["check", str(g)], sites["noisy"], sites["exits"],
           env={**env, "GRAMMARKIT_DISABLE_PLUGINS": "exits, noisy"})
    assert r.returncode == 1 and not marker.exists()
    r = gk(["--no-plugins", "plugins", "--json"], sites["noisy"], env=env)
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    assert infos["noisy"]["status"] == "disabled" and infos["split-operations"]["status"] == "ok"
    assert infos["graph-sampler"]["status"] == "ok"  # built-ins stay
    r = gk(["check", str(g)], sites["noisy"], env={**env, "GRAMMARKIT_DISABLE_PLUGINS": "noisy,nosuch"})
    assert "no plugin of that name is installed" in r.stderr


def test_help_version_and_fmt_import_no_plugin_code(sites, tmp_path):
    marker = tmp_path / "marker"
    env = {"GK_MARKER": str(marker)}
    for args in (["--help"], ["--version"], ["fmt", str(GRAMMAR)], ["fmt", "--help"]):
        r = gk(args, sites["noisy"], env=env)
        assert r.returncode == 0, (args, r.stderr)
        assert not marker.exists(), args
    assert "Plugins may add commands" in gk(["--help"], env=env).stdout
    r = gk(["check", str(GRAMMAR)], sites["noisy"], env=env)
    assert not marker.exists()  # a grammar that needs no plugin is checked without them
    g = tmp_path / "lerp.grammar"
    g.write_text("Lot --> footprint(rect(4, 4)) extrude(lerp(1, 3, 0.5)) X.\n")
    r = gk(["check", str(g)], sites["noisy"], env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert marker.exists()  # check needs the plugin's function: the plugin loads


def test_plugins_lists_each_backends_options():
    r = gk(["plugins", "--json"])
    assert r.returncode == 0, r.stderr
    infos = {p["name"]: p for p in json.loads(r.stdout)}
    split = {o["name"]: o for o in infos["split-backend"]["backend_options"]["split"]}
    assert split["variations"]["type"] == "bool" and split["variations"]["default"] is False
    assert "max-depth" in split
    assert infos["graph-sampler"]["backend_options"]["graph-sampler"]
    r = gk(["plugins"])
    assert "split --option variations (bool = False)" in r.stdout


# -- hooks receive the one Application; pluggy's call with per-plugin guards ---------------------
def test_hooks_receive_the_application_and_argument_free_hooks_keep_working():
    from grammarkit.plugins import Application

    seen = []

    class WithApp:
        @hookimpl
        def grammarkit_operations(self, app):
            seen.append(app)
            return [OperationSpec(name="with_app", apply=lambda *a: None)]

    class Plain:
        @hookimpl
        def grammarkit_operations(self):
            return [OperationSpec(name="plain_op", apply=lambda *a: None)]

    pm = PluginManager(load_entry_points=False)
    pm.register(WithApp(), "with-app")
    pm.register(Plain(), "plain")
    assert {"with_app", "plain_op"} <= set(pm.operations())
    assert len(seen) == 1 and isinstance(seen[0], Application) and seen[0] is pm.app
    assert seen[0].registries is pm.registries()


def test_hook_wrappers_run_and_a_broken_plugin_is_isolated_inside_pluggys_call():

    calls = []

    class Wrapper:
        @hookimpl(wrapper=True)
        def grammarkit_operations(self):
            calls.append("before")
            result = yield
            calls.append(("after", sorted(c.plugin for c in result)))
            return result

    class Broken:
        @hookimpl
        def grammarkit_operations(self, app):
            raise RuntimeError("boom")

    class Good:
        @hookimpl
        def grammarkit_operations(self):
            return [OperationSpec(name="good_op", apply=lambda *a: None)]

    pm = PluginManager(load_entry_points=False)
    for name, plugin in (("wrapper", Wrapper()), ("broken", Broken()), ("good", Good())):
        pm.register(plugin, name)
    assert "good_op" in pm.operations()
    assert calls == ["before", ("after", ["good"])]  # the wrapper saw the guarded results
    infos = {i.name: i for i in pm.plugins()}
    assert any("raised RuntimeError: boom" in e for e in infos["broken"].errors)
    assert infos["good"].ok
