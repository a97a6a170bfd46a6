"""Speed of the .grammar front end: parse, parse+check, print, per example grammar and a ~1 MB file.

    python benchmarks/bench_parse.py [--runs 5] [--size-mb 1.0]

Prints a table with the median over --runs of each step and, as the baseline measured in the same
run, the time of Lark's lexer alone over the same text (the floor for any parse): `x lex` is how
many times slower the full parse + check is than tokenising.
"""
from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from grammarkit.dsl import check, parse  # noqa: E402
from grammarkit.dsl.parser import get_parser  # noqa: E402
from grammarkit.printer import print_grammar  # noqa: E402
from _timing import median_time  # noqa: E402 - benchmarks/ is on sys.path




def generated_grammar(size_bytes: int) -> str:
    """A large, valid grammar: copies of the example grammars' rules with renamed symbols."""
    sources = [p.read_text(encoding="utf-8") for p in sorted((ROOT / "grammars").glob("*.grammar"))]
    # self-contained files only (imports are not followed here)
    body = [re.sub(r"^grammar .*$", "", s, flags=re.M) for s in sources if "import " not in s]
    names = re.compile(r"\b(?!Start\b)([A-Z][A-Za-z0-9_]*|[a-z_][a-z0-9_]*_[a-z0-9_]+)\b")
    out = ["grammar generated"]
    k = 0
    size = 0
    while size < size_bytes:
        for i, text in enumerate(body):
            # suffix capitalised and snake_case names: new rules, attrs and snippets per copy
            chunk = names.sub(lambda m, tag=f"{i}_{k}": f"{m.group(1)}_{tag}", text)
            out.append(chunk)
            size += len(chunk)
        k += 1
    return "\n".join(out)


def row(name: str, text: str, runs: int) -> tuple:
    lines = text.count("\n") + 1
    lexer = get_parser()
    t_lex = median_time(lambda: list(lexer.lex(text)), runs)
    t_parse = median_time(lambda: parse(text), runs)
    t_check = median_time(lambda: check(text), runs)
    g = parse(text)
    t_print = median_time(lambda: print_grammar(g), runs)
    return (name, len(text), lines, t_lex, t_parse, t_check, t_print, lines / t_check, t_check / t_lex)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--size-mb", type=float, default=1.0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    get_parser()
    build = time.perf_counter() - t0
    check("A --> NIL")  # load plugins once, outside the timings
    rows = []
    for p in sorted((ROOT / "grammars").glob("**/*.grammar")):
        rows.append(row(str(p.relative_to(ROOT)), p.read_text(encoding="utf-8"), args.runs))
    big = generated_grammar(int(args.size_mb * 1024 * 1024))
    errors = [d for d in check(big) if d.severity == "error"]
    assert not errors, errors[:3]
    rows.append(row(f"generated {len(big) / 1e6:.1f} MB", big, max(1, min(args.runs, 3))))
    print(f"parser build (once per process): {build * 1000:.0f} ms\n")
    head = ("grammar", "chars", "lines", "lex ms", "parse ms", "parse+check ms", "print ms",
            "lines/s", "x lex")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name, chars, lines, lex, p, c, pr, lps, ratio in rows:
        print(f"| {name} | {chars:,} | {lines:,} | {lex * 1000:.1f} | {p * 1000:.1f} | "
              f"{c * 1000:.1f} | {pr * 1000:.1f} | {lps:,.0f} | {ratio:.1f} |")


if __name__ == "__main__":
    main()
