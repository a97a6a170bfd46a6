"""Every failure of issue 19, reproduced as a user meets it: the `grammarkit` command in a
subprocess under a timeout and an address-space cap (tests/qa/attack.py). Each must end with a
clear error and the expected exit status (1; 2 for command-line usage errors), never a
traceback, a hang, more than 1 GB of memory, or a lost file.

The worst grammars of ordinary constructs at the size limit must check within 1 GB and end in
bounded time. That bound is a guard against a hang or a blow-up (each case's budget, 60 s of CPU,
three times the worst case measured), not a speed figure: the speed of `check` on these files is
measured by `benchmarks/bench_parse.py --worst` (the worst, long chains, takes ~18 s of CPU on a
quiet 2-core machine and ~24 s on CI's, where the other pytest worker shares the cores)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import attack  # noqa: E402


@pytest.mark.parametrize("case", attack.fast_cases(), ids=lambda c: c.name)
def test_attack_case_gives_a_clear_error(case, tmp_path):
    outcome = attack.run_case(case, tmp_path)
    assert outcome.verdict == "clear", (
        f"{case.name}: {outcome.verdict}: {outcome.detail}\n--- output ---\n{outcome.output[-3000:]}")


BIG = [c for c in attack.CASES if c.big]


@pytest.mark.parametrize("case", BIG, ids=lambda c: c.name)
def test_worst_grammar_at_the_size_limit_checks_in_bounded_time_and_memory(case, tmp_path):
    outcome = attack.run_case(case, tmp_path)
    assert outcome.verdict == "clear", f"{case.name}: {outcome.verdict}: {outcome.detail}\n{outcome.output[-2000:]}"
    # CPU time, not wall time: the test machine is shared, so wall time says little
    assert outcome.cpu <= case.timeout, f"{case.name}: {outcome.cpu:.1f} s of CPU"
    assert outcome.peak_mb <= 1024, f"{case.name}: {outcome.peak_mb:.0f} MB"


def test_worst_grammars_fill_the_limit():
    """The generated worst cases are really at the limit (and just under it)."""
    limit = attack.size_limit()
    for kind, text in attack.worst_grammars().items():
        size = len(text.encode("utf-8"))
        assert limit - 4096 < size <= limit, (kind, size)


def test_one_byte_over_the_limit_is_refused(tmp_path):
    from grammarkit.dsl import DEFAULT_MAX_BYTES, check

    p = tmp_path / "over.grammar"
    p.write_text("A --> B.\n" + "#" * (DEFAULT_MAX_BYTES - 9) + "\n", encoding="utf-8")
    assert p.stat().st_size == DEFAULT_MAX_BYTES + 1
    (d,) = check(p)
    assert d.code == "too-large" and d.span.file == str(p)
