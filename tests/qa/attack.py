"""Reproductions of every failure of issue 19 (hardening), run as a user would: the `grammarkit`
command in a subprocess, under a CPU-time budget and an address-space cap.

Each case builds its inputs in a fresh folder, runs one command and is classified:

- ``clear``: the expected exit status, no traceback, the expected words in the output;
- ``traceback``: Python's "Traceback (most recent call last)" reached the user;
- ``hang``: the command used more CPU time than the case's budget, or slept ten times as long
  (its process group is killed);
- ``memory``: the peak resident memory passed 1 GB (measured with wait4's rusage);
- ``lost``: a file that had to survive was changed or removed;
- ``wrong``: any other unexpected result (wrong status, message without the expected words).

`python tests/qa/attack.py` prints the table of the closing note; tests/qa/test_attack.py runs
every case as a test. The big-file cases (a grammar just under the size limit) take seconds
each; `fast_cases()` leaves them out.
"""
from __future__ import annotations

import dataclasses
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[2]
TRACEBACK = "Traceback (most recent call last)"
MEMORY_CAP = 4 << 30  # address space: a runaway case fails inside the cap, not the machine
MEMORY_LIMIT = 1 << 30  # peak resident memory a case may use
SIZE_LIMIT = None  # filled lazily: grammarkit.dsl.DEFAULT_MAX_BYTES


def size_limit() -> int:
    global SIZE_LIMIT
    if SIZE_LIMIT is None:
        from grammarkit.dsl import DEFAULT_MAX_BYTES
        SIZE_LIMIT = DEFAULT_MAX_BYTES
    return SIZE_LIMIT


@dataclasses.dataclass
class Setup:
    argv: list[str]
    stdin: bytes | None = None
    env: dict[str, str] = dataclasses.field(default_factory=dict)
    keep: dict[Path, bytes] = dataclasses.field(default_factory=dict)  # files that must survive
    check: Callable[[Path], str | None] | None = None  # extra check of the folder: problem or None
    fsize: int | None = None  # RLIMIT_FSIZE: writes past this many bytes fail (a full disk)


@dataclasses.dataclass
class Case:
    name: str
    group: str
    setup: Callable[[Path], Setup]
    # expected exit status: 1 for errors, 2 for command-line usage errors (click's convention),
    # None for 0 or 1 (only time and memory matter)
    status: int | None = 1
    words: str = ""  # regex the output must contain
    timeout: float = 30.0
    big: bool = False


@dataclasses.dataclass
class Outcome:
    case: Case
    verdict: str
    status: int | None
    seconds: float
    peak_mb: float
    cpu: float
    output: str
    detail: str = ""


WALL_BACKSTOP = 10  # a case asleep (no CPU) is a hang after this many times its budget


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a running process and its reaped children (Linux /proc;
    elsewhere infinity, so the wall clock decides as before)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return float("inf")
    return sum(int(x) for x in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def run_case(case: Case, folder: Path | None = None) -> Outcome:
    own = folder is None
    tmp = tempfile.TemporaryDirectory(prefix="gk-attack-") if own else None
    work = Path(tmp.name) if tmp else folder
    try:
        s = case.setup(work)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [p for p in (s.env.pop("PYTHONPATH", ""), os.environ.get("PYTHONPATH", "")) if p]),
            "GRAMMARKIT_CACHE_DIR": os.environ.get("GRAMMARKIT_CACHE_DIR", str(work / ".cache")),
            "COLUMNS": "200", **s.env}
        out_path, err_path = work / ".stdout", work / ".stderr"
        before = {p: p.read_bytes() if p.exists() else None for p in s.keep}

        fsize = s.fsize

        def limits() -> None:
            resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
            if fsize is not None:  # Python ignores SIGXFSZ, so a write past it fails with EFBIG
                resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
            os.setsid()

        with open(out_path, "wb") as out, open(err_path, "wb") as err:
            stdin = subprocess.PIPE if s.stdin is not None else subprocess.DEVNULL
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "grammarkit", *s.argv], cwd=work,
                                    stdin=stdin, stdout=out, stderr=err, env=env,
                                    preexec_fn=limits)
            if s.stdin is not None:
                try:
                    proc.stdin.write(s.stdin)
                except (BrokenPipeError, OSError):
                    pass  # the command refused to read it all: fine
                try:
                    proc.stdin.close()
                except OSError:
                    pass
            status, usage, hung = None, None, False
            while True:
                pid, wstatus, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    status = os.waitstatus_to_exitcode(wstatus)
                    proc.returncode = status
                    break
                # a hang is judged by work, not by the clock (issue 32: a loaded machine made
                # slow cases "hang"): the command's CPU time past the case's budget, or (a
                # command asleep for good uses none) the wall clock past ten times it
                wall = time.perf_counter() - t0
                if wall > case.timeout and (_cpu_seconds(proc.pid) > case.timeout
                                            or wall > WALL_BACKSTOP * case.timeout):
                    hung = True
                    with _quiet():
                        os.killpg(proc.pid, signal.SIGKILL)
                    _, wstatus, usage = os.wait4(proc.pid, 0)
                    proc.returncode = -9
                    break
                time.sleep(0.02)
            seconds = time.perf_counter() - t0
        output = out_path.read_bytes().decode("utf-8", "replace") + "\n" + \
            err_path.read_bytes().decode("utf-8", "replace")
        peak_mb = usage.ru_maxrss / 1024 if usage else 0.0
        cpu = usage.ru_utime + usage.ru_stime if usage else 0.0
        lost = [str(p.name) for p, data in before.items()
                if data is not None and (not p.exists() or p.read_bytes() != data)]
        extra = s.check(work) if s.check else None
        if hung:
            verdict, detail = "hang", f"killed after {seconds:.0f} s (budget {case.timeout:.0f} s of CPU)"
        elif TRACEBACK in output:
            verdict, detail = "traceback", output[output.index(TRACEBACK):][-600:]
        elif peak_mb * (1 << 20) > MEMORY_LIMIT:
            verdict, detail = "memory", f"{peak_mb:.0f} MB"
        elif lost:
            verdict, detail = "lost", "changed: " + ", ".join(lost)
        elif extra:
            verdict, detail = ("lost" if extra.startswith("lost") else "wrong"), extra
        elif status != case.status and not (case.status is None and status in (0, 1)):
            verdict, detail = "wrong", f"exit status {status}, expected {case.status}"
        elif case.words and not re.search(case.words, output, re.I | re.S):
            verdict, detail = "wrong", f"output lacks /{case.words}/"
        else:
            verdict, detail = "clear", ""
        return Outcome(case, verdict, status, seconds, peak_mb, cpu, output, detail)
    finally:
        if tmp:
            tmp.cleanup()


class _quiet:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return exc[0] is not None and issubclass(exc[0], OSError)


# -- helpers building inputs -----------------------------------------------------------------

GOOD = "grammar g\nLot --> footprint(rect(8, 6)) extrude(9) Mass.\n"


def _write(folder: Path, name: str, text: str | bytes) -> Path:
    p = folder / name
    p.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text, encoding="utf-8")
    return p


def _grammar(text: str, *args: str, cmd: str = "derive", name: str = "g.grammar",
             env: dict | None = None) -> Callable[[Path], Setup]:
    def setup(folder: Path) -> Setup:
        _write(folder, name, text)
        argv = [cmd, name, *args]
        if cmd == "derive" and "-o" not in args:
            argv += ["-o", "out.glb"]
        return Setup(argv, env=dict(env or {}))
    return setup


def _fifo(folder: Path, name: str) -> Path:
    p = folder / name
    os.mkfifo(p)
    return p


def _glb_with_buffer(folder: Path, uri: str) -> Path:
    """A glTF (JSON) whose buffer is the external file `uri`."""
    import json
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": uri, "byteLength": 36}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 0]}],
           "meshes": [{"name": "A", "primitives": [{"attributes": {"POSITION": 0}}]}],
           "nodes": [{"name": "A.0", "mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}
    return _write(folder, "model.gltf", json.dumps(doc))


# A hostile plugin, installed for one command by putting a dist-info folder on PYTHONPATH.
_PLUGIN_HEADER = '''
import sys, time
import pluggy
from grammarkit.registry import OperationSpec, FunctionSpec, ConstraintSpec, ExporterSpec, Param
hookimpl = pluggy.HookimplMarker("grammarkit")
'''


def _plugin(body: str, name: str = "hostile") -> Callable[[Path], dict]:
    def install(folder: Path) -> dict:
        site = folder / "site"
        _write(site, f"{name}_plugin.py", _PLUGIN_HEADER + body)
        dist = site / f"{name}_plugin-0.1.dist-info"
        _write(dist, "METADATA", f"Metadata-Version: 2.1\nName: {name}-plugin\nVersion: 0.1\n")
        _write(dist, "entry_points.txt", f"[grammarkit]\n{name} = {name}_plugin\n")
        return {"PYTHONPATH": str(site)}
    return install


def _with_plugin(body: str, argv: list[str], text: str = GOOD, name: str = "g.grammar",
                 files: dict[str, str] | None = None) -> Callable[[Path], Setup]:
    install = _plugin(body)

    def setup(folder: Path) -> Setup:
        _write(folder, name, text)
        for n, t in (files or {}).items():
            _write(folder, n, t)
        return Setup(list(argv), env=install(folder))
    return setup


# -- big files just under the size limit -------------------------------------------------------

def _fill(unit: Callable[[int], str], head: str = "grammar big\n", tail: str = "",
          limit: int | None = None) -> str:
    """`head`, then unit(0), unit(1), ... while the text stays under the size limit."""
    limit = (limit or size_limit()) - len(tail.encode()) - 64
    parts, size, i = [head], len(head), 0
    while True:
        u = unit(i)
        if size + len(u.encode()) > limit:
            break
        parts.append(u)
        size += len(u.encode())
        i += 1
    parts.append(tail)
    return "".join(parts)


def worst_grammars(limit: int | None = None) -> dict[str, str]:
    """The most expensive grammars of ordinary constructs that fit under the size limit."""
    return {
        "many rules": _fill(lambda i: f"R{i} --> extrude({i % 7 + 1}) comp(f) {{ top: R{i + 1} | side: W. | bottom: NIL }}\n",
                            head="grammar big\nLot --> R0\n", limit=limit),
        "many consts": _fill(lambda i: f"const c{i} = c{i - 1} + {i % 9} * 2\n" if i else "const c0 = 1\n",
                             tail="Lot --> extrude(c0) X.\n", limit=limit),
        "case arms": _fill(lambda i: f"K{i} --> " + " ".join(f"case h == {j}: extrude({j % 5 + 1}) X." for j in range(40))
                           + f" else: K{i + 1}\n", head="grammar big\nattr h = 3\nLot --> K0\n", limit=limit),
        "deep nesting": _fill(lambda i: f"D{i} --> extrude(" + "(" * 40 + "1" + ")" * 40
                              + ") [ t(0, 0, 1) [ s(1, 1, 1) [ r(0, 0, 1) [ B. ] ] ] ]" + f" D{i + 1}\n",
                              head="grammar big\nLot --> D0\n", limit=limit),
        "push/pop": _fill(lambda i: f"P{i} --> [ t(0, 0, {i % 3}) P{i + 1} ] [ s(1, 1, 1) X. ]\n",
                          head="grammar big\nLot --> P0\n", limit=limit),
        "long chains": _fill(lambda i: f"C{i} --> " + " ".join(f"t(0, 0, {k})" for k in range(40)) + f" C{i + 1}\n",
                             head="grammar big\nLot --> C0\n", limit=limit),
        "undefined successors": _fill(lambda i: f"U{i} --> extrude(1) Missing{i} Other{i}\n",
                                      head="grammar big\nLot --> U0\n", limit=limit),
        "unknown operations": _fill(lambda i: f"O{i} --> frobnicate{i}(1, 2) O{i + 1}\n",
                                    head="grammar big\nLot --> O0\n", limit=limit),
        "many errors": _fill(lambda i: f"E{i} --> extrude(x{i}) comp(q) {{ nope: E{i}. }} split(w)\n",
                             head="grammar big\nLot --> E0\n", limit=limit),
        "long expressions": _fill(lambda i: f"const k{i} = " + " + ".join(str(j) for j in range(60)) + "\n",
                                  tail="Lot --> X.\n", limit=limit),
    }


def _big(kind: str) -> Callable[[Path], Setup]:
    def setup(folder: Path) -> Setup:
        _write(folder, "big.grammar", worst_grammars()[kind])
        return Setup(["check", "big.grammar"])
    return setup


# -- the cases ---------------------------------------------------------------------------------

def _same_output(folder: Path) -> Setup:
    g = _write(folder, "s.grammar", GOOD)
    return Setup(["derive", "s.grammar", "-o", "s.grammar", "--format", "glb"],
                 keep={g: g.read_bytes()})


def _tree_same(folder: Path) -> Setup:
    _write(folder, "s.grammar", GOOD)
    return Setup(["derive", "s.grammar", "-o", "x.glb", "--tree", "x.glb"],
                 check=lambda f: "lost: x.glb written" if (f / "x.glb").exists() else None)


def _keep_file(folder: Path, name: str, data: str | bytes, argv: list[str]) -> Setup:
    p = _write(folder, name, data)
    return Setup(argv, keep={p: p.read_bytes()})


def _learn_same(folder: Path) -> Setup:
    src = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
    p = folder / "ex.glb"
    p.write_bytes(src.read_bytes())
    return Setup(["learn", "ex.glb", "-o", "ex.glb"], keep={p: p.read_bytes()})


def _fmt_symlink(folder: Path) -> Setup:
    real = _write(folder, "real.grammar", "grammar g\nLot-->extrude( 9 )   X.\n")
    (folder / "link.grammar").symlink_to(real.name)

    def check(f: Path) -> str | None:
        if not (f / "link.grammar").is_symlink():
            return "lost: the link became a regular file"
        if "extrude( 9 )" in real.read_text():
            return "the real file was not formatted"
        return None
    return Setup(["fmt", "-i", "link.grammar"], check=check)


def _fifo_grammar(folder: Path) -> Setup:
    _fifo(folder, "pipe.grammar")
    return Setup(["check", "pipe.grammar"])


def _fifo_buffer(folder: Path) -> Setup:
    _fifo(folder, "buf.bin")
    _glb_with_buffer(folder, "buf.bin")
    return Setup(["render", "model.gltf", "-o", "m.png"])


def _fifo_insert(folder: Path) -> Setup:
    _fifo(folder, "buf.bin")
    _glb_with_buffer(folder, "buf.bin")
    _write(folder, "g.grammar", 'Lot --> extrude(3) i("model.gltf") X.\n')
    return Setup(["derive", "g.grammar", "-o", "o.glb"])


FACADE = """Lot --> footprint(rect(40, 20)) extrude(30) comp(f) { side: F | top: T. | bottom: NIL }
F --> split(y) { { ~1: split(x) { { ~1: W }* } }* }
W --> extrude(0.3) X.
"""


def _full_disk(folder: Path) -> Setup:
    """A write that fails half-way (RLIMIT_FSIZE stands for a full disk): the error names the
    user's path, not the temporary file, and the model that was there stays whole."""
    _write(folder, "g.grammar", FACADE)
    old = _write(folder, "paris.glb", b"an earlier model")
    return Setup(["derive", "g.grammar", "-o", "paris.glb"], fsize=64 * 1024,
                 keep={old: old.read_bytes()},
                 check=lambda f: "a temporary file was left behind" if list(f.glob(".paris*")) else None)


def _folder_as_file(cmd: str) -> Callable[[Path], Setup]:
    def setup(folder: Path) -> Setup:
        (folder / "d.grammar").mkdir()
        (folder / "m.glb").mkdir()
        argv = {"check": ["check", "d.grammar"], "derive": ["derive", "d.grammar", "-o", "o.glb"],
                "fmt": ["fmt", "d.grammar"], "render": ["render", "m.glb", "-o", "m.png"],
                "validate": ["validate", "t.grammar", "m.glb"]}[cmd]
        _write(folder, "t.grammar", (ROOT / "grammars/tiling/castle/castle.grammar").read_text()
               .replace('"castle_small.glb"', f'"{ROOT}/grammars/tiling/castle/castle_small.glb"')
               .replace('"castle_large.glb"', f'"{ROOT}/grammars/tiling/castle/castle_large.glb"'))
        return Setup(argv)
    return setup


def _missing_dependency(folder: Path) -> Setup:
    # a `manifold3d` that cannot be imported stands for an optional dependency not installed
    site = folder / "blocker"
    _write(site, "manifold3d/__init__.py", "raise ImportError('No module named manifold3d')\n")
    _write(site, "trimesh/__init__.py", "raise ImportError('No module named trimesh')\n")
    src = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
    (folder / "m.glb").write_bytes(src.read_bytes())
    return Setup(["render", "m.glb", "-o", "m.png"], env={"PYTHONPATH": str(site)})


def _hip_roof(n: int) -> str:
    import math
    pts = ", ".join(f"{10 * math.cos(2 * math.pi * k / n):.4f}, {10 * math.sin(2 * math.pi * k / n):.4f}"
                    for k in range(n))
    return (f"Lot --> footprint(polygon({pts})) extrude(5) comp(f) {{ top: R | side: W. | bottom: NIL }}\n"
            "R --> roofHip(30) Roof.\n")


_NEIGHBORS = """grammar t
part A = mesh("{glb}", "Wall.0")
part B = mesh("{glb}", "Tower.0")
neighbors A: {{B}}
neighbors B: {{A}}
constraint count(A, {n})
"""


def _tiling_count(folder: Path) -> Setup:
    glb = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
    _write(folder, "t.grammar", _NEIGHBORS.format(glb=glb, n="9" * 5000))
    return Setup(["check", "t.grammar"])


def _api_check_big_int(folder: Path) -> Setup:
    glb = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
    text = f"grammar t\npart A = mesh(\"{glb}\", \"Wall.0\")\nneighbors A in {'9' * 5000}: {{A}}\n"
    _write(folder, "t.grammar", text)
    code = ("import grammarkit, sys\nr = grammarkit.check(open('t.grammar').read(), filename='t.grammar')\n"
            "print(r)\nsys.exit(1 if any(d.severity == 'error' for d in (getattr(r, 'diagnostics', None) or r)) else 0)\n")
    _write(folder, "api.py", code)
    return Setup(["check", "t.grammar"])


def _stdin_zeros(folder: Path) -> Setup:
    return Setup(["fmt", "-"], stdin=b"\0" * (64 << 20))


PLUGIN_OP_BAD_RESULT = '''
def _apply(ctx, shape, args, block):
    return 42
@hookimpl
def grammarkit_operations():
    return [OperationSpec("weird", params=(), apply=_apply)]
'''
PLUGIN_FN_RAISES = '''
def _boom(*a, **k):
    raise RuntimeError("boom")
@hookimpl
def grammarkit_functions():
    return [FunctionSpec("boom", 0, 1, impl=_boom)]
'''
PLUGIN_OP_RAISES = '''
def _apply(ctx, shape, args, block):
    raise ValueError("bad op")
@hookimpl
def grammarkit_operations():
    return [OperationSpec("explode", params=(), apply=_apply)]
'''
PLUGIN_OP_SLOW = '''
def _apply(ctx, shape, args, block):
    time.sleep(600)
@hookimpl
def grammarkit_operations():
    return [OperationSpec("slow", params=(), apply=_apply)]
'''
PLUGIN_OP_EXIT = '''
def _apply(ctx, shape, args, block):
    sys.exit(0)
@hookimpl
def grammarkit_operations():
    return [OperationSpec("quit", params=(), apply=_apply)]
'''
PLUGIN_CONSTRAINT_RAISES = '''
def _check(graph, args, context):
    raise RuntimeError("constraint boom")
@hookimpl
def grammarkit_constraints():
    return [ConstraintSpec("crashy", check=_check)]
'''
PLUGIN_CONSTRAINT_NONE = '''
def _check(graph, args, context):
    return None  # forgot to return its violations: must not pass every shape
@hookimpl
def grammarkit_constraints():
    return [ConstraintSpec("lazy", check=_check)]
'''
PLUGIN_IMPORT_HANGS = '''
time.sleep(600)
'''
PLUGIN_IMPORT_EXITS = '''
sys.exit(0)
'''
PLUGIN_IMPORT_PRINTS = '''
print("hello from a plugin")
'''
PLUGIN_GARBAGE = '''
@hookimpl
def grammarkit_operations():
    return ["nonsense", None, FunctionSpec("f", 0, 0)]
@hookimpl
def grammarkit_exporters():
    return 17
@hookimpl
def grammarkit_cli_commands():
    return [None]
'''
PLUGIN_REPLACES_BUILTIN = '''
@hookimpl(trylast=True)
def grammarkit_operations():
    return [OperationSpec("extrude", params=(Param("h", "number"),), apply=lambda *a: None)]
@hookimpl(tryfirst=True)
def grammarkit_exporters():
    return [ExporterSpec("glb", (".glb",), encode=lambda model: b"")]
'''
PLUGIN_EMPTY_EXPORTER = '''
@hookimpl
def grammarkit_exporters():
    return [ExporterSpec("void", (".void",), encode=lambda model: b"")]
'''


def _validate_with_constraint(plugin: str, name: str) -> Callable[[Path], Setup]:
    """`validate` of the castle with a plugin's constraint `name` added to the grammar."""
    def setup(folder: Path) -> Setup:
        glb = ROOT / "grammars" / "tiling" / "castle" / "castle_small.glb"
        text = (ROOT / "grammars/tiling/castle/castle.grammar").read_text().replace(
            '"castle_small.glb"', f'"{glb}"').replace(
            'example castle_large = assembly("castle_large.glb")', "") + f"constraint {name}\n"
        _write(folder, "t.grammar", text)
        return Setup(["validate", "t.grammar"], env=_plugin(plugin)(folder))
    return setup


_validate_crashy = _validate_with_constraint(PLUGIN_CONSTRAINT_RAISES, "crashy")
_validate_none = _validate_with_constraint(PLUGIN_CONSTRAINT_NONE, "lazy")


def _empty_exporter_over_good(folder: Path) -> Setup:
    _write(folder, "g.grammar", GOOD)
    good = _write(folder, "out.void", b"a good model")
    return Setup(["derive", "g.grammar", "-o", "out.void"], env=_plugin(PLUGIN_EMPTY_EXPORTER)(folder),
                 keep={good: good.read_bytes()})


def _sampler_rerun(folder: Path) -> Setup:
    """Re-running the sampler into the same folder with another seed resumes or refuses; the
    manifest always lists exactly the files on disk."""
    import json
    g = (ROOT / "grammars/tiling/castle/castle.grammar").read_text().replace(
        '"castle_small.glb"', f'"{ROOT}/grammars/tiling/castle/castle_small.glb"').replace(
        '"castle_large.glb"', f'"{ROOT}/grammars/tiling/castle/castle_large.glb"')
    _write(folder, "t.grammar", g)
    first = subprocess.run([sys.executable, "-m", "grammarkit", "derive", "t.grammar", "-o", "out",
                            "-n", "3", "--seed", "1", "--workers", "1"], cwd=folder,
                           capture_output=True, timeout=120)
    assert first.returncode == 0, first.stderr.decode()

    def check(f: Path) -> str | None:
        listed = set()
        for line in (f / "out" / "manifest.jsonl").read_text().splitlines():
            if line.strip():
                rec = json.loads(line)
                listed.update(v for k, v in rec.items() if k in ("file", "path", "files") and v)
        on_disk = {p.name for p in (f / "out").glob("*.glb")}
        flat = set()
        for v in listed:
            flat.update(v if isinstance(v, list) else [v])
        flat = {Path(v).name for v in flat}
        return None if on_disk <= flat else f"lost: unlisted files {sorted(on_disk - flat)}"
    return Setup(["derive", "t.grammar", "-o", "out", "-n", "3", "--seed", "2", "--workers", "1"],
                 check=check)


CASES: list[Case] = [
    # silent data loss
    Case("derive -o its own grammar", "data loss", _same_output, words="input"),
    Case("--tree and -o the same file", "data loss", _tree_same, words="same|both|twice|more than once"),
    Case("learn -o its own example", "data loss", _learn_same, words="input", timeout=90),
    Case("fmt -i through a symlink", "data loss", _fmt_symlink, status=0),
    Case("import-cga -o its own CGA file", "data loss", lambda f: _keep_file(
        f, "rules.cga", "Lot --> extrude(10) Mass\n", ["import-cga", "rules.cga", "-o", "rules.cga"]),
        words="input"),
    Case("import-cga --report over its -o", "data loss", lambda f: _keep_file(
        f, "rules.cga", "Lot --> extrude(10) Mass\n",
        ["import-cga", "rules.cga", "-o", "x.grammar", "--report", "x.grammar"]), words="same file"),
    Case("render -o its own model", "data loss", lambda f: _keep_file(
        f, "m.glb", (ROOT / "grammars/tiling/castle/castle_small.glb").read_bytes(),
        ["render", "m.glb", "-o", "m.glb"]), status=2, words="image|png"),
    Case("plugin empty exporter over a good file", "data loss", _empty_exporter_over_good,
         words="void|empty"),
    Case("sampler re-run, another seed", "data loss", _sampler_rerun, status=1, timeout=120,
         words="seed|overwrite|resume|earlier"),
    # unbounded reads
    Case("check /dev/zero", "unbounded read", lambda f: Setup(["check", "/dev/zero"]),
         words="not a regular file|too large"),
    Case("derive /dev/zero", "unbounded read", lambda f: Setup(["derive", "/dev/zero", "-o", "o.glb"]),
         words="not a regular file|too large"),
    Case("fmt - with stdin of zeros", "unbounded read", _stdin_zeros, words="too large|UTF-8|syntax"),
    Case("check a FIFO", "unbounded read", _fifo_grammar, timeout=15, words="not a regular file"),
    Case("render glTF with a FIFO buffer", "unbounded read", _fifo_buffer, timeout=30,
         words="not a regular file|buf.bin"),
    Case("i() of a glTF with a FIFO buffer", "unbounded read", _fifo_insert, timeout=30,
         words="not a regular file|buf.bin"),
    # derive bombs
    Case('material("x" * 600000000)', "derive bomb",
         _grammar('Lot --> extrude(3) material("x" * 600000000) X.\n'), words="string|long|limit"),
    Case('"x" * 1e10', "derive bomb", _grammar('Lot --> extrude(3) material("x" * 1e10) X.\n'),
         words="string|long|limit"),
    Case("string bomb through a parameter", "derive bomb",
         _grammar('Lot --> A(600000000)\nA(n) --> extrude(3) material("x" * n) X.\n'),
         words="string|long|limit"),
    Case("big-integer %", "derive bomb",
         _grammar("Lot --> A(10 ^ 400)\nA(n) --> extrude(n % 7 + 1) X.\n"),
         words="error"),
    Case("5000-digit neighbors count (check)", "derive bomb", _tiling_count, words="error"),
    Case("5000-digit count via grammarkit.check()", "derive bomb", lambda f: _api_check(f),
         words="error"),
    Case("NUL byte in import path", "derive bomb", _grammar('import "a\\u0000b.grammar"\nLot --> X.\n',
                                                          cmd="check"), words="error"),
    Case("raw NUL byte in import path", "derive bomb",
         lambda f: Setup(["check", str(_write(f, "g.grammar", 'import "a\0b.grammar"\nLot --> X.\n').name)]),
         words="error"),
    Case("NUL byte in i() path", "derive bomb", lambda f: Setup(
        ["derive", str(_write(f, "g.grammar", 'Lot --> extrude(3) i("a\0b.glb") X.\n').name), "-o", "o.glb"]),
        words="error"),
    Case("5000-character import path", "derive bomb",
         _grammar(f'import "{"a" * 5000}.grammar"\nLot --> X.\n', cmd="check"), words="error"),
    Case("5000-character i() path", "derive bomb",
         _grammar(f'Lot --> extrude(3) i("{"a" * 5000}.glb") X.\n'), words="error"),
    Case("render --size <5000 digits>x2", "derive bomb",
         lambda f: Setup(["render", str(_write(f, "g.grammar", GOOD).name), "-o", "o.png",
                          "--size", "9" * 5000 + "x2"]), status=2, words="size"),
    Case("full-width digits １０", "lenient numbers", _grammar("Lot --> extrude(１０) X.\n", cmd="check"),
         words=r"1:\d+: error"),
    Case("Arabic-Indic digits ١٢", "lenient numbers", _grammar("Lot --> extrude(١٢) X.\n", cmd="check"),
         words=r"1:\d+: error"),
    Case("1_0", "lenient numbers", _grammar("Lot --> extrude(1_0) X.\n", cmd="check"),
         words=r"1:\d+: error"),
    Case("hip roof, 400-vertex footprint", "derive bomb", _grammar(_hip_roof(400)), timeout=60,
         status=None, words=""),
    Case("hip roof, 3000-vertex footprint", "derive bomb", _grammar(_hip_roof(3000)), timeout=60,
         status=None),
    # plugins
    Case("plugin op returns an int", "plugins",
         _with_plugin(PLUGIN_OP_BAD_RESULT, ["derive", "g.grammar", "-o", "o.glb"],
                      text="Lot --> extrude(3) weird() X.\n"), words="hostile.*weird|weird.*hostile"),
    Case("plugin op raises", "plugins",
         _with_plugin(PLUGIN_OP_RAISES, ["derive", "g.grammar", "-o", "o.glb"],
                      text="Lot --> extrude(3) explode() X.\n"), words="hostile.*explode|explode.*hostile"),
    Case("plugin function raises", "plugins",
         _with_plugin(PLUGIN_FN_RAISES, ["derive", "g.grammar", "-o", "o.glb"],
                      text="Lot --> A(1)\nA(n) --> extrude(boom(n) + 1) X.\n"),
         words=r"2:18: error: boom\(\): plugin 'hostile' failed"),
    Case("plugin op sys.exit(0)", "plugins",
         _with_plugin(PLUGIN_OP_EXIT, ["derive", "g.grammar", "-o", "o.glb"],
                      text="Lot --> extrude(3) quit() X.\n"), words="hostile|quit"),
    Case("plugin op sleeps, --timeout 3", "plugins",
         _with_plugin(PLUGIN_OP_SLOW, ["derive", "g.grammar", "-o", "o.glb", "--timeout", "3"],
                      text="Lot --> extrude(3) slow() X.\n"), timeout=30, words="time"),
    Case("plugin constraint raises in validate", "plugins", _validate_crashy, timeout=90,
         words="crashy"),
    Case("plugin constraint returns None in validate", "plugins", _validate_none, timeout=90,
         words="lazy.*returned NoneType"),
    Case("plugin import hangs: --help", "plugins",
         _with_plugin(PLUGIN_IMPORT_HANGS, ["--help"]), status=0, timeout=20, words="Usage"),
    Case("plugin import hangs: --version", "plugins",
         _with_plugin(PLUGIN_IMPORT_HANGS, ["--version"]), status=0, timeout=20, words="version"),
    Case("plugin import hangs: fmt", "plugins",
         _with_plugin(PLUGIN_IMPORT_HANGS, ["fmt", "g.grammar"]), status=0, timeout=20, words="Lot"),
    Case("check of a grammar that uses a plugin operation", "plugins",
         _with_plugin(PLUGIN_OP_BAD_RESULT, ["check", "g.grammar"], text="Lot --> extrude(3) weird() X.\n"),
         status=0, words="0 errors"),
    Case("plugin import hangs: check", "plugins",
         _with_plugin(PLUGIN_IMPORT_HANGS, ["check", "g.grammar"]), status=0, timeout=20,
         words="0 errors"),
    Case("plugin import exits: check broken grammar", "plugins",
         _with_plugin(PLUGIN_IMPORT_EXITS, ["check", "g.grammar"], text="Lot --> nope(\n"),
         words="syntax"),
    Case("plugin prints on import: plugins --json", "plugins",
         lambda f: _json_ok(_with_plugin(PLUGIN_IMPORT_PRINTS, ["plugins", "--json"])(f)), status=0),
    Case("plugin returns garbage: plugins", "plugins",
         _with_plugin(PLUGIN_GARBAGE, ["plugins"]), status=0, words="hostile"),
    Case("plugin returns garbage: derive", "plugins",
         _with_plugin(PLUGIN_GARBAGE, ["derive", "g.grammar", "-o", "o.glb"]), status=0),
    Case("plugin replaces built-ins", "plugins",
         lambda f: _replaced(_with_plugin(PLUGIN_REPLACES_BUILTIN, ["derive", "g.grammar", "-o", "o.glb"])(f)),
         status=0, words="cannot be replaced"),
    # error messages
    Case("full disk names the user's path", "error messages", _full_disk,
         words=r"paris\.glb: cannot write"),
    Case("folder as grammar: check", "error messages", status=2, setup=_folder_as_file("check"), words="folder|directory"),
    Case("folder as grammar: derive", "error messages", status=2, setup=_folder_as_file("derive"), words="folder|directory"),
    Case("folder as grammar: fmt", "error messages", status=2, setup=_folder_as_file("fmt"), words="folder|directory"),
    Case("folder as model: render", "error messages", status=2, setup=_folder_as_file("render"), words="folder|directory"),
    Case("folder as model: validate", "error messages", _folder_as_file("validate"), words="folder|directory"),
    Case("U+2028, U+0085 and form feed in comments: the right source line", "error messages",
         _grammar("# a\u2028b\u0085c\fd\nLot --> extrude(x) X.\n", cmd="check"),
         words=r"g\.grammar:2:17: error[^\n]*\n    Lot --> extrude\(x\) X\."),
    Case("missing optional dependency", "error messages", _missing_dependency,
         words="trimesh|manifold3d"),
] + [Case(f"check, a file at the size limit of {kind}", "big files", _big(kind), timeout=60, big=True,
          status=1 if kind in ("unknown operations", "many errors") else 0)
     for kind in ("many rules", "many consts", "case arms", "deep nesting", "push/pop", "long chains",
                  "undefined successors", "unknown operations", "many errors", "long expressions")]


def _api_check(folder: Path) -> Setup:
    s = _api_check_big_int(folder)
    return Setup(["check", "t.grammar"], check=lambda f: _run_api(f))


def _run_api(folder: Path) -> str | None:
    r = subprocess.run([sys.executable, "api.py"], cwd=folder, capture_output=True, text=True, timeout=60)
    if TRACEBACK in r.stderr:
        return "grammarkit.check() raised: " + r.stderr.strip().splitlines()[-1]
    return None


def _json_ok(s: Setup) -> Setup:
    import json

    def check(f: Path) -> str | None:
        try:
            json.loads((f / ".stdout").read_text())
        except ValueError as exc:
            return f"stdout is not JSON: {exc}"
        return None
    s.check = check
    return s


def _replaced(s: Setup) -> Setup:
    def check(f: Path) -> str | None:
        out = f / "o.glb"
        if not out.exists() or out.stat().st_size == 0:
            return "lost: the built-in glb exporter was replaced"
        return None
    s.check = check
    return s


def fast_cases() -> list[Case]:
    return [c for c in CASES if not c.big]


def table(outcomes: list[Outcome]) -> str:
    cols = ["clear", "traceback", "hang", "memory", "lost", "wrong"]
    groups: dict[str, list[Outcome]] = {}
    for o in outcomes:
        groups.setdefault(o.case.group, []).append(o)
    lines = ["| group | cases | clear errors | tracebacks | hangs | memory > 1 GB | data lost | other |",
             "|---|---|---|---|---|---|---|---|"]
    for g, os_ in list(groups.items()) + [("total", outcomes)]:
        counts = [sum(1 for o in os_ if o.verdict == c) for c in cols]
        lines.append(f"| {g} | {len(os_)} | " + " | ".join(str(c) for c in counts) + " |")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-k", default="", help="run only cases whose name contains this")
    ap.add_argument("--fast", action="store_true", help="leave out the big-file cases")
    ap.add_argument("-v", action="store_true", help="print the output of failing cases")
    args = ap.parse_args(argv)
    cases = [c for c in (fast_cases() if args.fast else CASES) if args.k.lower() in c.name.lower()]
    outcomes = []
    for c in cases:
        o = run_case(c)
        outcomes.append(o)
        print(f"{o.verdict:9s} {o.seconds:6.1f} s {o.cpu:6.1f} s CPU {o.peak_mb:7.0f} MB  {c.name}"
              + (f"  -- {o.detail[:300]}" if o.detail else ""), flush=True)
        if args.v and o.verdict != "clear":
            print("    " + o.output.strip()[-1500:].replace("\n", "\n    "))
    print()
    print(table(outcomes))
    return 0 if all(o.verdict == "clear" for o in outcomes) else 1


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main(sys.argv[1:]))
