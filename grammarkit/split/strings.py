"""CGA's string and list functions, as expression functions of split grammars.

CGA's lists are strings of items each ended by `;` (`"a;b;c;"`). The functions follow the
CGA reference: indices start at 0, an index out of range gives `""` (listItem) or `-1`
(listIndex, find); `str()` of a whole number has no decimal point (`str(3) == "3"`), as in
CityEngine. Registered through the `grammarkit_functions` hook by grammarkit.split.operations.
"""
from __future__ import annotations

from typing import Any

from ..registry import FunctionSpec

__all__ = ["STRING_FUNCTIONS", "cga_str"]


def cga_str(v: Any) -> str:
    """CGA's str(): numbers without a trailing .0, booleans as true/false, strings unchanged."""
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
)
