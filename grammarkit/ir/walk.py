"""A public walker over rule bodies: every item, every nested sequence, in source order.

A rule body nests sequences inside operation blocks (`split(x) { 1: A | ~1: B }`, repeat
groups `{ ... }*` included), pushes `[ ... ]`, `case` and stochastic arms. Code that needs
"every operation call" or "every successor" of a body walks it with these functions instead
of recursing by hand (the checker, reachability, the split compiler, the CGA translator, the
sketch plugin). The walk uses an explicit stack, so deep nesting never hits the recursion
limit.
"""
from __future__ import annotations

from typing import Any, Iterator

from .split import Branch, Case, Choice, OpCall, Pattern, Push, Repeat, Seq, Successor

__all__ = ["block_branches", "block_seqs", "child_seqs", "walk", "walk_seqs", "successor_names"]


def block_branches(block: Any) -> list[Branch]:
    """The entries `key: body` of an operation's block (a tuple of Branch/Repeat, or None),
    those inside repeat groups included, in source order."""
    out: list[Branch] = []
    stack = list(reversed(tuple(block or ())))
    while stack:
        x = stack.pop()
        if isinstance(x, Branch):
            out.append(x)
        elif isinstance(x, Repeat):
            stack.extend(reversed(x.items))
    return out


def block_seqs(block: Any) -> list[Seq]:
    """The bodies of an operation's block, repeat groups included, in source order."""
    return [b.body for b in block_branches(block)]


def child_seqs(item: Any) -> list[Seq]:
    """The sequences nested directly in one item, in source order ([] for a leaf item)."""
    if isinstance(item, OpCall):
        return block_seqs(item.block)
    if isinstance(item, Push):
        return [item.body]
    if isinstance(item, (Case, Choice)):
        return [a.body for a in item.arms] + ([item.otherwise] if item.otherwise is not None else [])
    return []


def walk_seqs(body: Seq) -> Iterator[Seq]:
    """`body` and every sequence nested in it, depth first, in source order."""
    stack = [body]
    while stack:
        seq = stack.pop()
        yield seq
        nested = [s for item in seq.items for s in child_seqs(item)]
        stack.extend(reversed(nested))


def walk(body: Seq) -> Iterator[Any]:
    """Every item of `body` and of the sequences nested in it (operation calls, successors,
    terminals, NIL, pushes, cases, choices, patterns), depth first in source order: an item
    comes before the items nested in it."""
    stack: list[Any] = list(reversed(body.items))
    while stack:
        item = stack.pop()
        yield item
        for seq in reversed(child_seqs(item)):
            stack.extend(reversed(seq.items))


def successor_names(body: Seq) -> Iterator[str]:
    """The rule names `body` hands shapes to: successors and the names of repeat patterns."""
    for item in walk(body):
        if isinstance(item, Successor):
            yield item.name
        elif isinstance(item, Pattern):
            yield from item.group
            if item.tail is not None:
                yield item.tail
