"""The optimised enumeration finds exactly the operations the first implementation found.

The fingerprints below were computed by the code before the speed work (main at 439387c,
plugins/substructure/grammarkit_substructure/search.py as it was there) with `_fingerprint`
as written here: a SHA-256 over every operation in output order, with its cut pairs, both
pieces (complement flag, node list, graph size), the recursion tag, the symmetry size and
the violations. So they pin the set of operations, their order, and how each piece is stored
(listed, or as the complement of the rest), not just their number. The grown castles are the
benchmark's (benchmarks/bench_substructure.py, `grown_castle`), loaded from there so that both
use one definition.
"""
import hashlib
import importlib.util
from pathlib import Path

import pytest

from grammarkit.tiling import read_assembly
from grammarkit_substructure.operations import find_operations
from grammarkit_substructure.shape import Shape

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "grammars" / "tiling"


def _bench():
    path = ROOT / "benchmarks" / "bench_substructure.py"
    spec = importlib.util.spec_from_file_location("bench_substructure", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _fingerprint(ops) -> tuple[int, str]:
    h = hashlib.sha256()
    for o in ops:
        h.update(repr((o.pairs, o.removed_side.complement, o.removed_side.nodes, o.removed_side.n,
                       o.copied_side.complement, o.copied_side.nodes, o.copied_side.n,
                       o.recursive, o.symmetry_size, o.violations)).encode())
    return len(ops), h.hexdigest()


@pytest.fixture(scope="module")
def grown():
    bench = _bench()
    return {n: bench.grown_castle(n).graph for n in (20, 70, 300)}


@pytest.fixture(scope="module")
def examples():
    return {p.stem: Shape.from_assembly(read_assembly(p)).graph for p in sorted(EXAMPLES.glob("*/*.glb"))}


@pytest.mark.parametrize("n,q,expected", [
    (20, 0, (230, "41f9d4877a1d6cd0154d8542ae7e017708c31373c6657062e669fc58ef5e54b9")),
    (70, 0, (2565, "062e5bffa51a2c8e33b77f4dae74c37eb474f69ea4fc667c80458a09197094e9")),
    (70, 1, (2530, "57d85f479efd3a32dbbb8f8e7b9e7fa1ef079c73059d64a62289d8b7cec0bed4")),
    (300, 0, (48034, "75525086f0410b89a34dc85b3c5883cd52bf8003a9015c1e54ef85e8e3bf9d37")),
])
def test_grown_castles_keep_their_operations(grown, n, q, expected):
    assert _fingerprint(find_operations(grown[n], q=q)) == expected


@pytest.mark.parametrize("stem,q,expected", [
    ("track_long", 0, (818, "dcf757545b9503542d2c744168dd90aedbc6933efeee3a243d31ac27356df55f")),
    ("track_long", 2, (766, "423c4a8439d03f24f2b1d0b55c7932f155a5ab92929bd6f857c01728ec0f0200")),
    ("castle_large", 0, (670, "dd463e2808d657ad24d5337619ec03fa9372571b44defcd2a79de5b8ec71c3da")),
    ("facade_large", 0, (415, "acd3e9f3b1af7df0f5bdc329433da6006451b0ab1ed27b1c83d5db1d20b1ea22")),
    ("facade_large", 1, (431, "9e19c3081a76a49998c8971034c8e581d5e612621b9ae37197a722c450409a8f")),
    ("coast_5x6_h3_r90", 0, (242, "9cb1a5b020cbae72b6076ce6036c1eaa635b2e43801ca8cd8a9a425c3afa3391")),
    ("coast_6x5_h2_r0", 2, (189, "803780f2de68464e15429cf9e5cb4baf1697c31691299c43da4135b7de741b7e")),
])
def test_tiling_examples_keep_their_operations(examples, stem, q, expected):
    assert _fingerprint(find_operations(examples[stem], q=q)) == expected


@pytest.mark.parametrize("donor,host,q,expected", [
    ("castle_small", "castle_large", 0, (390, "b06c2775ff0fc2ad5138deeb8189e2ed1c87faf895b8d37e52b51c50c92f51bb")),
    ("castle_large", "castle_small", 1, (389, "fb654bf90f732c79f4640668fe2397f6eb2b2c0ae1d07561150e198a2ff4ce5e")),
    ("facade_small", "facade_large", 1, (295, "96c1284c2e22c372e7b88b4b4da53c5b627f6cc9723cdbf3de5131f63e298d77")),
    ("track_short", "track_long", 0, (386, "6d41956a4ecb58636e92502e2743a401100ed1a76af77360486ca2995bd87f0f")),
])
def test_donor_into_another_host_keeps_its_operations(examples, donor, host, q, expected):
    assert _fingerprint(find_operations(examples[donor], examples[host], q=q)) == expected


def test_a_grown_donor_into_an_example_keeps_its_operations(grown, examples):
    got = _fingerprint(find_operations(examples["castle_small"], grown[70]))
    assert got == (782, "3ffccd2e5e234a0259c509a34f9809381907c3c26de93e18a10f6ebea7acf308")
    got = _fingerprint(find_operations(grown[70], examples["castle_small"]))
    assert got == (782, "d17d375d07356df479c24019ece11c9db4ad899c7168a292820e29b56501eb15")


def test_the_garbage_collector_is_restored():
    import gc

    g = Shape.from_assembly(read_assembly(EXAMPLES / "castle" / "castle_small.glb")).graph
    assert gc.isenabled()
    find_operations(g)
    assert gc.isenabled()
    gc.disable()
    try:
        find_operations(g)
        assert not gc.isenabled()  # left as the caller had it
    finally:
        gc.enable()
