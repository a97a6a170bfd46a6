"""Code blocks of README.md and docs/*.md, classified for tests/docs/test_docs_run.py."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
ILLUSTRATIVE = "<!-- illustrative -->"
# marks a block that shows what the nearest runnable block above it prints (some of its lines,
# in order): tests/docs/test_docs_run.py runs that block and compares
OUTPUT = "<!-- output -->"
SHELL_LANGS = {"bash", "sh", "shell", "console"}
PYTHON_LANGS = {"python", "py"}
# an untagged block is a shell block when every command line starts with one of these
COMMANDS = ("grammarkit ", "python ", "python3 ", "pip ", "cd ", "mkdir ", "ls ", "cat ", "npm ", "node ")

FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})\s*([\w+-]*)")


@dataclass
class Block:
    file: Path
    line: int  # 1-based line of the opening fence
    lang: str
    code: str
    marker: str  # the HTML comment on the line before the fence, or ""

    @property
    def where(self) -> str:
        return f"{self.file.relative_to(ROOT)}:{self.line}"

    @property
    def kind(self) -> str:
        """'python', 'shell' or 'other' (grammar text, JSON, output, ...)."""
        if self.lang in PYTHON_LANGS:
            return "python"
        if self.lang in SHELL_LANGS:
            return "shell"
        if self.lang == "":
            lines = [ln.strip() for ln in self.code.splitlines() if ln.strip() and not ln.strip().startswith("#")]
            if lines and all(ln.startswith(COMMANDS) or ln.startswith(("  ", "--")) for ln in lines) \
                    and lines[0].startswith(COMMANDS):
                return "shell"
        return "other"


def blocks(path: Path) -> list[Block]:
    out = []
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang = m.group(1), m.group(2), m.group(3).lower()
        start = i
        body = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i])
            i += 1
        i += 1
        marker = lines[start - 1].strip() if start > 0 and lines[start - 1].strip().startswith("<!--") else ""
        out.append(Block(path, start + 1, lang, "\n".join(body) + "\n", marker))
    return out


def all_blocks() -> list[Block]:
    return [b for f in DOC_FILES for b in blocks(f)]


def outputs_of(block: Block, every: list[Block]) -> list[Block]:
    """The `<!-- output -->` blocks that show what `block` prints: those of its file whose
    nearest shell or Python block above them is `block`."""
    shown, current = [], None
    for b in every:
        if b.file != block.file:
            continue
        if b.kind in ("shell", "python"):
            current = b
        elif b.marker == OUTPUT and current is block:
            shown.append(b)
    return shown


# a duration is the one part of a shown output that differs from run to run and machine to machine
DURATION = re.compile(r"\d+(?:\.\d+)?(?= ?(?:s|ms|min)\b)")


def missing_lines(shown: str, printed: str) -> list[str]:
    """The lines of `shown` that `printed` does not contain in the same order (the lines between
    them are free). Durations are compared as any number, and `...` in a shown line stands for
    any text."""
    def pattern(line: str) -> re.Pattern:
        parts = [re.escape(DURATION.sub("\x00", p)).replace("\x00", r"\d+(?:\.\d+)?")
                 for p in line.strip().split("...")]
        return re.compile(".*".join(parts))

    lines = [ln.rstrip() for ln in printed.splitlines()]
    missing, at = [], 0
    for want in (ln for ln in shown.splitlines() if ln.strip()):
        rx = pattern(want)
        hit = next((i for i in range(at, len(lines)) if rx.fullmatch(lines[i].strip())), None)
        if hit is None:
            missing.append(want)
        else:
            at = hit + 1
    return missing
