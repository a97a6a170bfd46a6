"""The closing table of issues 19 and 31: every attack of tests/qa/attack.py run as a user would
(the `grammarkit` command in a subprocess with a timeout and a 4 GB address-space cap),
classified as clear error, traceback, hang, memory over 1 GB, data lost or other; and the
studio's groups (issue 31): its folder confinement (tests/qa/test_confinement.py's catalogue
plus a seeded fuzz of the same paths as tests/qa/test_confinement_fuzz.py, each case through
the studio's Work with an audit hook watching what is opened) and its server (HTTP and
websocket attacks on a running studio).

    python benchmarks/bench_hardening.py [--fast] [-k WORDS] [-v] [--studio-only] [--fuzz N]

Issue 31's groups (data lost: -o naming a device, FIFO or socket, two runs into one folder, a
GLB with a part moved to the scene root; signals in the interpreter's start-up, the first
second and during `train`; time and size; the issue's tracebacks and smaller items) follow the
catalogue; the studio's cases of that issue are in the studio groups.

Prints one line per case (wall seconds, CPU seconds, peak resident memory; the studio cases
wall seconds only, they run in this process) and the table, whose `confinement bypasses`
column counts files used (or opened) outside the studio's folder. Wall times are noisy on a
shared machine; the CPU column is what the size limit is chosen by.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import random
import signal
import socket
import stat
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "qa"))

import attack
from attack import Case, Setup

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
    from grammarkit_studio.work import Work
    from test_confinement import ATTACKS, Attack, make_tree, run_attack
    from test_confinement_fuzz import LOT, SEGMENTS, _escape, _opens, answer_problem

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
    from grammarkit_studio import running
    from test_studio_attacks import STUDIO_ATTACKS

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


# ---------------------------------------------------------------------------------------------
# Issue 31's groups: data lost, signals, time and size, its tracebacks and smaller items, each
# case as a user meets it (one command through attack.run_case, or several processes)
# ---------------------------------------------------------------------------------------------
PARIS = ROOT / "grammars" / "paris.grammar"
CASTLE = ROOT / "grammars" / "tiling" / "castle" / "castle.grammar"
CLI = [sys.executable, "-m", "grammarkit"]


# -- data lost: outputs that are not regular files ---------------------------------------------
def _special(kind: str, name: str, argv: Callable[[str], list[str]]) -> Callable[[Path], Setup]:
    """A case whose output `name` is a FIFO, a symlink to /dev/null or a unix socket that must
    stay what it is (a regular file renamed over it is data lost)."""
    def setup(folder: Path) -> Setup:
        attack._write(folder, "g.grammar", attack.GOOD)
        path = folder / name
        holder = []
        if kind == "fifo":
            os.mkfifo(path)
        elif kind == "devnull":
            path.symlink_to(os.devnull)
        else:
            sock = socket.socket(socket.AF_UNIX)
            sock.bind(str(path))
            holder.append(sock)
        test = {"fifo": stat.S_ISFIFO, "devnull": stat.S_ISCHR, "socket": stat.S_ISSOCK}[kind]

        def check(_folder: Path) -> str | None:
            for s in holder:
                s.close()
            ok = os.path.lexists(path) and test(os.stat(path).st_mode) and \
                (kind != "devnull" or path.is_symlink())
            return None if ok else f"lost: {name} ({kind}) was replaced"
        return Setup(argv(name), check=check)
    return setup


def special_output_cases() -> list[Case]:
    g = "data lost: -o device/FIFO/socket"
    cases = []
    for kind in ("fifo", "devnull", "socket"):
        cases += [
            Case(f"derive -o a {kind}", g, _special(kind, "out.glb", lambda n: ["derive", "g.grammar", "-o", n]),
                 words="not a regular file|named pipe|device|socket"),
            Case(f"derive --variations -o a {kind}", g, _special(
                kind, "out", lambda n: ["derive", "g.grammar", "--variations", "2", "-o", n]),
                words="named pipe|device|socket|not a"),
            Case(f"batch --merge a {kind}", g, _special(kind, "city.glb", lambda n: [
                "batch", "g.grammar", "--variations", "2", "-o", "city", "--merge", n]),
                words="named pipe|device|socket|not a regular"),
            Case(f"derive --preview a {kind}", g, _special(kind, "p.png", lambda n: [
                "derive", "g.grammar", "-o", "a.glb", "--preview", n]), words="named pipe|device|socket|not a"),
            Case(f"import-cga -o a {kind}", g, _cga_to(kind), words="named pipe|device|socket|not a"),
        ]
    return cases


def _cga_to(kind: str) -> Callable[[Path], Setup]:
    inner = _special(kind, "out.grammar", lambda n: ["import-cga", "r.cga", "-o", n])

    def setup(folder: Path) -> Setup:
        attack._write(folder, "r.cga", "Lot --> extrude(3) Mass\n")
        return inner(folder)
    return setup


# -- data lost: a GLB edited elsewhere ---------------------------------------------------------
def _moved_node(folder: Path) -> Setup:
    """The castle example's GLB with one part moved to the scene root (as a trimesh or Blender
    edit does): `validate` must read every part or refuse the file naming the node."""
    from grammarkit.dsl import load
    from grammarkit.tiling import load_examples, read_assembly, write_assembly

    asm = load_examples(load(CASTLE))[0]
    path = write_assembly(asm, folder / "castle.glb")
    data = path.read_bytes()
    n = int.from_bytes(data[12:16], "little")
    doc = json.loads(data[20:20 + n])
    scene = doc["scenes"][doc.get("scene", 0)]
    root = doc["nodes"][scene["nodes"][0]]
    moved = root["children"].pop(0)
    scene["nodes"].append(moved)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + n:]
    glb = data[:12] + struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    glb = glb[:8] + struct.pack("<I", len(glb)) + glb[12:]
    edited = folder / "edited.glb"
    edited.write_bytes(glb)
    parts = len(asm.parts)

    def check(_folder: Path) -> str | None:
        out = ((_folder / ".stdout").read_text() + (_folder / ".stderr").read_text())
        try:
            got = len(read_assembly(edited).parts)
        except Exception as exc:  # noqa: BLE001 - a refusal naming the node is fine
            return None if "node" in str(exc) else f"wrong: {exc}"
        if got != parts:
            return f"lost: {got} of {parts} parts read ({out.strip()[-200:]})"
        return None
    return Setup(["validate", str(CASTLE), "edited.glb"], check=check)


# -- time and size ---------------------------------------------------------------------------
def _lots(n: int) -> Callable[[Path], Setup]:
    def setup(folder: Path) -> Setup:
        ring = [[50 * math.cos(2 * math.pi * i / n), 50 * math.sin(2 * math.pi * i / n)] for i in range(n)]
        attack._write(folder, "lots.geojson", json.dumps({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))
        attack._write(folder, "g.grammar", "grammar g\nLot --> extrude(3) Mass.\n")
        return Setup(["batch", "g.grammar", "--lots", "lots.geojson", "-o", "out", "--workers", "1"])
    return setup


def _lots_text(text: str) -> Callable[[Path], Setup]:
    def setup(folder: Path) -> Setup:
        attack._write(folder, "lots.geojson", text)
        attack._write(folder, "g.grammar", "grammar g\nLot --> extrude(3) Mass.\n")
        return Setup(["batch", "g.grammar", "--lots", "lots.geojson", "-o", "out", "--workers", "1"])
    return setup


def _many_rules(folder: Path) -> Setup:
    attack._write(folder, "big.cga", "".join(f"Rule{i} --> extrude({i % 7 + 1}) Rule{i + 1}\n"
                                             for i in range(60_000)))
    return Setup(["import-cga", "big.cga", "-o", "big.grammar"])


def _huge_png(folder: Path) -> Setup:
    """A PNG that claims 20,000 x 20,000 pixels (the header is what a decoder trusts)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 20_000, 20_000, 8, 0, 0, 0, 0)) + \
        chunk(b"IDAT", zlib.compress(b"\0" * 20_001 * 4)) + chunk(b"IEND", b"")
    attack._write(folder, "huge.png", png)
    return Setup(["recognize", "--type", "Window", "huge.png"])


def _pickle_models(folder: Path) -> Setup:
    import pickle

    class Evil:
        def __reduce__(self):
            return (os.system, ("touch pwned",))
    attack._write(folder, "evil.models", pickle.dumps({"format": "grammarkit-sketch-models", "x": Evil()},
                                                      protocol=2))
    attack._write(folder, "c.png", _small_png())

    def check(f: Path) -> str | None:
        err = (f / ".stderr").read_text()
        if (f / "pwned").exists():
            return "lost: the pickle ran"
        return "wrong: repeats torch's weights_only advice" if "weights_only=False" in err else None
    return Setup(["recognize", "--type", "Window", "--models", "evil.models", "c.png"], check=check)


def _small_png() -> bytes:
    import io

    from PIL import Image
    buf = io.BytesIO()
    Image.new("L", (64, 64), 255).save(buf, "PNG")
    return buf.getvalue()


def subprocess_cases() -> list[Case]:
    deep = '{"type": "Polygon", "coordinates": ' + "[" * 100_000 + "]" * 100_000 + "}"
    empty = json.dumps({"type": "Polygon", "coordinates": [[]]})
    return special_output_cases() + [
        Case("validate a GLB with a part moved to the scene root", "data lost: GLB with a moved node",
             _moved_node, status=None, timeout=120),
        Case("a lot outline of 5,000 vertices", "time and size", _lots(5_000), status=None, timeout=120),
        Case("a lot outline of 20,000 vertices", "time and size", _lots(20_000), status=None,
             words="limit per lot", timeout=120),
        Case("import-cga /dev/zero", "time and size", lambda f: Setup(["import-cga", "/dev/zero", "-o", "z.grammar"]),
             words="not a regular file|device"),
        Case("import-cga of 60,000 rules (2.7 MB)", "time and size", _many_rules, words="limit", timeout=120),
        Case("batch lots with an empty ring [[]]", "tracebacks", _lots_text(empty), status=None,
             words="at least 3"),
        Case("batch lots JSON nested 100,000 deep", "tracebacks", _lots_text(deep), words="nested too deeply"),
        Case("recognize a 20,000 x 20,000 PNG", "tracebacks", _huge_png, words="huge.png", timeout=120),
        Case("recognize with a pickle-bearing models file", "smaller", _pickle_models, words="refused",
             timeout=120),
    ]


# -- cases of several processes: two runs into one folder, signals ------------------------------
def _manifest(out: Path) -> list[dict]:
    m = out / "manifest.jsonl"
    return [json.loads(x) for x in m.read_text().splitlines()] if m.exists() else []


def _consistent(out: Path) -> str | None:
    if not out.exists():
        return None
    entries = _manifest(out)
    if len({e["id"] for e in entries}) != len(entries):
        return "lost: ids listed twice"
    if {q.name for q in out.glob("*.glb")} != {e["file"] for e in entries}:
        return "lost: files and manifest differ"
    if (out / ".grammarkit.lock").exists():
        return "lost: the lock was left"
    return None


def two_runs(tmp: Path, command: str) -> tuple[str, str]:
    out = tmp / "out"
    first = subprocess.Popen([*CLI, command, str(PARIS), "--variations", "8", "--seed", "7", "--workers", "1",
                              "-o", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    end = time.monotonic() + 300
    while first.poll() is None and not (out / ".grammarkit.lock").exists() and time.monotonic() < end:
        time.sleep(0.02)
    second = subprocess.run([*CLI, command, str(PARIS), "--variations", "8", "--seed", "8", "--workers", "1",
                             "-o", str(out)], check=False, capture_output=True, text=True, timeout=600)
    try:
        first.wait(timeout=600)
    except subprocess.TimeoutExpired:
        first.kill()
        return "hang", "the first run did not end"
    err = first.stderr.read() + second.stderr
    if attack.TRACEBACK in err:
        return "traceback", err[-400:]
    problem = _consistent(out)
    if problem:
        return "lost", problem
    seed = json.loads((out / "run.json").read_text()).get("seed") if (out / "run.json").exists() else None
    if second.returncode == 0 or seed != 7 or len(_manifest(out)) != 8:
        return "lost", f"second run exit {second.returncode}, run.json seed {seed}, {len(_manifest(out))} listed"
    return "clear", ""


SIGNAL_COMMANDS = {
    "batch": ["batch", str(PARIS), "--variations", "300", "--workers", "1"],
    "derive --variations": ["derive", str(PARIS), "--variations", "300", "--workers", "1"],
    "derive -n (graph sampler, 2 workers)": ["derive", str(CASTLE), "-n", "300", "--workers", "2"],
}


def signal_case(tmp: Path, command: str, sig: int, delay: float, ignored: bool = False) -> tuple[str, str]:
    from test_outputs_locks_signals import signal_at

    out = tmp / "out"
    code, err = signal_at(SIGNAL_COMMANDS[command], out, sig, delay, ignored=ignored)
    if code is None:
        return "hang", "still running 60 s after the signal"
    if code == 0:
        return "wrong", "exit 0: the signal was ignored"
    if code == 130 and attack.TRACEBACK in err:
        return "traceback", err[-400:]
    return ("lost", problem) if (problem := _consistent(out)) else ("clear", "")


def train_signal_case(tmp: Path, sig: int) -> tuple[str, str]:
    from test_train_signals import OLD_MODEL, make_castle_dataset

    ds = make_castle_dataset(tmp / "ds")
    model = tmp / "models" / "castle.vae"
    model.parent.mkdir()
    model.write_bytes(OLD_MODEL)
    p = subprocess.Popen([*CLI, "train", "string-vae", str(ds), "-o", str(model), "--epochs", "100000",
                          "--hidden", "8", "--latent", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    lines = []
    for line in p.stderr:  # the signal lands once training runs: the second epoch reported
        lines.append(line)
        if line.startswith("epoch 2/"):
            break
    p.send_signal(sig)
    try:
        code = p.wait(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        return "hang", "still training 120 s after the signal"
    err = "".join(lines) + p.stderr.read()
    if attack.TRACEBACK in err:
        return "traceback", err[-400:]
    if model.read_bytes() != OLD_MODEL or sorted(q.name for q in model.parent.iterdir()) != [model.name]:
        return "lost", "the earlier model changed or a temporary file was left"
    return ("clear", "") if code == 130 and "interrupted" in err else ("wrong", f"exit {code}")


def process_cases(words: str) -> list[tuple[str, str, Callable[[Path], tuple[str, str]]]]:
    """(group, name, run(tmp folder) -> (verdict, detail)) of the cases of several processes."""
    cases: list[tuple[str, str, Callable[[Path], tuple[str, str]]]] = []
    for command in ("batch", "derive"):
        cases.append(("data lost: two runs into one folder", f"two {command} runs, seeds 7 and 8",
                      lambda t, c=command: two_runs(t, c)))
    for command in SIGNAL_COMMANDS:
        for sig, delay in ((signal.SIGTERM, 0.0), (signal.SIGINT, 0.1), (signal.SIGTERM, 0.3),
                           (signal.SIGINT, 0.6), (signal.SIGTERM, 1.0)):
            cases.append(("signals", f"{command}: {sig.name} at {delay:g} s",
                          lambda t, c=command, s=sig, d=delay: signal_case(t, c, s, d)))
        cases.append(("signals", f"{command}: SIGINT at 0.6 s, started with SIGINT ignored",
                      lambda t, c=command: signal_case(t, c, signal.SIGINT, 0.6, ignored=True)))
    for sig in (signal.SIGINT, signal.SIGTERM):
        cases.append(("signals", f"train string-vae: {sig.name} mid-run",
                      lambda t, s=sig: train_signal_case(t, s)))
    return [c for c in cases if words in c[1].lower()]


def run_process_case(run: Callable[[Path], tuple[str, str]]) -> tuple[str, str, float]:
    with tempfile.TemporaryDirectory(prefix="gk-31-") as tmp:
        t0 = time.perf_counter()
        try:
            verdict, detail = run(Path(tmp))
        except Exception as exc:  # noqa: BLE001 - a crash of the harness is a finding too
            verdict, detail = "traceback", f"{type(exc).__name__}: {exc}"
        return verdict, detail, time.perf_counter() - t0


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
    ap.add_argument("--issue31-only", action="store_true", help="run only issue 31's groups")
    args = ap.parse_args(argv)
    words = args.k.lower()
    rows: list[Row] = []
    if not args.studio_only and not args.issue31_only:
        cases = [c for c in (attack.fast_cases() if args.fast else attack.CASES) if words in c.name.lower()]
        for c in cases:
            o = attack.run_case(c)
            rows.append(Row(c.group, c.name, o.verdict, o.seconds, o.detail,
                            f"{o.cpu:6.1f} s CPU {o.peak_mb:7.0f} MB", o.output))
            _show(rows[-1], args.v)
    if not args.studio_only:  # issue 31's groups
        for c in subprocess_cases():
            if words in c.name.lower():
                o = attack.run_case(c)
                rows.append(Row(c.group, c.name, o.verdict, o.seconds, o.detail,
                                f"{o.cpu:6.1f} s CPU {o.peak_mb:7.0f} MB", o.output))
                _show(rows[-1], args.v)
        for group, name, run in process_cases(words):
            verdict, detail, seconds = run_process_case(run)
            rows.append(Row(group, name, verdict, seconds, detail))
            _show(rows[-1], args.v)
    if args.issue31_only:
        print("\n" + table(rows))
        return 0 if all(r.verdict == "clear" for r in rows) else 1
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
