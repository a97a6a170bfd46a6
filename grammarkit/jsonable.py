"""Plain JSON values from the nested mappings, sequences and numpy values that reports,
manifests and GLB extras carry (numpy arrays and scalars are not JSON-serialisable)."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np


def to_jsonable(value: Any) -> Any:
    """`value` with mappings as dicts (string keys), sequences as lists, numpy as Python
    numbers; anything else that JSON cannot hold becomes its `str()`."""
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    return str(value)
