"""Training sets of shape graphs and their strings, made from a back end's output.

`build_dataset(grammar, source="graph-sampler", n=5000)` runs the back end through
`grammarkit.run.iter_results`, takes the shape graph of every result (plus the grammar's
examples), keeps each isomorphism class once, checks it against the grammar's topology rules
and draws up to `strings_per_graph` different strings per graph (random roots and orders; the
paper trains on all of them). Per part it also stores the Kalojanov local frame of the result's
geometry (`grammarkit.tiling.local_frame`), which the edge categories of the instantiation
step are learned from.

A dataset folder (written as one transaction by `grammarkit.run.write_files`):

    dataset.json     what it is: grammar name and hash, alphabet, topology rules, source back
                     end, seed, counts, format version
    graphs.jsonl     one graph per line: id, types, edges, histogram, source, frames, variants
    strings.tsv      graph index <TAB> string, one line per string
    histograms.csv   graph id and the count of each part type
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from grammarkit.errors import GrammarkitError

from .graphs import GraphSet, TypedGraph
from .strings import Alphabet, strings_of
from .topology import TopologyRules

__all__ = ["DATASET_FORMAT", "DATASET_VERSION", "Dataset", "build_dataset", "load_dataset", "make_dataset",
           "write_dataset"]

DATASET_FORMAT = "grammarkit-string-dataset"
DATASET_VERSION = 1
FILES = ("dataset.json", "graphs.jsonl", "strings.tsv", "histograms.csv")


@dataclass
class Dataset:
    meta: dict
    graphs: list[TypedGraph]
    strings: list[list[str]]  # per graph
    ids: list[str]
    sources: list[str]
    frames: list[list[list[float]] | None] = field(default_factory=list)  # per graph: per node 16 floats
    path: Path | None = None
    variants: list[list[str] | None] = field(default_factory=list)  # per graph: per node geometry key

    @property
    def alphabet(self) -> Alphabet:
        return Alphabet.from_json(self.meta["alphabet"])

    @property
    def grammar_hash(self) -> str:
        return str(self.meta["grammar_hash"])

    def __len__(self) -> int:
        return len(self.graphs)

    def files(self) -> dict[str, str]:
        """The folder's files as text."""
        lines = []
        for i, g in enumerate(self.graphs):
            row: dict[str, Any] = {"id": self.ids[i], "types": list(g.types), "edges": [list(e) for e in g.edges],
                                   "histogram": g.histogram(), "source": self.sources[i]}
            if self.frames and self.frames[i] is not None:
                row["frames"] = self.frames[i]
            if self.variants and self.variants[i] is not None:
                row["variants"] = self.variants[i]
            lines.append(json.dumps(row, separators=(",", ":")))
        types = list(self.alphabet.types)
        hist = ["id," + ",".join(types)]
        for i, g in enumerate(self.graphs):
            h = g.histogram()
            hist.append(self.ids[i] + "," + ",".join(str(h.get(t, 0)) for t in types))
        strings = [f"{i}\t{s}" for i, ss in enumerate(self.strings) for s in ss]
        return {"dataset.json": json.dumps(self.meta, indent=1, sort_keys=True) + "\n",
                "graphs.jsonl": "\n".join(lines) + "\n",
                "strings.tsv": "\n".join(strings) + "\n",
                "histograms.csv": "\n".join(hist) + "\n"}


def _frames_of(assembly: Any) -> tuple[list[list[float]], list[str]]:
    """Each part's Kalojanov local frame (16 numbers) and geometry variant key."""
    from grammarkit.tiling import local_frame

    from .categories import variant_key

    return ([[round(float(x), 7) for x in local_frame(p).ravel()] for p in assembly.parts],
            [variant_key(p) for p in assembly.parts])


def _graph_of_result(result: Any) -> tuple[TypedGraph, Any]:
    """The typed graph of a back-end result (its manifest graph, else the shape graph
    recomputed from its Assembly), and the Assembly (or None)."""
    from grammarkit.tiling import Assembly, shape_graph

    model = result.model
    graph = (result.extra or {}).get("graph")
    if graph is not None and isinstance(model, Assembly):
        ids = [p.id for p in model.parts]
        nodes = graph["nodes"]
        if [n["id"] for n in nodes] == ids:
            return TypedGraph.from_json(graph), model
    if isinstance(model, Assembly):
        g = shape_graph(model)
        order = {p.id: k for k, p in enumerate(model.parts)}
        return TypedGraph.make([p.type for p in model.parts],
                               [(order[u], order[v]) for u, v in g.edges()]), model
    if graph is not None:
        return TypedGraph.from_json(graph), None
    raise GrammarkitError(f"result {result.id!r} has neither an assembly nor a graph to learn from")


# long: one pass over the back end's results with the checks and bookkeeping of every graph
# (the nested `add` shares the counters); split up, the counters would be passed around
def build_dataset(grammar: Any, *, source: str = "graph-sampler", n: int = 1000, seed: int = 0,
                  iterations: int = 4, options: Mapping[str, Any] | None = None,
                  strings_per_graph: int = 10, include_examples: bool = True, frames: bool = True,
                  workers: int | None = 1, progress: Callable | None = None,
                  grammar_file: str | None = None, time_limit: float | None = None) -> tuple[Dataset, dict]:
    """A dataset of up to `n` graphs from back end `source` (plus the examples); returns the
    dataset and a report (counts, skipped graphs, shortfall). `time_limit` (seconds) is the run
    layer's graceful budget: the back end stops after it and what it made is kept."""
    from grammarkit.run import grammar_hash, iter_results
    from grammarkit.tiling import load_examples, shape_graph

    if strings_per_graph < 1:
        raise GrammarkitError("strings per graph must be at least 1")
    if grammar.family != "tiling":
        raise GrammarkitError(f"{grammar.name}: shape strings describe tiling grammars (parts and "
                              f"neighbour rules); this is a {grammar.family} grammar")
    rules = TopologyRules.from_grammar(grammar)
    alphabet = Alphabet.for_types(rules.types)
    seen = GraphSet()
    graphs: list[TypedGraph] = []
    ids: list[str] = []
    sources: list[str] = []
    all_frames: list = []
    all_variants: list = []
    report = {"results": 0, "duplicates": 0, "invalid": 0, "disconnected": 0}
    invalid_examples: list[str] = []

    def add(g: TypedGraph, gid: str, src: str, asm: Any) -> None:
        if len(g) == 0:
            return
        import networkx as nx

        if not nx.is_connected(g.to_networkx()):
            report["disconnected"] += 1
            return
        problems = rules.check(g, limit=1)
        if problems:
            report["invalid"] += 1
            if src.startswith("example:"):
                invalid_examples.append(f"{src}: {problems[0].message}")
            return
        if not seen.add(g):
            report["duplicates"] += 1
            return
        graphs.append(g)
        ids.append(gid)
        sources.append(src)
        fr, var = _frames_of(asm) if (frames and asm is not None) else (None, None)
        all_frames.append(fr)
        all_variants.append(var)

    if include_examples:
        for asm in load_examples(grammar):
            sg = shape_graph(asm)
            order = {p.id: k for k, p in enumerate(asm.parts)}
            g = TypedGraph.make([p.type for p in asm.parts], [(order[u], order[v]) for u, v in sg.edges()])
            add(g, f"example_{asm.name}", f"example:{asm.name}", asm)
    made = 0
    for result in iter_results(grammar, backend=source, n=n, seed=seed, iterations=iterations,
                               options=dict(options or {}), workers=workers, progress=progress,
                               time_limit=time_limit):
        report["results"] += 1
        g, asm = _graph_of_result(result)
        add(g, str(result.id), f"{source}:{result.id}", asm)
        made += 1
    shortfall = None
    if made < n:
        shortfall = (f"back end {source!r} made {made} of the {n} results asked for (with "
                     f"{iterations} iteration(s)"
                     + (f", time limit {time_limit:g} s" if time_limit is not None else "")
                     + "); more --iterations or other --option values may give more")
    ds = make_dataset(graphs, rules, alphabet, ids=ids, sources=sources, frames=all_frames, variants=all_variants,
                      strings_per_graph=strings_per_graph, seed=seed,
                      meta={"grammar": grammar.name, "grammar_hash": grammar_hash(grammar),
                            "grammar_file": grammar_file or (str(grammar.source_path)
                                                             if getattr(grammar, "source_path", None) else None),
                            "source": source, "iterations": iterations, "options": dict(options or {}),
                            "requested": n, "examples_included": include_examples, "shortfall": shortfall,
                            "skipped": {k: v for k, v in report.items() if k != "results"}})
    report["graphs"] = len(graphs)
    report["strings"] = ds.meta["strings"]
    report["shortfall"] = shortfall
    report["invalid_examples"] = invalid_examples
    report["graphs_with_fewer_strings"] = sum(1 for ss in ds.strings if len(ss) < strings_per_graph)
    return ds, report


def make_dataset(graphs: list[TypedGraph], rules: TopologyRules, alphabet: Alphabet, *,
                 ids: list[str] | None = None, sources: list[str] | None = None, frames: list | None = None,
                 variants: list | None = None, strings_per_graph: int = 10, seed: int = 0, meta: Mapping[str, Any] | None = None) -> Dataset:
    """A dataset of given graphs (each connected and valid): up to `strings_per_graph` strings
    per graph, drawn with numpy generators seeded by (seed, graph index)."""
    from .strings import tokenize

    strings: list[list[str]] = []
    for i, g in enumerate(graphs):
        rng = np.random.default_rng([seed, i])
        strings.append(strings_of(g, alphabet, strings_per_graph, rng=rng))
    max_tokens = 0
    max_ring = 0
    for ss in strings:
        for s in ss:
            toks = tokenize(s, alphabet)
            max_tokens = max(max_tokens, len(toks))
            max_ring = max([max_ring] + [int(t.value) for t in toks if t.kind == "ring"])
    full = {"format": DATASET_FORMAT, "version": DATASET_VERSION, "alphabet": alphabet.to_json(),
            "rules": rules.to_json(), "seed": seed, "graphs": len(graphs),
            "strings": sum(len(s) for s in strings), "strings_per_graph": strings_per_graph,
            "max_tokens": max_tokens, "max_ring_label": max_ring}
    full.update(dict(meta or {}))
    n = len(graphs)
    return Dataset(full, list(graphs), strings, list(ids or [f"graph_{i:05d}" for i in range(n)]),
                   list(sources or [""] * n), list(frames or [None] * n), None, list(variants or [None] * n))


def write_dataset(dataset: Dataset, out: str | Path, *, overwrite: bool = False) -> Path:
    """Write the dataset folder as one transaction; refuses to replace another dataset unless
    `overwrite`, and refuses a file or a non-dataset folder with other content."""
    from grammarkit.run import write_files

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise GrammarkitError(f"{out}: is a file; a dataset is a folder (e.g. -o castle_ds/)")
    if out.is_dir() and any(out.iterdir()):
        if not (out / "dataset.json").exists():
            raise GrammarkitError(f"{out}: the folder holds other files; give a new or empty folder")
        if not overwrite:
            raise GrammarkitError(f"{out}: holds a dataset already; use --overwrite to replace it")
    write_files({out / name: text for name, text in dataset.files().items()})
    dataset.path = out
    return out


def load_dataset(path: str | Path) -> Dataset:
    """Read a dataset folder; every problem names the file (and line)."""
    path = Path(path)
    if not path.exists():
        raise GrammarkitError(f"{path}: no such dataset folder")
    if not path.is_dir():
        raise GrammarkitError(f"{path}: a dataset is a folder made by `grammarkit dataset`, not a file")
    meta_path = path / "dataset.json"
    if not meta_path.exists():
        raise GrammarkitError(f"{path}: not a dataset folder (no dataset.json); make one with "
                              "`grammarkit dataset GRAMMAR -o FOLDER`")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise GrammarkitError(f"{meta_path}: cannot read: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != DATASET_FORMAT:
        raise GrammarkitError(f"{meta_path}: not a grammarkit string dataset")
    if meta.get("version") != DATASET_VERSION:
        raise GrammarkitError(f"{meta_path}: dataset format version {meta.get('version')!r}; this "
                              f"grammarkit reads version {DATASET_VERSION} (rebuild the dataset)")
    graphs: list[TypedGraph] = []
    ids: list[str] = []
    sources: list[str] = []
    frames: list = []
    variants: list = []
    gpath = path / "graphs.jsonl"
    try:
        lines = gpath.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise GrammarkitError(f"{gpath}: cannot read: {exc.strerror or exc}") from None
    for k, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
            graphs.append(TypedGraph.make(row["types"], row["edges"]))
        except (ValueError, KeyError, TypeError) as exc:
            raise GrammarkitError(f"{gpath}:{k}: not a graph record ({exc})") from None
        ids.append(str(row.get("id", k - 1)))
        sources.append(str(row.get("source", "")))
        frames.append(row.get("frames"))
        variants.append(row.get("variants"))
    strings: list[list[str]] = [[] for _ in graphs]
    spath = path / "strings.tsv"
    try:
        slines = spath.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise GrammarkitError(f"{spath}: cannot read: {exc.strerror or exc}") from None
    for k, line in enumerate(slines, 1):
        if not line.strip():
            continue
        idx, sep, text = line.partition("\t")
        if not sep or not idx.isdigit() or int(idx) >= len(graphs):
            raise GrammarkitError(f"{spath}:{k}: expected 'graph index<TAB>string' with an index below "
                                  f"{len(graphs)}")
        strings[int(idx)].append(text)
    return Dataset(meta, graphs, strings, ids, sources, frames, path, variants)
