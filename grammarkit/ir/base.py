"""Base classes of the IR: source spans and immutable nodes.

Every IR node is a frozen pydantic model that may carry the source span it came from.
Equality and hashing ignore spans (and attached comments), so that
``parse(print(ir)) == ir`` holds although printing moves text around.
"""
from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict


class Span(BaseModel):
    """Where a node came from: 1-based line and column, end exclusive."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    file: str | None = None
    line: int = 0
    column: int = 0
    end_line: int = 0
    end_column: int = 0

    def __str__(self) -> str:
        return f"{self.file or '<string>'}:{self.line}:{self.column}"


class Node(BaseModel):
    """An IR node: immutable, JSON round-trippable, compared without its span."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    # Fields that do not take part in equality (source positions, comments kept for `fmt`).
    _ignored_in_eq: ClassVar[frozenset[str]] = frozenset({"span", "comments"})

    span: Span | None = None

    def _key(self) -> tuple[Any, ...]:
        return tuple(
            (name, _freeze(value))
            for name, value in self.__dict__.items()
            if name not in self._ignored_in_eq
        )

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._key() == other._key()  # type: ignore[union-attr]

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._key()))

    def without_spans(self) -> "Node":
        """A copy with every span removed (useful for snapshots)."""
        return type(self).model_validate(_strip(self.model_dump(mode="python")))


def _freeze(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_freeze(v) for v in value)
    if isinstance(value, dict):
        return tuple(sorted((k, _freeze(v)) for k, v in value.items()))
    return value


def _strip(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _strip(v) for k, v in data.items() if k != "span"}
    if isinstance(data, (list, tuple)):
        return [_strip(v) for v in data]
    return data
