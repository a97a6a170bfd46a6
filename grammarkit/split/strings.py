"""CGA's string and list functions, as expression functions of split grammars.

CGA's lists are strings of items each ended by `;` (`"a;b;c;"`). The functions follow the
CGA reference: indices start at 0, an index out of range gives `""` (listItem) or `-1`
(listIndex, find); `str()` of a whole number has no decimal point (`str(3) == "3"`), as in
CityEngine. Registered through the `grammarkit_functions` hook by grammarkit.split.operations.

CGA's arrays (`[1, 2, 3]`, `[1, 2; 3, 4]`, `readStringTable`) are values of the expression
language too: a text value that starts with ARRAY_TAG and holds the rows, the columns and each
item with its type (`f` number, `b` boolean, `s` text), so an array is passed through attrs,
consts, rule parameters and `==` like any value, and `m[i, j]` gives a number, a boolean or a
text as the item was. The importer (grammarkit/cga/expressions.py) writes `cgaArray(rows,
columns, items...)` for an array literal and `cgaIndex(m, i)`/`cgaIndex(m, i, j)` for an index
(CGA: from 0; one index on a 2D array counts in row-major order; out of range is an error).
"""
from __future__ import annotations

from typing import Any

from ..registry import FunctionSpec

__all__ = ["ARRAY_TAG", "STRING_FUNCTIONS", "array_value", "cga_str"]

ARRAY_TAG = "\x1farray:"
_SEP = "\x1f"


def cga_str(v: Any) -> str:
    """CGA's str(): numbers without a trailing .0, booleans as true/false, strings unchanged;
    an array as `[a,b;c,d]` (rows separated by `;`)."""
    if isinstance(v, str) and v.startswith(ARRAY_TAG):
        rows, cols, items = _array(v)
        text = [cga_str(x) for x in items]
        return "[" + ";".join(",".join(text[r * cols:(r + 1) * cols]) for r in range(rows)) + "]"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _float(v: Any) -> float:
    if isinstance(v, str):
        try:
            return float(v.strip())
        except ValueError:
            return float("nan")  # CGA: a string that is not a number is NaN
    return float(v)


def _items(lst: str) -> list[str]:
    s = str(lst)
    parts = s.split(";")
    return parts[:-1] if s.endswith(";") else parts if s else []


def _index(i: Any) -> int:
    if isinstance(i, bool) or not isinstance(i, (int, float)) or not float(i).is_integer():
        raise ValueError(f"an index must be a whole number, got {i!r}")
    return int(i)


def _list_item(lst: str, i: Any) -> str:
    items, k = _items(lst), _index(i)
    return items[k] if 0 <= k < len(items) else ""


def _list_index(lst: str, item: Any) -> int:
    items = _items(lst)
    return items.index(str(item)) if str(item) in items else -1


def _list_range(lst: str, start: Any, end: Any) -> str:
    items = _items(lst)
    part = items[max(0, _index(start)):max(0, _index(end))]
    return "".join(x + ";" for x in part)


def _find(s: str, sub: str, n: Any = 0) -> int:
    """Position of the n-th occurrence (from 0) of `sub` in `s`, or -1."""
    pos, k = -1, _index(n)
    for _ in range(k + 1):
        pos = str(s).find(str(sub), pos + 1)
        if pos < 0:
            return -1
    return pos


def _substring(s: str, start: Any, end: Any) -> str:
    return str(s)[max(0, _index(start)):max(0, _index(end))]


def _replace(s: str, old: str, new: str) -> str:
    return str(s).replace(str(old), str(new)) if str(old) else str(s)


def _typed(v: Any) -> str:
    if isinstance(v, bool):
        return "b1" if v else "b0"
    if isinstance(v, (int, float)):
        return "f" + repr(float(v))
    return "s" + str(v)


def _untyped(item: str) -> Any:
    kind, body = item[:1], item[1:]
    return float(body) if kind == "f" else body == "1" if kind == "b" else body


def array_value(rows: int, cols: int, items: "list[Any] | tuple[Any, ...]") -> str:
    """The array value of `rows` x `cols` items (row-major): numbers, booleans or texts."""
    if rows * cols != len(items):
        raise ValueError(f"an array of {rows} x {cols} needs {rows * cols} items, got {len(items)}")
    return f"{ARRAY_TAG}{rows}:{cols}" + "".join(_SEP + _typed(x) for x in items)


def _array(v: Any) -> tuple[int, int, list[Any]]:
    if not isinstance(v, str) or not v.startswith(ARRAY_TAG):
        raise ValueError(f"expected an array, got {cga_str(v)!r}")
    head, *items = v[len(ARRAY_TAG):].split(_SEP)
    rows, cols = (int(x) for x in head.split(":"))
    return rows, cols, [_untyped(x) for x in items]


def _new_array(rows: Any, cols: Any, *items: Any) -> str:
    """An array literal of rows x cols items; an item that is an array is spliced in, as CGA
    does: the items of a row side by side (`[a, b]`, same number of rows), the rows one under
    another (`[a; "x"; b]`, same number of columns)."""
    r, c = _index(rows), _index(cols)
    if not any(isinstance(x, str) and x.startswith(ARRAY_TAG) for x in items):
        return array_value(r, c, items)
    blocks = [_array(x) if isinstance(x, str) and x.startswith(ARRAY_TAG) else (1, 1, [x]) for x in items]
    out_rows: list[list[Any]] = []
    for k in range(r):
        row = blocks[k * c:(k + 1) * c]
        nonempty = [b for b in row if b[0] * b[1]]
        if len({b[0] for b in nonempty}) > 1:
            raise ValueError("arrays side by side in an array literal have different numbers of rows")
        height = nonempty[0][0] if nonempty else 0
        for i in range(height):
            out_rows.append([x for b in nonempty for x in b[2][i * b[1]:(i + 1) * b[1]]])
    if len({len(x) for x in out_rows}) > 1:
        raise ValueError("the rows of an array literal have different numbers of columns")
    width = len(out_rows[0]) if out_rows else 0
    return array_value(len(out_rows), width, [x for row in out_rows for x in row])


def _array_index(m: Any, i: Any, j: Any = None) -> Any:
    rows, cols, items = _array(m)
    if j is None:  # one index: row-major over every item (CGA)
        k = _index(i)
        if not 0 <= k < len(items):
            raise ValueError(f"array index {k} out of range (the array has {len(items)} items)")
        return items[k]
    r, c = _index(i), _index(j)
    if not (0 <= r < rows and 0 <= c < cols):
        raise ValueError(f"array index [{r}, {c}] out of range (the array is {rows} x {cols})")
    return items[r * cols + c]


def _span(n: int, start: Any, end: Any, step: Any) -> list[int]:
    """CGA's index range start:end or start:step:end, both ends included (a negative step
    counts down); indices outside 0..n-1 select nothing (a range over the rows of a table
    that has none, `m[1:nRows(m) - 1, 0]`, is empty)."""
    a, b, k = _index(start), _index(end), _index(step)
    if k == 0:
        raise ValueError("an array index range has step 0")
    return [i for i in range(a, b + (1 if k > 0 else -1), k) if 0 <= i < n]


def _array_slice(m: Any, *bounds: Any) -> str:
    """m[r0:r1, c0:c1] (cgaSlice(m, r0, r1, rstep, c0, c1, cstep)) or, with three bounds, a
    range over the items in row-major order (a 1 x k array)."""
    rows, cols, items = _array(m)
    if len(bounds) == 3:
        picked = [items[k] for k in _span(len(items), *bounds)]
        return array_value(1, len(picked), picked)
    rs, cs = _span(rows, *bounds[:3]), _span(cols, *bounds[3:])
    return array_value(len(rs), len(cs), [items[r * cols + c] for r in rs for c in cs])


def _same(item: Any, v: Any) -> bool:
    """An array item equal to v: numbers by value (the evaluator may hand over ints), a
    boolean only to a boolean, a text only to a text."""
    if isinstance(item, bool) or isinstance(v, bool):
        return isinstance(item, bool) and isinstance(v, bool) and item == v
    if isinstance(item, float):
        return isinstance(v, (int, float)) and item == float(v)
    return isinstance(v, str) and item == v


def _find_first(v: Any, match: Any) -> float:
    """CGA's findFirst: of an array, the index (row-major) of the first item equal to match;
    of a text, the position of the first match."""
    if isinstance(v, str) and v.startswith(ARRAY_TAG):
        items = _array(v)[2]
        return float(next((k for k, x in enumerate(items) if _same(x, match)), -1))
    return float(str(v).find(str(match)))


def _size(v: Any) -> float:
    """CGA's size(): the number of items of an array, the length of a text otherwise."""
    if isinstance(v, str) and v.startswith(ARRAY_TAG):
        return float(len(_array(v)[2]))
    return float(len(str(v)))


ARRAY_FUNCTIONS: tuple[FunctionSpec, ...] = (
    FunctionSpec("cgaArray", 2, None, "cgaArray(rows, columns, items...): a CGA array (row-major)",
                 _new_array),
    FunctionSpec("cgaIndex", 2, 3, "cgaIndex(m, i) / cgaIndex(m, i, j): CGA's m[i] / m[i, j] (from 0)",
                 _array_index),
    FunctionSpec("cgaSlice", 4, 7, "cgaSlice(m, r0, r1, rstep[, c0, c1, cstep]): CGA's m[r0:r1, c0:c1]",
                 _array_slice),
    FunctionSpec("cgaFindFirst", 2, 2, "cgaFindFirst(m, v): CGA's findFirst of an array or a text",
                 _find_first),
    FunctionSpec("cgaVector", 1, 1, "cgaVector(m): the items of a CGA array as a vector (per-edge values)",
                 lambda m: tuple(_array(m)[2])),
    FunctionSpec("cgaSize", 1, 1, "cgaSize(m): CGA's size(): the items of an array", _size),
    FunctionSpec("cgaRows", 1, 1, "cgaRows(m): CGA's nRows()", lambda m: float(_array(m)[0])),
    FunctionSpec("cgaColumns", 1, 1, "cgaColumns(m): CGA's nColumns()", lambda m: float(_array(m)[1])),
)


STRING_FUNCTIONS: tuple[FunctionSpec, ...] = (
    FunctionSpec("str", 1, 1, "str(x): x as text (CGA: 3 -> \"3\", 2.5 -> \"2.5\")", cga_str),
    FunctionSpec("float", 1, 1, "float(x): a number from a number, boolean or text", _float),
    FunctionSpec("len", 1, 1, "len(s): number of characters", lambda s: len(str(s))),
    FunctionSpec("find", 2, 3, "find(s, sub, n=0): position of the n-th sub in s, or -1", _find),
    FunctionSpec("substring", 3, 3, "substring(s, start, end): characters start..end-1", _substring),
    FunctionSpec("replace", 3, 3, "replace(s, old, new): every old in s replaced by new", _replace),
    FunctionSpec("listSize", 1, 1, "listSize(\"a;b;\"): number of items of a CGA list",
                 lambda lst: len(_items(lst))),
    FunctionSpec("listItem", 2, 2, "listItem(list, i): item i (from 0), or \"\"", _list_item),
    FunctionSpec("listIndex", 2, 2, "listIndex(list, item): index of item, or -1", _list_index),
    FunctionSpec("listFirst", 1, 1, "listFirst(list): the first item, or \"\"",
                 lambda lst: _list_item(lst, 0)),
    FunctionSpec("listLast", 1, 1, "listLast(list): the last item, or \"\"",
                 lambda lst: (_items(lst) or [""])[-1]),
    FunctionSpec("listRange", 3, 3, "listRange(list, start, end): items start..end-1 as a list",
                 _list_range),
) + ARRAY_FUNCTIONS
