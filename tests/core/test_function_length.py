"""No function over 80 lines without a reason (issue 25).

A function (or method) of grammarkit/ or plugins/ longer than 80 lines, counted from its `def`
to its last line, is split, or carries a comment line `# long: <why it is one piece>` directly
above its `def` (above its decorators, if any). The failure lists every offender as
file:line function (length) so that the owners can fix theirs.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAX_LINES = 80
REASON = re.compile(r"^\s*#\s*long:\s*\S")


def _sources() -> list[Path]:
    files = sorted((ROOT / "grammarkit").rglob("*.py")) + sorted((ROOT / "plugins").rglob("*.py"))
    return [p for p in files if "__pycache__" not in p.parts and ".egg-info" not in str(p)]


def _reason_above(lines: list[str], first: int) -> bool:
    """Whether the block of comment lines directly above line `first` (1-based) holds a
    `# long:` line: a reason may run over several comment lines."""
    i = first - 2
    while i >= 0 and lines[i].lstrip().startswith("#"):
        if REASON.match(lines[i]):
            return True
        i -= 1
    return False


def long_functions(path: Path) -> list[tuple[int, str, int, bool]]:
    """(line of def, qualified name, length in lines, has a `# long:` reason) of every
    function of `path` longer than MAX_LINES."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    out = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                length = (child.end_lineno or child.lineno) - child.lineno + 1
                if length > MAX_LINES:
                    first = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                    out.append((child.lineno, name, length, _reason_above(lines, first)))
                visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(text, filename=str(path)), "")
    return out


def test_long_functions_say_why():
    offenders = []
    for path in _sources():
        for line, name, length, reasoned in long_functions(path):
            if not reasoned:
                offenders.append(f"{path.relative_to(ROOT)}:{line} {name} ({length} lines)")
    if offenders:
        pytest.fail(f"{len(offenders)} function(s) over {MAX_LINES} lines without a `# long: <reason>` "
                    "comment directly above the def (or its decorators); split them or say why:\n  "
                    + "\n  ".join(offenders), pytrace=False)


def test_the_check_sees_long_functions_and_reasons(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_LINES))
    method_body = "\n".join(f"        x{i} = {i}" for i in range(MAX_LINES))
    src = (f"def short():\n    pass\n\n\ndef long_one():\n{body}\n\n\n"
           f"# long: one table,\n# clearer in one piece\n@staticmethod\ndef long_two():\n{body}\n\n\n"
           f"class K:\n    def method(self):\n{method_body}\n")
    path = tmp_path / "m.py"
    path.write_text(src)
    found = {name: (length, reasoned) for _, name, length, reasoned in long_functions(path)}
    assert found == {"long_one": (MAX_LINES + 1, False), "long_two": (MAX_LINES + 1, True),
                     "K.method": (MAX_LINES + 1, False)}


MAX_MODULE_LINES = 700
DATA_TABLE = re.compile(r"^#\s*data table:\s*\S", re.MULTILINE)  # in a module's first 20 lines


def test_no_module_over_700_lines_except_data_tables():
    # issue 25: a module over 700 lines holds more than one concern; a module that is mostly one
    # table (an operation list, a CGA function map) says so with `# data table: <what>`
    offenders = []
    for path in _sources():
        text = path.read_text(encoding="utf-8")
        n = len(text.splitlines())
        if n > MAX_MODULE_LINES and not DATA_TABLE.search("\n".join(text.splitlines()[:20])):
            offenders.append(f"{path.relative_to(ROOT)} ({n} lines)")
    assert not offenders, f"modules over {MAX_MODULE_LINES} lines: {offenders}"
