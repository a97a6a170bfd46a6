"""The closing table of issues 19 and 31: every attack of tests/qa/attack.py run as a user would
(the `grammarkit` command in a subprocess with a timeout and a 4 GB address-space cap),
classified as clear error, traceback, hang, memory over 1 GB, data lost or other; and the
studio's groups (issue 31): its folder confinement (tests/qa/test_confinement.py's catalogue
plus a seeded fuzz of the same paths as tests/qa/test_confinement_fuzz.py, each case through
the studio's Work with an audit hook watching what is opened) and its server (HTTP and
websocket attacks on a running studio).

    python benchmarks/bench_hardening.py [--fast] [-k WORDS] [-v] [--studio-only] [--fuzz N]

Prints one line per case (wall seconds, CPU seconds, peak resident memory; the studio cases
wall seconds only, they run in this process) and the table, whose `confinement bypasses`
column counts files used (or opened) outside the studio's folder. Wall times are noisy on a
shared machine; the CPU column is what the size limit is chosen by.
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "qa"))

import attack  # noqa: E402

COLUMNS = ["clear", "traceback", "hang", "memory", "lost", "bypass", "wrong"]
HEADINGS = {"clear": "clear errors", "traceback": "tracebacks", "hang": "hangs", "memory": "memory > 1 GB",
            "lost": "data lost", "bypass": "confinement bypasses", "wrong": "other"}


@dataclass
class Row:
    group: str
    name: str
    verdict: str
    seconds: float
    detail: str = ""
    usage: str = ""  # CPU and memory of a subprocess case
    output: str = ""


def _show(r: Row, verbose: bool) -> None:
    print(f"{r.verdict:9s} {r.seconds:6.1f} s {r.usage}  {r.name}" + (f"  -- {r.detail[:300]}" if r.detail else ""),
          flush=True)
    if verbose and r.verdict != "clear" and r.output:
        print("    " + r.output.strip()[-1500:].replace("\n", "\n    "))


def confinement_rows(fuzz: int, words: str) -> list[Row]:
    """The catalogue of confinement attacks and `fuzz` seeded random paths, through Work."""
    from test_confinement import ATTACKS, Attack, make_tree, run_attack
    from test_confinement_fuzz import LOT, SEGMENTS, _escape, _opens, answer_problem

    from grammarkit_studio.work import Work

    rows = []
    with tempfile.TemporaryDirectory(prefix="gk-confine-") as tmp:
        tree = make_tree(Path(tmp))
        work = Work(str(tree.grammar), str(tree.root))
        opens = _opens()
        rng = random.Random(31)
        cases = [("studio confinement", a, None, None) for a in ATTACKS if words in a.name.lower()]
        for k in range(fuzz if words in "fuzz" else 0):
            segs = [rng.choice(SEGMENTS) for _ in range(rng.randint(1, 6))]
            path = rng.choice(["", "", "/", f"{tree.base}/", f"{tree.root}/"]) + "/".join(segs)
            mask = [rng.random() < 0.4 for _ in range(5)]
            sink = rng.choice(["i", "texture", "import"])
            lit = f'"{_escape(path, mask)}"'
            if sink == "import":
                a = Attack(f"fuzz {k}", f"grammar g\nimport {lit}\n{LOT}A.\n", "check")
            else:
                a = Attack(f"fuzz {k}", f"grammar g\nconst p = {lit}\n{LOT}{sink}(p) A.\n")
            cases.append(("studio confinement fuzz", a, path, sink))
        for group, a, path, sink in cases:
            opens.watch, opens.seen, opens.active = os.path.realpath(tree.base), [], True
            t0 = time.perf_counter()
            try:
                verdict, detail = run_attack(work, a, tree)
            finally:
                opens.active = False
            seconds = time.perf_counter() - t0
            root = os.path.realpath(tree.root)
            outside = [p for p in opens.seen if not (p == root or p.startswith(root + os.sep))]
            if outside:
                verdict, detail = "bypass", f"opened outside: {outside[:3]}"
            elif path is not None:  # judged as the fuzz test judges (tests/qa/test_confinement_fuzz.py)
                problem = answer_problem(tree, path, sink, verdict)
                verdict, detail = ("clear", "") if problem is None else (
                    "traceback" if verdict == "traceback" else "wrong", f"{problem}: {detail}")
            rows.append(Row(group, a.name if path is None else f"{a.name}: {sink} {path!r}", verdict,
                            seconds, detail))
    return rows


def _baseline(fuzz: int, words: str) -> tuple[int, int]:
    """(bypasses, cases) of the confinement cases when grammarkit.confine refuses nothing."""
    from unittest import mock

    from grammarkit import confine

    with mock.patch.object(confine, "refusal", lambda *a, **k: None):
        rows = confinement_rows(fuzz, words)
    return sum(r.verdict == "bypass" for r in rows), len(rows)


def server_rows(words: str) -> list[Row]:
    from test_studio_attacks import STUDIO_ATTACKS

    from grammarkit_studio import running

    rows = []
    with tempfile.TemporaryDirectory(prefix="gk-studio-") as tmp:
        path = Path(tmp) / "g.grammar"
        path.write_text(attack.GOOD)
        with running(path, poll=0.5) as studio:
            for name, fn in STUDIO_ATTACKS:
                if words not in name.lower():
                    continue
                t0 = time.perf_counter()
                try:
                    verdict, detail = fn(studio)
                except Exception as exc:  # noqa: BLE001 - a crash of the attack is a finding
                    verdict, detail = "traceback", f"{type(exc).__name__}: {exc}"
                rows.append(Row("studio server", name, verdict, time.perf_counter() - t0, detail))
    return rows


def table(rows: list[Row]) -> str:
    """attack.table's table with a confinement-bypasses column (one Counter per group)."""
    from collections import Counter

    counts: dict[str, Counter] = {}
    for r in rows:
        counts.setdefault(r.group, Counter())[r.verdict] += 1
    counts["total"] = sum(counts.values(), Counter())
    out = ["| group | cases | " + " | ".join(HEADINGS[c] for c in COLUMNS) + " |",
           "|" + "---|" * (len(COLUMNS) + 2)]
    out += [f"| {g} | {c.total()} | " + " | ".join(str(c[k]) for k in COLUMNS) + " |" for g, c in counts.items()]
    return "\n".join(out)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-k", default="", help="run only cases whose name contains this")
    ap.add_argument("--fast", action="store_true", help="leave out the big-file cases")
    ap.add_argument("-v", action="store_true", help="print the output of failing cases")
    ap.add_argument("--studio-only", action="store_true", help="run only the studio's groups")
    ap.add_argument("--fuzz", type=int, default=300, help="random paths of the confinement fuzz")
    args = ap.parse_args(argv)
    words = args.k.lower()
    rows: list[Row] = []
    if not args.studio_only:
        cases = [c for c in (attack.fast_cases() if args.fast else attack.CASES) if words in c.name.lower()]
        for c in cases:
            o = attack.run_case(c)
            rows.append(Row(c.group, c.name, o.verdict, o.seconds, o.detail,
                            f"{o.cpu:6.1f} s CPU {o.peak_mb:7.0f} MB", o.output))
            _show(rows[-1], args.v)
    baseline = _baseline(args.fuzz, words)
    for r in confinement_rows(args.fuzz, words) + server_rows(words):
        rows.append(r)
        if args.v or r.verdict != "clear" or r.group != "studio confinement fuzz":
            _show(r, args.v)
    print()
    print(table(rows))
    if baseline[1]:
        print(f"\nbaseline in the same run, grammarkit.confine switched off: {baseline[0]} of {baseline[1]} "
              "confinement cases read or list a file outside the folder (the rest name no file there)")
    return 0 if all(r.verdict == "clear" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
