"""Where the imported grammar finds its assets, from wherever it is written.

- Literal names of found assets become paths relative to the output grammar (as before).
- A CityEngine project's folders (cga/project.py: the rule file's folder, the project and its
  `assets/`, imported projects) become the grammar's `asset_dir` lines (INTERFACES.md item
  1), relative to the output grammar, so that computed names (attrs, consts, rule
  arguments, fileRandom) resolve at derive time from any working folder.
- Where the language has no `asset_dirs` yet (the IR field is missing), computed `i()` and
  `texture()` names go through an emitted function that tries the same folders with
  `fileExists` at derive time instead (the same lookup, spelled in the grammar).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from .. import ir as _ir
from ..ir import Binary, Call, Function, Grammar, Num, Ref, Str
from .report import ImportReport

LOOKUP_FUNCTION = "cga_asset"


def relative_dirs(dirs: Sequence[Path], output: "str | Path | None") -> tuple[str, ...]:
    """The folders as paths relative to the output grammar's folder (posix, no repeats)."""
    out_dir = Path(output).resolve().parent if output else Path.cwd()
    seen: list[str] = []
    for d in dirs:
        rel = Path(os.path.relpath(Path(d).resolve(), out_dir)).as_posix()
        if rel not in seen:
            seen.append(rel)
    return tuple(seen)


def supports_asset_dirs() -> bool:
    """Whether the language has `asset_dir` statements (INTERFACES.md item 1: the IR's
    `AssetDir` statement, read back as `Grammar.asset_dirs`)."""
    return getattr(_ir, "AssetDir", None) is not None


def _is_material_map(node: dict) -> bool:
    """`set(material.colormap, "file")` and the other texture maps."""
    if node.get("name") != "set" or len(node["args"]) != 2:
        return False
    target = node["args"][0]["value"]
    name = target.get("name", "") if isinstance(target, dict) else ""
    return name.startswith("material.") and name.endswith("map")


def _asset_arg(node: dict) -> dict | None:
    """The path argument of an i(), texture() or material-map set() node, else None."""
    if node.get("kind") == "op" and node.get("args") and (
            node.get("name") in ("i", "texture") or _is_material_map(node)):
        return node["args"][0 if node.get("name") != "set" else 1]
    return None


def place_assets(grammar: Grammar, report: ImportReport, output: "str | Path | None",
                 search_dirs: Sequence[Path] = (), projects: "dict[str, Path] | None" = None) -> Grammar:
    """Literal found assets relative to the output; the project's folders as asset_dir lines
    (or, without them in the language, a derive-time lookup of computed names)."""
    found = {a["path"]: a["resolved"] for a in report.assets if a["found"]}
    out_dir = Path(output).resolve().parent if output else Path.cwd()
    mapping = {p: Path(os.path.relpath(Path(r).resolve(), out_dir)).as_posix() for p, r in found.items()}
    dirs = relative_dirs(search_dirs, output) if search_dirs else ()
    wrap = bool(dirs) and not supports_asset_dirs()
    # a computed workspace path (`/ESRI.lib/assets/...` from Esri's Plant_Loader) names a file
    # of a project the package carries; asset_dir lines do not map its project prefix, so
    # computed names go through the lookup of the workspace paths alone
    named_only = bool(projects) and not wrap and supports_asset_dirs()
    wrap = wrap or named_only
    if not mapping and not dirs and not named_only:
        return grammar
    data = grammar.model_dump(mode="python")
    wrapped = [False]
    taken = {s.get("name") for s in data.get("statements", ()) if isinstance(s, dict)}
    fname = LOOKUP_FUNCTION
    while fname in taken:
        fname += "_"

    def walk(node: Any) -> Any:
        if isinstance(node, dict):
            arg = _asset_arg(node)
            if arg is not None:
                value = arg["value"]
                if value.get("kind") == "str" and value["value"] in mapping:
                    value["value"] = mapping[value["value"]]
                elif wrap and value.get("kind") != "str":
                    arg["value"] = Call(func=fname, args=(_expr(value),)).model_dump(mode="python")
                    wrapped[0] = True
            return {k: walk(v) for k, v in node.items()}
        if isinstance(node, (list, tuple)):  # pydantic dumps tuple fields (blocks) as tuples
            return [walk(v) for v in node]
        return node
    data = walk(data)
    out = Grammar.model_validate(data)
    if dirs and supports_asset_dirs():
        lines = tuple(_ir.AssetDir(value=Str(value=d)) for d in dirs)
        out = out.model_copy(update={"statements": lines + tuple(out.statements)})
    if wrapped[0]:
        named = {name: relative_dirs([d], output)[0] for name, d in (projects or {}).items()}
        out = out.model_copy(update={"statements": (_lookup_function(fname, () if named_only else dirs, named),
                                                    *out.statements)})
    return out


def _expr(value: dict) -> Any:
    """A dumped expression back as IR (through a throwaway function statement)."""
    return Function.model_validate({"name": "x", "params": (), "value": value}).value


def _lookup_function(name: str, dirs: Sequence[str], projects: "dict[str, str] | None" = None) -> Function:
    """func cga_asset(p) = select(fileExists(p), p, select(fileExists("d1/" + p), "d1/" + p, ... p))
    - the grammar's folder first, then each project folder in CityEngine's order; a workspace
    path `/Project/rest` is first tried as `rest` in that project's folder."""
    p = Ref(name="p")
    body: Any = p
    for d in reversed(("",) + tuple(dirs)):
        path = p if not d else Binary(op="+", left=Str(value=d.rstrip("/") + "/"), right=p)
        body = Call(func="select", args=(Call(func="fileExists", args=(path,)), path, body))
    for proj, d in sorted((projects or {}).items(), reverse=True):
        mark = Str(value=f"/{proj}/")
        path = Binary(op="+", left=Str(value=d.rstrip("/") + "/"), right=Call(func="getSuffix", args=(p, mark)))
        starts = Binary(op="==", left=Call(func="findFirst", args=(p, mark)), right=Num(value=0))
        body = Call(func="select", args=(Binary(op="&&", left=starts, right=Call(func="fileExists", args=(path,))),
                                         path, body))
    return Function(name=name, params=("p",), value=body)
