"""Import CityEngine CGA rule files into grammarkit (`grammarkit import-cga`).

    grammar, diagnostics = grammarkit.import_cga("building.cga")   # or CGA text
    result = grammarkit.cga.translate_cga("building.cga")          # + text, report, ok

One module per concern: `cga.lark` (the grammar), `parser` (text -> tree, located syntax
errors), `expressions` and the `translate` package (tree -> IR: a translator of mixins, one handler module per operation family), `frames` (CGA's axes -> grammarkit's),
`report` (what happened to each construct), `importer` (print + check, nothing half-done).
See docs/cga.md.
"""
from .importer import MISSING_ASSETS, ImportResult, import_cga, translate_cga
from .report import Construct, ImportReport

__all__ = ["import_cga", "translate_cga", "ImportResult", "ImportReport", "Construct", "MISSING_ASSETS"]
