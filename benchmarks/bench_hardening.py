"""The closing table of issue 19: every attack of tests/qa/attack.py run as a user would (the
`grammarkit` command in a subprocess with a timeout and a 4 GB address-space cap), classified
as clear error, traceback, hang, memory over 1 GB, data lost or other.

    python benchmarks/bench_hardening.py [--fast] [-k WORDS] [-v]

Prints one line per case (wall seconds, CPU seconds, peak resident memory) and the table. Wall
times are noisy on a shared machine; the CPU column is what the size limit is chosen by.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "qa"))

import attack  # noqa: E402

if __name__ == "__main__":
    sys.exit(attack.main(sys.argv[1:]))
