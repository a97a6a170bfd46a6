"""Issue 31: the studio's folder confinement. A grammar the studio serves may reach only files
inside its folder, however the path is written: escapes (`\\u{2e}\\u{2e}`, `\\u{2f}`), absolute
paths, concatenations, consts, attrs (also set by the page's sliders), symbolic links (to files
and to folders), and for every kind of file (imports, inserted meshes, a glTF's external
buffer, textures, fileExists/fileSearch, tiling part meshes and examples).

`ATTACKS` is the catalogue that benchmarks/bench_hardening.py also runs (group "studio
confinement"); `run_attack` says what became of one: "clear" (refused with the outside-folder
error), "bypass" (the file was used), "traceback" or "wrong" (another error: an attack that no
longer tests what it means to, or an answer that depends on what exists outside).
"""
from __future__ import annotations

import json
import os
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from grammarkit import confine
from grammarkit.errors import GrammarkitError

sys.path.insert(0, str(Path(__file__).parent))
from attack import _glb_with_buffer  # noqa: E402 - the glTF of issue 19's external-buffer attacks

SECRET_ATTR = "leaked_secret"
LOT = "Lot --> footprint(rect(4, 4)) extrude(2) "


@dataclass(frozen=True)
class Tree:
    """A grammar folder (`root`) beside a folder it must not reach (`secret`), with links."""

    base: Path
    root: Path
    secret: Path

    @property
    def grammar(self) -> Path:
        return self.root / "g.grammar"


def _box_obj() -> str:
    v = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    return "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(
        f"f {a} {b} {c}\nf {a} {c} {d}\n" for a, b, c, d in faces)


PNG_1x1 = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010802000000907753de0000000c49444154"
                        "08d763f8cfc0000003010100c9fe92ef0000000049454e44ae426082")


def make_tree(base: Path) -> Tree:
    """root/ (the studio's folder) and secret/ beside it:

    root/g.grammar, parts/in.obj, tex.png, evil.gltf (buffer ../secret/tri.bin),
    parts/quoted.gltf (buffer %2e%2e/%2e%2e/secret/tri.bin), asm/a.obj -> ../../secret/secret.obj,
    link_out -> ../secret, link_file.obj -> ../secret/secret.obj, link_in -> parts,
    sub/up -> .. (root itself: inside), sub/up2 -> ../.. (base: outside);
    secret/secret.grammar (defines attr leaked_secret), secret.obj, tex.png, tri.bin."""
    root, secret = base / "root", base / "secret"
    (root / "parts").mkdir(parents=True)
    (root / "sub").mkdir()
    secret.mkdir()
    (root / "g.grammar").write_text(f"grammar g\n{LOT}A.\n")
    (root / "parts" / "in.obj").write_text(_box_obj())
    (root / "tex.png").write_bytes(PNG_1x1)
    _glb_with_buffer(root, "../secret/tri.bin").rename(root / "evil.gltf")
    _glb_with_buffer(root, "%2e%2e/%2e%2e/secret/tri.bin").rename(root / "parts" / "quoted.gltf")
    (root / "asm").mkdir()
    os.symlink("../../secret/secret.obj", root / "asm" / "a.obj")
    (secret / "secret.grammar").write_text(f"grammar secret\nattr {SECRET_ATTR} = 1\n")
    (secret / "secret.obj").write_text(_box_obj())
    (secret / "tex.png").write_bytes(PNG_1x1)
    (secret / "tri.bin").write_bytes(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0))
    os.symlink("../secret", root / "link_out")
    os.symlink("../secret/secret.obj", root / "link_file.obj")
    os.symlink("parts", root / "link_in")
    os.symlink("..", root / "sub" / "up")
    os.symlink("../..", root / "sub" / "up2")
    return Tree(base, root, secret)


@dataclass(frozen=True)
class Attack:
    name: str
    text: str  # grammar text (the page sends text; the file on disk is g.grammar)
    op: str = "derive"  # "check" or "derive"
    attrs: dict = field(default_factory=dict)
    absolute: bool = False  # `{secret}` in text/attrs stands for the secret folder's absolute path

    def materialise(self, tree: Tree) -> tuple[str, dict]:
        fill = (lambda s: s.replace("{secret}", str(tree.secret))) if self.absolute else (lambda s: s)
        return fill(self.text), {k: fill(v) if isinstance(v, str) else v for k, v in self.attrs.items()}


def _imp(path: str) -> str:
    return f'grammar g\nimport "{path}"\n{LOT}A.\n'


def _ins(expr: str, head: str = "") -> str:
    return f"grammar g\n{head}{LOT}i({expr}) A.\n"


ATTACKS: list[Attack] = [
    # imports (refused before the file is looked at)
    Attack("import \\u{2e}\\u{2e}/secret", _imp(r"\u{2e}\u{2e}/secret/secret.grammar"), "check"),
    Attack("import ..\\u{2f}secret", _imp(r"..\u{2f}secret/secret.grammar"), "check"),
    Attack("import \\u{2f}etc/passwd", _imp(r"\u{2f}etc/passwd"), "check"),
    Attack("import /etc/passwd", _imp("/etc/passwd"), "check"),
    Attack("import ../secret", _imp("../secret/secret.grammar"), "check"),
    Attack("import through a folder link", _imp("link_out/secret.grammar"), "check"),
    Attack("import through a link to the parent", _imp("sub/up2/secret/secret.grammar"), "check"),
    Attack("import ./sub/../../secret", _imp("./sub/../../secret/secret.grammar"), "check"),
    Attack("import with doubled slashes", _imp("..//secret//secret.grammar"), "check"),
    Attack("import by absolute path", _imp("{secret}/secret.grammar"), "check", absolute=True),
    # inserted meshes
    Attack("i() of a concatenation", _ins('"../secret/" + "secret.obj"')),
    Attack("i() of a const", _ins("p", 'const p = "../secret/secret.obj"\n')),
    Attack("i() of an attr", _ins("p", 'attr p = "../secret/secret.obj"\n')),
    Attack("i() of an attr set by the page", _ins("p", 'attr p = "parts/in.obj"\n'),
           attrs={"p": "{secret}/secret.obj"}, absolute=True),
    Attack("i() of an escaped literal", _ins(r'"\u{2e}\u{2e}\u{2f}secret/secret.obj"')),
    Attack("i() of a link to a file", _ins('"link_file.obj"')),
    Attack("i() through a folder link", _ins('"link_out/secret.obj"')),
    Attack("i() through a link to the parent", _ins('"sub/up2/secret/secret.obj"')),
    Attack("i() of a glTF whose buffer is outside", _ins('"evil.gltf"')),
    Attack("i() of a glTF whose buffer URI is percent-encoded", _ins('"parts/quoted.gltf"')),
    Attack("i() of a rule argument", "grammar g\n"
           + 'Lot --> footprint(rect(4, 4)) extrude(2) B("../secret/" + "secret.obj")\n'
           + "B(p) --> i(p) A.\n"),
    Attack("i() of getPrefix of a const", _ins('getPrefix(p, "#")', 'const p = "../secret/secret.obj#x"\n')),
    # textures and file functions
    Attack("texture() outside", f'grammar g\n{LOT}texture("../secret/tex.png") A.\n'),
    Attack("texture() of a concatenation", f'grammar g\nconst d = "../secret/"\n{LOT}texture(d + "tex.png") A.\n'),
    Attack("set(material.colormap) through a link", f'grammar g\n{LOT}set(material.colormap, "link_out/tex.png") A.\n'),
    Attack("fileExists outside", f'grammar g\n{LOT}report("k", fileExists("../secret/secret.obj")) A.\n'),
    Attack("fileExists of a missing file outside", f'grammar g\n{LOT}report("k", fileExists("../secret/none.obj")) A.\n'),
    Attack("fileExists of an absolute path", f'grammar g\n{LOT}report("k", fileExists("/etc/passwd")) A.\n'),
    # tiling grammars
    Attack("tiling mesh() through a link", 'grammar t\npart A = mesh("link_out/secret.obj")\n'
           "example e { A at (0, 0, 0) rot (0, 0, 0) }\n"),
    Attack("tiling example: a folder holding a link outside", 'grammar t\npart A = box(1, 1, 1)\n'
           'example e = assembly("asm")\n'),
    Attack("tiling example assembly outside", 'grammar t\npart A = box(1, 1, 1)\n'
           'example e = assembly("../secret/secret.obj")\n'),
]


def _diagnostics(work: Any, attack: Attack, tree: Tree) -> tuple[bool, list[dict], Any]:
    text, attrs = attack.materialise(tree)
    try:
        if attack.op == "check":
            out = work.check(text)
            return out["ok"], out["diagnostics"], out
        out = work.derive(text, attrs, 0)
        diags = list(out["check"]["diagnostics"]) + list((out.get("error") or {}).get("diagnostics", []))
        if out.get("error") and not diags:
            diags = [{"code": None, "message": out["error"]["message"]}]
        return out["ok"], diags, out
    except GrammarkitError as exc:
        return False, [d.to_json() for d in exc.diagnostics], None


def run_attack(work: Any, attack: Attack, tree: Tree) -> tuple[str, str]:
    """(verdict, detail) of one attack through the studio's Work (the worker's code)."""
    try:
        ok, diags, out = _diagnostics(work, attack, tree)
    except Exception as exc:  # noqa: BLE001 - a traceback is a finding, not a test crash
        return "traceback", f"{type(exc).__name__}: {exc}"
    for d in diags:
        if d.get("file") and not Path(d["file"]).resolve().is_relative_to(tree.root.resolve()):
            return "bypass", f"a diagnostic shows the outside file {d['file']}"
    if ok:
        return "bypass", "accepted"
    if any(d.get("code") == confine.CODE for d in diags):
        return "clear", ""
    return "wrong", "; ".join(str(d.get("message"))[:200] for d in diags) or "no diagnostic"


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Tree:
    return make_tree(tmp_path_factory.mktemp("confine"))


@pytest.fixture(scope="module")
def work(tree):
    from grammarkit_studio.work import Work

    return Work(str(tree.grammar), str(tree.root))


@pytest.mark.parametrize("attack", ATTACKS, ids=lambda a: a.name)
def test_every_attack_is_refused(work, tree, attack):
    verdict, detail = run_attack(work, attack, tree)
    assert verdict == "clear", f"{attack.name}: {verdict}: {detail}"


def test_imports_are_refused_at_their_line_without_reading_the_file(work, tree):
    out = work.check(_imp(r"\u{2f}etc/passwd"))
    (d,) = out["diagnostics"]  # nothing of /etc/passwd: no syntax error located in it
    assert d["code"] == "outside-folder" and d["line"] == 2 and d["file"] == str(tree.grammar)
    assert "'/etc/passwd' is outside" in d["message"] and str(tree.root) in d["message"]


def test_the_refusal_does_not_tell_whether_the_outside_file_exists(work, tree):
    msgs = []
    for name in ("secret.obj", "none.obj"):
        with pytest.raises(confine.ConfinementError) as exc:
            work.derive(_ins(f'"../secret/" + "{name}"'), {}, 0)
        msgs.append(str(exc.value).replace(name, "X"))
    assert msgs[0] == msgs[1]
    # the check-time diagnostic of a literal link does not show where the link points
    out = work.check(_ins('"link_file.obj"'))
    assert [d["code"] for d in out["diagnostics"]] == ["outside-folder"]
    assert str(tree.secret) not in json.dumps(out["diagnostics"])


def test_derive_errors_are_located_at_the_operation(work, tree):
    with pytest.raises(confine.ConfinementError) as exc:
        work.derive(_ins("p", 'const p = "../secret/secret.obj"\n'), {}, 0)
    d = exc.value.diagnostics[0]
    assert d.code == "outside-folder" and d.span is not None and d.span.line == 3
    assert "in rule 'Lot'" in d.message and "mesh file" in d.message


def test_files_inside_the_folder_still_work(work, tree):
    for text in (_ins('"parts/in.obj"'), _ins('"link_in/in.obj"'), _ins('"sub/up/parts/in.obj"'),
                 _ins('"parts/" + n', 'const n = "in.obj"\n'),
                 f'grammar g\n{LOT}texture("tex.png") A.\n',
                 f'grammar g\n{LOT}report("k", fileExists("parts/in.obj")) A.\n',
                 f'grammar g\n{LOT}i(fileRandom("parts/*.obj")) A.\n'):
        out = work.derive(text, {}, 0)
        assert out["ok"], (text, out.get("error"), out["check"]["diagnostics"])


def test_file_search_lists_only_the_folder(work, tree):
    """fileSearch walks the grammar's folder, not through a link to a folder outside."""
    out = work.derive(f'grammar g\n{LOT}report("k", fileSearch("*.obj")) A.\n', {}, 0)
    assert out["ok"]
    listed = out["facts"].get("reports") or json.dumps(out["facts"])
    assert "secret.obj" not in str(listed).replace("link_file.obj", "")


def test_outside_the_studio_nothing_is_confined(tree):
    """The command line and the Python API are not confined (behaviour unchanged)."""
    from grammarkit.dsl import load
    from grammarkit.split import derive

    path = tree.root / "free.grammar"
    path.write_text(_ins('"../secret/secret.obj"'))
    assert confine.current() is None
    assert derive(load(path), seed=0).triangle_count > 0


def test_the_studio_worker_process_refuses_too(tree):
    """Through the real worker process (what the page drives)."""
    from grammarkit_studio.worker import CallFailed, Worker

    worker = Worker(str(tree.grammar), str(tree.root), "test")
    try:
        with pytest.raises(CallFailed) as exc:
            worker.call("derive", 60, text=_ins('"../secret/" + "secret.obj"'), attrs={}, seed=0)
        assert "outside" in exc.value.info["message"]
        assert [d["code"] for d in exc.value.info["diagnostics"]] == ["outside-folder"]
        out = worker.call("check", 60, text=_imp(r"..\u{2f}secret/secret.grammar"))
        assert [d["code"] for d in out["diagnostics"]] == ["outside-folder"]
    finally:
        worker.close()


# -- the policy itself ---------------------------------------------------------------------------

def test_policy_api(tree):
    root = tree.root
    assert confine.current() is None and confine.allows("/etc/passwd")
    confine.check("/etc/passwd")  # no policy: nothing is refused
    with confine.confined(root, who="the test") as policy:
        assert policy.root == os.path.realpath(root) and confine.current() == policy
        assert confine.allows(root) and confine.allows(root / "parts" / "in.obj")
        assert confine.allows("parts/in.obj", base=root)
        assert not confine.allows(str(root) + "-sibling/x")  # a prefix of the name is not inside
        assert not confine.allows("link_out/secret.obj", base=root)
        assert not confine.allows("a\0b", base=root)
        with pytest.raises(confine.ConfinementError, match="the only folder the test reads"):
            confine.check("../secret/secret.obj", base=root, what="mesh file")
        d = confine.refusal("/etc/passwd", what="import")
        assert d is not None and d.code == "outside-folder" and d.hint
        with confine.confined(tree.base):  # cannot widen
            assert confine.current() == policy
        with confine.confined(None):  # cannot lift
            assert confine.current() == policy
        with confine.confined(root / "parts") as inner:  # can narrow
            assert inner.root.endswith("parts") and not confine.allows(root / "tex.png")
    assert confine.current() is None


def test_guarded_loaders_check_before_their_cache(tree):
    from functools import lru_cache

    calls = []

    @confine.guarded("mesh file")
    @lru_cache(maxsize=8)
    def load(path: str) -> str:
        calls.append(path)
        return path

    outside = str(tree.secret / "secret.obj")
    assert load(outside) == outside  # unconfined: read and cached
    with confine.confined(tree.root), pytest.raises(confine.ConfinementError):
        load(outside)  # the cached copy is not handed out either
    with confine.confined(tree.root):
        assert load("builtin:cube") == "builtin:cube"
    assert calls == [outside, "builtin:cube"] and load.cache_info().hits == 0
    load.cache_clear()


def test_policy_follows_threads_started_with_the_context(tree):
    import asyncio
    import threading

    async def inside() -> Any:
        return await asyncio.to_thread(confine.current)

    with confine.confined(tree.root) as policy:
        assert asyncio.run(inside()) == policy
        seen = []
        t = threading.Thread(target=lambda: seen.append(confine.current()))
        t.start()
        t.join()
        assert seen == [None]  # a plain thread starts unconfined: code that hands work to one re-enters


def test_confine_is_a_bottom_floor_module():
    import ast

    tree = ast.parse(Path(confine.__file__).read_text())
    mods = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level}
    mods |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names
             if a.name.startswith("grammarkit")}
    assert mods <= {"errors", "ir.base"}, mods


def test_every_worker_operation_runs_confined(work, tree):
    """Each operation the page can ask for (worker.Worker.OPS) is a confined Work method, and
    the policy is left when it returns (a gallery between its steps too)."""
    from grammarkit_studio.work import Work
    from grammarkit_studio.worker import Worker

    for op in Worker.OPS:
        method = getattr(Work, "format_text" if op == "format" else op)
        assert getattr(method, "__wrapped__", None) is not None, f"{op} is not confined"
    work.check(_imp("../secret/secret.grammar"))
    assert confine.current() is None
    steps = work.gallery(_ins('"../secret/" + "secret.obj"'), n=2, seed=0)
    with pytest.raises(confine.ConfinementError):
        next(steps)
    assert confine.current() is None
    items = list(work.gallery(_ins('"parts/" + "in.obj"'), n=2, seed=0))
    assert items[-1]["done"] and items[-1]["count"] >= 1 and confine.current() is None
