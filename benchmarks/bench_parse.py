"""Speed of the .grammar front end: parse, parse+check, print, per example grammar and a ~1 MB file.

    python benchmarks/bench_parse.py [--runs 5] [--size-mb 0.4] [--worst]

With --worst, a second table splits `check` of the worst grammars at the size limit
(tests/qa/attack.py: long chains, push/pop, many errors, ...) into its shares: lexing, the
LALR parse, the tree -> IR transform, the checker, and formatting every diagnostic with its
source line, each the median of --runs runs, in CPU seconds (time.process_time: the machine is
shared, so wall time is noisy).

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
    ap.add_argument("--size-mb", type=float, default=0.4,
                    help="size of the generated grammar (under the 512 KiB limit)")
    ap.add_argument("--worst", action="store_true", help="also the worst cases' shares")
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


def cpu_median(fn, runs: int) -> float:  # noqa: ANN001
    """Median CPU time of fn, each run after a full collection and with the GC paused (as the
    front end runs), so that one stage does not pay for the garbage of the previous one."""
    import gc

    from grammarkit.gcpause import paused_gc

    times = []
    for _ in range(runs):
        gc.collect()
        with paused_gc():
            t = time.process_time()
            fn()
            times.append(time.process_time() - t)
    return sorted(times)[len(times) // 2]


def worst_shares(runs: int) -> None:
    """Where `check` of the worst files at the size limit spends its time."""
    sys.path.insert(0, str(ROOT / "tests" / "qa"))
    import attack

    from grammarkit.dsl import DEFAULT_MAX_BYTES
    from grammarkit.dsl.checker import check_grammar
    from grammarkit.dsl.frontend import parse_source
    from grammarkit.dsl.parser import parse_tree
    from grammarkit.gcpause import paused_gc
    from grammarkit.plugins import builtin_registries

    registries = builtin_registries()
    head = ("worst case", "KB", "lex s", "parse s", "transform s", "checker s", "diagnostics s",
            "diagnostics", "total s", "x lex")
    print(f"\nworst grammars at the size limit ({DEFAULT_MAX_BYTES // 1024} KiB), CPU seconds, "
          f"median of {runs}\n")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    lexer = get_parser()
    for kind, text in attack.worst_grammars().items():
        t_lex = cpu_median(lambda: list(lexer.lex(text)), runs)
        t_tree = cpu_median(lambda: parse_tree(text, "w.grammar"), runs)
        t_ir = cpu_median(lambda: parse_source(text, "w.grammar"), runs) - t_tree
        parsed = parse_source(text, "w.grammar")
        diags = list(parsed.diagnostics)
        t_check = 0.0
        if parsed.grammar is not None and not diags:
            t_check = cpu_median(lambda: check_grammar(parsed.grammar, registries, None), runs)
            with paused_gc():
                diags = check_grammar(parsed.grammar, registries, None)
        t_diag = cpu_median(lambda: [d.format(text) for d in diags], runs)
        total = t_tree + t_ir + t_check + t_diag
        print(f"| {kind} | {len(text.encode()) // 1024} | {t_lex:.2f} | {t_tree - t_lex:.2f} | "
              f"{t_ir:.2f} | {t_check:.2f} | {t_diag:.2f} | {len(diags):,} | {total:.2f} | "
              f"{total / t_lex:.1f} |", flush=True)
    print("\n(parse s excludes the lexing it includes; the CLI adds ~0.4 s of start-up and "
          "prints at most 200 diagnostics)")


if __name__ == "__main__":
    main()
    if "--worst" in sys.argv:
        worst_shares(max(1, min(3, int(sys.argv[sys.argv.index("--runs") + 1])
                                if "--runs" in sys.argv else 3)))
