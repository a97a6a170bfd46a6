"""Issue 31: a fuzz test of the studio's file access. Hypothesis writes paths out of `..`, `.`,
empty segments, doubled slashes, absolute prefixes, symbolic links (to a file outside, to a
folder outside, to the parent of the grammar's folder, to a folder inside) and names of files
inside and outside, spells them with `\\u{..}` escapes, splits them into concatenations, holds
them in consts, attrs (or the page's attr values) and rule arguments, and hands them to every
sink that opens a file: `import`, `i()`, `texture()`, `fileExists()`.

Two oracles, both must hold for every case:
- **nothing outside is touched**: an audit hook (`sys.addaudithook`, the interpreter's own
  `open`/`os.listdir`/`os.scandir` events) records every file opened or folder listed while
  the studio's Work runs the case; none may resolve outside the grammar's folder (inside the
  test's tree, so library files do not count);
- **the answer is the policy's**: a path whose resolved form (`os.path.realpath`, as the kernel
  follows links and then `..`) is outside the folder is refused with the outside-folder error;
  one inside is never refused as outside.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from test_confinement import LOT, Attack, make_tree, run_attack  # noqa: E402

SEGMENTS = ["..", ".", "", "secret", "root", "parts", "sub", "up", "up2", "link_out", "link_in",
            "link_file.obj", "secret.obj", "in.obj", "secret.grammar", "tex.png", "none.obj", "evil.gltf"]


class _Opens:
    """Files opened and folders listed under `watch` while `active` (an audit hook cannot be
    removed, so it is installed once and switched)."""

    def __init__(self) -> None:
        self.active = False
        self.watch = ""
        self.seen: list[str] = []
        sys.addaudithook(self)

    def __call__(self, event: str, args: tuple) -> None:
        if not self.active or event not in ("open", "os.listdir", "os.scandir"):
            return
        path = args[0] if args else None
        if isinstance(path, (str, bytes, os.PathLike)):
            try:
                real = os.path.realpath(os.fsdecode(path))
            except (ValueError, OSError):
                return
            if real == self.watch or real.startswith(self.watch + os.sep):
                self.seen.append(real)


_OPENS: _Opens | None = None


def _opens() -> _Opens:
    global _OPENS
    if _OPENS is None:
        _OPENS = _Opens()
    return _OPENS


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    return make_tree(tmp_path_factory.mktemp("confine-fuzz"))


@pytest.fixture(scope="module")
def work(tree):
    from grammarkit_studio.work import Work

    return Work(str(tree.grammar), str(tree.root))


@st.composite
def paths(draw: Any, tree_base: str, tree_root: str) -> str:
    """A path as the grammar means it (after escapes and evaluation)."""
    prefix = draw(st.sampled_from(["", "", "", "./", "/", tree_base + "/", tree_root + "/"]))
    segments = draw(st.lists(st.sampled_from(SEGMENTS), min_size=1, max_size=7))
    joiners = draw(st.lists(st.sampled_from(["/", "/", "/", "//"]), min_size=len(segments), max_size=len(segments)))
    out = prefix
    for seg, joiner in zip(segments, joiners):
        out += seg + joiner
    return out.rstrip("/") if draw(st.booleans()) else out[:-1] if out.endswith("//") else out.rstrip("/")


def _escape(s: str, mask: list[bool]) -> str:
    """`s` as a .grammar string body, the characters picked by `mask` written as \\u{hex}."""
    out = []
    for i, c in enumerate(s):
        if c in '"\\':
            out.append("\\" + c)
        elif mask[i % len(mask)] if mask else False:
            out.append("\\u{%x}" % ord(c))
        else:
            out.append(c)
    return "".join(out)


@st.composite
def expressions(draw: Any, path: str) -> tuple[str, str, dict]:
    """(expression, statements it needs, attrs the page sends) whose value is `path`."""
    mask = draw(st.lists(st.booleans(), min_size=1, max_size=8))
    cuts = sorted(draw(st.lists(st.integers(0, len(path)), max_size=3)))
    pieces = [path[a:b] for a, b in zip([0, *cuts], [*cuts, len(path)])]
    literal = " + ".join(f'"{_escape(p, mask)}"' for p in pieces)
    form = draw(st.sampled_from(["literal", "const", "attr", "page", "argument", "prefix"]))
    if form == "literal":
        return literal, "", {}
    if form == "const":
        return "p", f"const p = {literal}\n", {}
    if form == "attr":
        return "p", f"attr p = {literal}\n", {}
    if form == "page":  # the page's slider/attr value replaces the grammar's
        return "p", 'attr p = "parts/in.obj"\n', {"p": path}
    if form == "prefix":
        return f'getPrefix({literal} + "#z", "#")', "", {}
    return "q", "", {"__argument__": literal}


def _grammar(sink: str, expr: str, head: str, attrs: dict) -> tuple[str, dict]:
    argument = attrs.pop("__argument__", None)
    use = {"i": f"i({expr}) A.", "texture": f"texture({expr}) A.",
           "fileExists": f'report("k", fileExists({expr})) A.'}[sink]
    if argument is not None:  # through a rule's parameter
        return f"grammar g\n{head}{LOT}B({argument})\nB(q) --> {use}\n", attrs
    return f"grammar g\n{head}{LOT}{use}\n", attrs


def _expect_outside(tree: Any, path: str) -> bool:
    return _expect_outside_of(tree.root, tree, path)


def _expect_outside_of(base: Any, tree: Any, path: str) -> bool:
    real = os.path.realpath(os.path.join(base, path))
    root = os.path.realpath(tree.root)
    return not (real == root or real.startswith(root + os.sep))


def _run(work: Any, tree: Any, attack: Attack) -> tuple[str, str, list[str]]:
    opens = _opens()
    opens.watch = os.path.realpath(tree.base)
    opens.seen = []
    opens.active = True
    try:
        verdict, detail = run_attack(work, attack, tree)
    finally:
        opens.active = False
    root = os.path.realpath(tree.root)
    outside = [p for p in opens.seen if not (p == root or p.startswith(root + os.sep))]
    return verdict, detail, outside


def _expect_refusal(tree: Any, path: str, sink: str) -> bool:
    """Whether the policy must refuse: the path resolves outside, or (for i()) it is the glTF
    inside whose buffer is outside."""
    if _expect_outside(tree, path):
        return True
    return sink == "i" and os.path.realpath(os.path.join(tree.root, path)) == os.path.realpath(tree.root / "evil.gltf")


def answer_problem(tree: Any, path: str, sink: str, verdict: str) -> str | None:
    """What is wrong with the policy's answer to `sink` of `path` (None: it is right)."""
    if verdict == "traceback":
        return "a traceback"
    if _expect_refusal(tree, path, sink):
        return None if verdict == "clear" else f"resolves outside, but: {verdict}"
    if sink == "texture" and not os.path.isabs(path) and _expect_outside_of(os.getcwd(), tree, path):
        # a computed relative texture name reaches the exporter as it is and is opened from the
        # working folder (a bug of the texturing code, reported): refusing it is right
        return None
    return "is inside, but it was refused as outside" if verdict == "clear" else None


def _judge(tree: Any, path: str, sink: str, verdict: str, detail: str, outside: list[str]) -> None:
    assert not outside, f"{sink} {path!r}: opened outside the folder: {outside}"
    problem = answer_problem(tree, path, sink, verdict)
    assert problem is None, f"{sink} {path!r} {problem}: {detail}"


FUZZ = settings(max_examples=int(os.environ.get("GRAMMARKIT_FUZZ_EXAMPLES", "120")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
                derandomize=True)


@FUZZ
@given(data=st.data())
def test_fuzz_file_sinks_never_leave_the_folder(work, tree, data):
    path = data.draw(paths(str(tree.base), str(tree.root)), label="path")
    expr, head, attrs = data.draw(expressions(path), label="expression")
    sink = data.draw(st.sampled_from(["i", "texture", "fileExists"]), label="sink")
    text, attrs = _grammar(sink, expr, head, dict(attrs))
    verdict, detail, outside = _run(work, tree, Attack("fuzz", text, "derive", attrs))
    _judge(tree, path, sink, verdict, detail, outside)


@FUZZ
@given(data=st.data())
def test_fuzz_imports_never_leave_the_folder(work, tree, data):
    path = data.draw(paths(str(tree.base), str(tree.root)), label="path")
    mask = data.draw(st.lists(st.booleans(), min_size=1, max_size=8), label="escapes")
    text = f'grammar g\nimport "{_escape(path, mask)}"\n{LOT}A.\n'
    verdict, detail, outside = _run(work, tree, Attack("fuzz", text, "check"))
    _judge(tree, path, "import", verdict, detail, outside)


def test_the_audit_oracle_sees_an_unconfined_read(tree):
    """The oracle is not blind: without the studio's confinement the same attack is recorded."""
    from grammarkit.dsl import check_text

    opens = _opens()
    opens.watch, opens.seen, opens.active = os.path.realpath(tree.base), [], True
    try:
        check_text(f'grammar g\nimport "../secret/secret.grammar"\n{LOT}A.\n', filename=str(tree.grammar))
    finally:
        opens.active = False
    assert any(p.endswith("secret.grammar") and "/secret/" in p for p in opens.seen)
