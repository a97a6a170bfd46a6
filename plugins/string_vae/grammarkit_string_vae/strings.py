"""Shape strings: SMILES-like text for typed graphs (Kalojanov et al. 2019, section 5.1).

A shape graph becomes a string by a depth-first traversal of a spanning tree:

- each node is one letter, its part type (the `Alphabet` maps types to letters);
- a node's subtrees follow it; all but the last are enclosed in brackets `( )`;
- each edge not in the tree (a cycle edge) is written as the same ring label right after the
  letters of both of its end nodes.

Two formats:

- `smiles` (grammarkit's): ring labels `1`..`9`, then `%10`..`%99` (as in SMILES); a label is
  free again once its cycle edge is closed and the lowest free label is used next, so few
  labels suffice. At one node, closings come before openings.
  Castle example: `TW(W1)GW(TW1)T` ... see docs/string-vae.md.
- `string2shape` (the authors' code, javorkk/string2shape): letters `A`, `B`, ... by type
  index, every cycle edge has its own number (never reused), several numbers after one node
  are separated by `%`, e.g. `A0%1(B0)C1`.

A graph has many strings (one per root and neighbour order); `encode` draws one at random,
`strings_of` draws several different ones. `decode` parses a string back into a `TypedGraph`
and raises `ShapeStringError` naming the character where a string is malformed; every node
and edge remembers the character it came from, so rule violations can be located too.
"""
from __future__ import annotations

import string as _string
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

import numpy as np

from grammarkit.errors import GrammarkitError
from grammarkit.ir import Span

from .graphs import TypedGraph

__all__ = [
    "Alphabet", "FORMATS", "MAX_STRING_LENGTH", "ParsedString", "ShapeStringError", "decode", "encode",
    "convert", "encode_with_order", "ring_token", "strings_of", "tokenize",
]

LETTERS = _string.ascii_uppercase + _string.ascii_lowercase
FORMATS = ("smiles", "string2shape")
MAX_RING_LABEL = 99
# Resource guard: longer strings are refused before parsing (a 10,000-part shape is ~15,000
# characters).
MAX_STRING_LENGTH = 200_000


class ShapeStringError(GrammarkitError):
    """A shape string that cannot be read or breaks the grammar; points at the character."""

    def __init__(self, message: str, text: str, index: int | None, *, hint: str | None = None,
                 code: str | None = None, more: Sequence[tuple[str, int | None]] = ()):
        self.text = text
        self.index = index
        from grammarkit.errors import Diagnostic

        diags = [Diagnostic("error", m, _span(i), hint if k == 0 else None, code)
                 for k, (m, i) in enumerate([(message, index), *more])]
        super().__init__(message, diagnostics=diags)

    def format(self, source: str | None = None) -> str:  # noqa: ARG002 - the string is the source
        return super().format(self.text)


def _span(index: int | None) -> Span | None:
    if index is None:
        return Span(file="<string>")
    return Span(file="<string>", line=1, column=index + 1, end_line=1, end_column=index + 2)


# --------------------------------------------------------------------------------------------
# the alphabet
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Alphabet:
    """One letter per part type (at most 52 types: A-Z, a-z)."""

    types: tuple[str, ...]
    letters: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.types) != len(self.letters):
            raise ValueError("an alphabet needs one letter per type")
        if len(set(self.letters)) != len(self.letters) or len(set(self.types)) != len(self.types):
            raise ValueError("alphabet letters and types must be unique")
        bad = [c for c in self.letters if len(c) != 1 or c not in LETTERS]
        if bad:
            raise ValueError(f"alphabet letters must be single ASCII letters, got {bad}")

    @classmethod
    def for_types(cls, types: Iterable[str], scheme: str = "initials") -> "Alphabet":
        """Letters for `types` (sorted by name). `initials`: the type's first letter (upper,
        then its other letters, then any free letter), so castle types read G, T, W;
        `index`: A, B, C, ... in type order (string2shape's convention)."""
        names = sorted(set(types))
        if len(names) > len(LETTERS):
            raise GrammarkitError(f"shape strings support at most {len(LETTERS)} part types, "
                                  f"got {len(names)}")
        if scheme == "index":
            return cls(tuple(names), tuple(LETTERS[: len(names)]))
        if scheme != "initials":
            raise ValueError(f"unknown alphabet scheme {scheme!r} (initials or index)")
        used: set[str] = set()
        letters = []
        for name in names:
            candidates = [c.upper() for c in name if c.isascii() and c.isalpha()]
            candidates += [c.lower() for c in name if c.isascii() and c.isalpha()]
            pick = next((c for c in candidates + list(LETTERS) if c not in used), None)
            used.add(pick)  # type: ignore[arg-type]
            letters.append(pick)
        return cls(tuple(names), tuple(letters))  # type: ignore[arg-type]

    @classmethod
    def from_json(cls, data: Mapping[str, str]) -> "Alphabet":
        """From `{letter: type}`."""
        items = sorted(data.items(), key=lambda kv: kv[1])
        return cls(tuple(t for _, t in items), tuple(c for c, _ in items))

    def to_json(self) -> dict[str, str]:
        return {c: t for c, t in zip(self.letters, self.types)}

    def letter(self, type_name: str) -> str:
        try:
            return self.letters[self.types.index(type_name)]
        except ValueError:
            raise GrammarkitError(f"part type {type_name!r} has no letter in the alphabet "
                                  f"({self.describe()})") from None

    def type_of(self, letter: str) -> str:
        return self.types[self.letters.index(letter)]

    def describe(self) -> str:
        return ", ".join(f"{c}={t}" for c, t in zip(self.letters, self.types))


# --------------------------------------------------------------------------------------------
# tokens
# --------------------------------------------------------------------------------------------
def ring_token(label: int) -> str:
    """The text of ring label `label` in the smiles format: 1-9, then %10-%99."""
    if not 1 <= label <= MAX_RING_LABEL:
        raise ValueError(f"ring label {label} outside 1..{MAX_RING_LABEL}")
    return str(label) if label < 10 else f"%{label:02d}"


@dataclass(frozen=True)
class Token:
    kind: str  # "node", "open", "close", "ring"
    text: str
    index: int  # position of its first character in the string
    value: int | str = 0  # ring label / id, or the node's letter


def tokenize(text: str, alphabet: Alphabet, fmt: str = "smiles") -> list[Token]:
    """Split a string into tokens; an unknown character is a located ShapeStringError."""
    if fmt not in FORMATS:
        raise GrammarkitError(f"unknown string format {fmt!r}; known: {', '.join(FORMATS)}")
    if len(text) > MAX_STRING_LENGTH:
        raise ShapeStringError(f"the string has {len(text)} characters, more than the limit of "
                               f"{MAX_STRING_LENGTH}", text[:80] + "...", None)
    letters = set(alphabet.letters)
    out: list[Token] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in letters:
            out.append(Token("node", c, i, c))
            i += 1
        elif c == "(":
            out.append(Token("open", c, i))
            i += 1
        elif c == ")":
            out.append(Token("close", c, i))
            i += 1
        elif fmt == "smiles" and c.isdigit() and c.isascii():
            if c == "0":
                raise ShapeStringError("ring label 0 is not used: labels run 1-9, then %10-%99",
                                       text, i)
            out.append(Token("ring", c, i, int(c)))
            i += 1
        elif fmt == "smiles" and c == "%":
            digits = text[i + 1:i + 3]
            if len(digits) != 2 or not (digits.isascii() and digits.isdigit()):
                raise ShapeStringError("'%' must be followed by a two-digit ring label (%10-%99)",
                                       text, i)
            out.append(Token("ring", text[i:i + 3], i, int(digits)))
            i += 3
        elif fmt == "string2shape" and c.isdigit() and c.isascii():
            j = i
            while j < n and text[j].isascii() and text[j].isdigit():
                j += 1
            out.append(Token("ring", text[i:j], i, int(text[i:j])))
            i = j
        elif fmt == "string2shape" and c == "%":
            prev_ring = bool(out) and out[-1].kind == "ring" and out[-1].index + len(out[-1].text) == i
            if not prev_ring or i + 1 >= n or not text[i + 1].isdigit():
                raise ShapeStringError("'%' separates two cycle numbers (string2shape format)",
                                       text, i)
            i += 1
        else:
            what = "whitespace" if c.isspace() else f"{c!r}"
            raise ShapeStringError(f"unknown character {what}", text, i,
                                   hint=f"letters are part types ({alphabet.describe()}); "
                                   "( ) enclose branches; digits are ring labels", code="unknown-letter")
    return out


# --------------------------------------------------------------------------------------------
# decoding
# --------------------------------------------------------------------------------------------
@dataclass
class ParsedString:
    """A decoded string: the graph, and which character made each node and edge."""

    text: str
    graph: TypedGraph
    node_index: list[int]  # character index of each node's letter
    edge_index: dict[tuple[int, int], int]  # (i, j), i < j -> character that made the edge
    tree_edges: list[tuple[int, int]] = field(default_factory=list)  # (parent, child) in order
    ring_edges: list[tuple[int, int]] = field(default_factory=list)  # (opener, closer) in order
    ring_chars: list[tuple[int, int]] = field(default_factory=list)  # their labels' characters


# long: one left-to-right pass over the tokens with the branch stack and open ring labels;
# long: every error case points at its own character, so the checks stay with that state
def decode(text: str, alphabet: Alphabet, fmt: str = "smiles") -> ParsedString:
    """Parse a shape string into its graph; malformed strings raise ShapeStringError at the
    offending character (unknown letters, unbalanced brackets, empty branches, ring labels
    that are not closed, that close on their own node or repeat an edge)."""
    text = text.strip()
    tokens = tokenize(text, alphabet, fmt)
    if not tokens:
        raise ShapeStringError("the string is empty: it needs at least one part letter", text, None)
    types: list[str] = []
    node_index: list[int] = []
    edges: dict[tuple[int, int], int] = {}
    tree: list[tuple[int, int]] = []
    rings_out: list[tuple[int, int]] = []
    ring_chars: list[tuple[int, int]] = []
    stack: list[tuple[int, int]] = []  # (owner node, index of its '(')
    current: int | None = None
    phase = "start"  # start | atom | after-branch | branch-start
    open_rings: dict[int, tuple[int, int]] = {}  # label -> (node, character index)
    seen_ids: set[int] = set()  # string2shape: ids already closed
    for tok in tokens:
        if tok.kind == "node":
            node = len(types)
            types.append(alphabet.type_of(tok.text))
            node_index.append(tok.index)
            if current is not None:
                if phase == "start":  # pragma: no cover - current is None at start
                    raise AssertionError
                edges[(current, node)] = tok.index
                tree.append((current, node))
            elif phase != "start":  # pragma: no cover - defensive
                raise AssertionError
            current = node
            phase = "atom"
        elif tok.kind == "open":
            if current is None:
                raise ShapeStringError("a branch '(' needs a part letter before it", text, tok.index)
            if phase == "branch-start":
                raise ShapeStringError("'((' : a branch must start with a part letter", text, tok.index)
            stack.append((current, tok.index))
            phase = "branch-start"
        elif tok.kind == "close":
            if not stack:
                raise ShapeStringError("')' closes no branch", text, tok.index)
            if phase == "branch-start":
                raise ShapeStringError("'()' : an empty branch", text, tok.index)
            current = stack.pop()[0]
            phase = "after-branch"
        else:  # ring label
            if current is None:
                raise ShapeStringError("a ring label needs a part letter before it", text, tok.index)
            if phase != "atom":
                raise ShapeStringError("a ring label must follow its part's letter directly "
                                       "(before any branch)", text, tok.index)
            label = int(tok.value)
            if label in open_rings:
                other, at = open_rings.pop(label)
                if other == current:
                    raise ShapeStringError(f"ring label {tok.text} closes on the part that opened "
                                           f"it (character {at + 1})", text, tok.index)
                key = (min(other, current), max(other, current))
                if key in edges:
                    raise ShapeStringError(f"ring label {tok.text} repeats the edge between the parts "
                                           f"at characters {node_index[other] + 1} and "
                                           f"{node_index[current] + 1}", text, tok.index)
                edges[key] = tok.index
                rings_out.append((other, current))
                ring_chars.append((at, tok.index))
                if fmt == "string2shape":
                    seen_ids.add(label)
            else:
                if fmt == "string2shape" and label in seen_ids:
                    raise ShapeStringError(f"cycle number {label} appears more than twice", text,
                                           tok.index)
                open_rings[label] = (current, tok.index)
        if len(types) > len(text):  # pragma: no cover - each node has a character
            raise AssertionError
    if stack:
        raise ShapeStringError("this '(' is never closed", text, stack[-1][1],
                               more=[("... and this '(' is never closed", at) for _, at in stack[-2::-1]])
    if open_rings:
        pending = sorted(open_rings.items(), key=lambda kv: kv[1][1])
        first = pending[0]
        raise ShapeStringError(f"ring label {first[0]} is opened here but never closed", text, first[1][1],
                               more=[(f"ring label {lab} is opened here but never closed", at)
                                     for lab, (_, at) in pending[1:]])
    norm = {(min(a, b), max(a, b)): at for (a, b), at in edges.items()}
    graph = TypedGraph(tuple(types), tuple(sorted(norm)))
    return ParsedString(text, graph, node_index, norm, tree, rings_out, ring_chars)


# --------------------------------------------------------------------------------------------
# encoding
# --------------------------------------------------------------------------------------------
def _dfs_tree(adj: list[list[int]], root: int, rng: np.random.Generator | None
              ) -> tuple[list[int], list[list[int]], list[int]]:
    """Randomised depth-first search (iterative, so long chains do not hit Python's recursion
    limit): visit order, tree children of each node in visit order, parent of each node."""
    n = len(adj)
    parent = [-1] * n
    children: list[list[int]] = [[] for _ in range(n)]
    order: list[int] = []
    seen = [False] * n

    def shuffled(v: int) -> list[int]:
        nb = list(adj[v])
        if rng is not None:
            rng.shuffle(nb)
        return nb

    seen[root] = True
    order.append(root)
    stack = [(root, iter(shuffled(root)))]
    while stack:
        v, it = stack[-1]
        for w in it:
            if not seen[w]:
                seen[w] = True
                parent[w] = v
                children[v].append(w)
                order.append(w)
                stack.append((w, iter(shuffled(w))))
                break
        else:
            stack.pop()
    return order, children, parent


def encode(graph: TypedGraph, alphabet: Alphabet, *, rng: np.random.Generator | None = None,
           root: int | None = None, fmt: str = "smiles") -> str:
    """One string of a connected graph: a random root and neighbour order from `rng` (without
    `rng`: root 0 and the edge order, deterministic)."""
    return encode_with_order(graph, alphabet, rng=rng, root=root, fmt=fmt)[0]


def encode_with_order(graph: TypedGraph, alphabet: Alphabet, *, rng: np.random.Generator | None = None,
                      root: int | None = None, fmt: str = "smiles") -> tuple[str, list[int]]:
    """`encode`, and which graph node each letter of the string is (the k-th letter is node
    order[k]; `decode` numbers nodes by letter, so decoded node k is graph node order[k])."""
    n = len(graph.types)
    if n == 0:
        raise GrammarkitError("an empty graph has no shape string")
    if fmt not in FORMATS:
        raise GrammarkitError(f"unknown string format {fmt!r}; known: {', '.join(FORMATS)}")
    letters = [alphabet.letter(t) for t in graph.types]
    adj = graph.adjacency()
    if root is None:
        root = int(rng.integers(n)) if rng is not None else 0
    order, children, parent = _dfs_tree(adj, root, rng)
    if len(order) != n:
        raise GrammarkitError(f"the graph has {n} nodes but only {len(order)} are connected to node "
                              f"{root}: a shape string describes one connected shape")
    position = {v: k for k, v in enumerate(order)}
    tree = {(min(v, p), max(v, p)) for v, p in enumerate(parent) if p >= 0}
    # cycle edges incident to each node, partner order as the node's (shuffled) adjacency
    ring_partners: list[list[int]] = [[] for _ in range(n)]
    for a, b in graph.edges:
        if (a, b) not in tree:
            ring_partners[a].append(b)
            ring_partners[b].append(a)
    if rng is not None:
        for lst in ring_partners:
            rng.shuffle(lst)
    # ring labels, assigned in the order the string is written (the DFS preorder)
    labels: dict[tuple[int, int], int] = {}
    ring_text: list[str] = [""] * n
    free: list[int] = []  # smiles: released labels (reused lowest first)
    next_label = 1 if fmt == "smiles" else 0
    for v in order:
        closing = [w for w in ring_partners[v] if position[w] < position[v]]
        opening = [w for w in ring_partners[v] if position[w] > position[v]]
        parts: list[str] = []
        for w in closing:
            lab = labels[(min(v, w), max(v, w))]
            parts.append(ring_token(lab) if fmt == "smiles" else str(lab))
            if fmt == "smiles":
                free.append(lab)
        for w in opening:
            if fmt == "smiles" and free:
                free.sort()
                lab = free.pop(0)
            else:
                lab = next_label
                next_label += 1
                if fmt == "smiles" and lab > MAX_RING_LABEL:
                    raise GrammarkitError(f"the graph needs more than {MAX_RING_LABEL} ring labels "
                                          "open at once, beyond the smiles format")
            labels[(min(v, w), max(v, w))] = lab
            parts.append(ring_token(lab) if fmt == "smiles" else str(lab))
        ring_text[v] = "".join(parts) if fmt == "smiles" else "%".join(parts)
    # emit: letter, ring labels, bracketed subtrees, last subtree (iteratively)
    out: list[str] = []
    stack: list[object] = [root]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            out.append(item)
            continue
        v = int(item)  # type: ignore[arg-type]
        out.append(letters[v])
        out.append(ring_text[v])
        kids = children[v]
        todo: list[object] = []
        for c in kids[:-1]:
            todo += ["(", c, ")"]
        if kids:
            todo.append(kids[-1])
        stack.extend(reversed(todo))
    return "".join(out), order


def strings_of(graph: TypedGraph, alphabet: Alphabet, n: int, *, rng: np.random.Generator,
               fmt: str = "smiles", max_tries: int | None = None) -> list[str]:
    """Up to `n` different strings of `graph` (random roots and neighbour orders), in the
    order found. Small graphs have fewer than `n` strings; `max_tries` (default 20 n) bounds
    the search."""
    found: dict[str, None] = {}
    tries = max_tries if max_tries is not None else 20 * n
    for _ in range(tries):
        if len(found) >= n:
            break
        found.setdefault(encode(graph, alphabet, rng=rng, fmt=fmt))
    return list(found)


def convert(text: str, alphabet: Alphabet, *, source: str = "smiles", target: str = "string2shape",
            target_alphabet: Alphabet | None = None) -> str:
    """The same string in another format: the traversal (root, child order, where each ring
    label sits) is kept; letters and ring labels are rewritten. The string is checked first
    (`decode`). string2shape's letters are by type index unless `target_alphabet` is given."""
    decode(text, alphabet, source)
    if target not in FORMATS:
        raise GrammarkitError(f"unknown string format {target!r}; known: {', '.join(FORMATS)}")
    dest = target_alphabet or (Alphabet.for_types(alphabet.types, "index") if target == "string2shape"
                               else Alphabet.for_types(alphabet.types))
    out: list[str] = []
    numbers: list[str] = []  # the ring labels after the current letter
    old_open: dict[int, int] = {}  # source label -> target label
    free: list[int] = []
    next_label = 1 if target == "smiles" else 0

    def flush() -> None:
        if numbers:
            out.append("".join(numbers) if target == "smiles" else "%".join(numbers))
            numbers.clear()

    for tok in tokenize(text.strip(), alphabet, source):
        if tok.kind != "ring":
            flush()
        if tok.kind == "node":
            out.append(dest.letter(alphabet.type_of(tok.text)))
        elif tok.kind in ("open", "close"):
            out.append(tok.text)
        else:
            old = int(tok.value)
            if old in old_open:
                lab = old_open.pop(old)
                if target == "smiles":
                    free.append(lab)
            else:
                if target == "smiles" and free:
                    free.sort()
                    lab = free.pop(0)
                else:
                    lab = next_label
                    next_label += 1
                old_open[old] = lab
            numbers.append(ring_token(lab) if target == "smiles" else str(lab))
    flush()
    return "".join(out)
