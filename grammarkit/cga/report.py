"""What the importer did with each CGA construct: the per-file report (`--report report.json`).

A *construct* is one thing of the CGA file that has a meaning of its own: a declaration
(attr, const, function, rule, import), a rule-body item (an operation call, a successor, a
terminal, NIL, a push/pop, a case or stochastic block), a selector of `comp`, and an
annotation that grammarkit can express (`@Range`, `@Enum`, `@StartRule`). Each ends in one
of three states:

- `translated`: mapped to grammarkit with the same meaning;
- `approximated`: mapped, but with a documented difference (a located warning says which);
- `dropped`: not translated (a located warning says why).

`warned` = approximated + dropped. Every warned construct names the missing *feature* (e.g.
`op:setback`, `fn:geometry.area`, `expr:case`) so that a corpus can rank missing features by
how many constructs they would unlock. Metadata without geometric meaning (`version`, UI
annotations such as `@Order`, `@Group`, `@Description`) is listed under `ignored` and is not
counted as a construct. The warned constructs of imported files are located warnings too, and
listed under `imported_warned` (each is counted in its own file's report, not in this one).
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Literal

from ..ir.base import Span

Status = Literal["translated", "approximated", "dropped"]


@dataclass(frozen=True)
class Construct:
    kind: str        # "op", "successor", "attr", "rule", "selector", ...
    name: str        # "split", "comp(f)", "Lot", "@Range", ...
    status: Status
    span: Span | None = None
    feature: str | None = None   # what is missing (warned constructs only)
    message: str | None = None

    def to_json(self) -> dict:
        s = self.span
        return {"kind": self.kind, "name": self.name, "status": self.status,
                "feature": self.feature, "message": self.message,
                "line": s.line if s else None, "column": s.column if s else None}


@dataclass
class ImportReport:
    file: str | None
    constructs: list[Construct] = field(default_factory=list)
    ignored: Counter = field(default_factory=Counter)
    assets: list[dict] = field(default_factory=list)
    checks: bool | None = None        # does the translated grammar pass `grammarkit check`?
    check_errors: list[str] = field(default_factory=list)
    # warned constructs of the files this one imports (each counted in its own file's report)
    imported: list[Construct] = field(default_factory=list)

    def add(self, construct: Construct) -> None:
        self.constructs.append(construct)

    @property
    def total(self) -> int:
        return len(self.constructs)

    def count(self, *statuses: str) -> int:
        return sum(1 for c in self.constructs if c.status in statuses)

    @property
    def translated(self) -> int:
        return self.count("translated")

    @property
    def warned(self) -> int:
        return self.count("approximated", "dropped")

    def features(self) -> Counter:
        """Missing features -> number of warned constructs they account for."""
        return Counter(c.feature or "other" for c in self.constructs
                       if c.status != "translated")

    def by_name(self, status: str) -> Counter:
        return Counter(f"{c.kind}:{c.name}" for c in self.constructs if c.status == status)

    def to_json(self) -> dict:
        return {
            "file": self.file,
            "constructs": {"total": self.total, "translated": self.translated,
                           "approximated": self.count("approximated"),
                           "dropped": self.count("dropped"), "warned": self.warned},
            "share_translated": round(self.translated / self.total, 4) if self.total else None,
            "translated": dict(sorted(self.by_name("translated").items())),
            "approximated": dict(sorted(self.by_name("approximated").items())),
            "dropped": dict(sorted(self.by_name("dropped").items())),
            "missing_features": dict(self.features().most_common()),
            "ignored": dict(sorted(self.ignored.items())),
            "assets": self.assets,
            "checks": self.checks,
            "check_errors": self.check_errors,
            "items": [c.to_json() for c in self.constructs],
            "imported_warned": [{**c.to_json(), "file": c.span.file if c.span else None}
                                for c in self.imported],
        }
