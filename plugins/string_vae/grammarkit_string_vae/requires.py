"""The optional dependencies of the learning commands, with install instructions when missing."""
from __future__ import annotations

from grammarkit.errors import GrammarkitError

INSTALL = ('python -m pip install -e ".[learning]" -c constraints.txt   (in a grammarkit checkout; '
           'the constraints file pins the CPU build of torch)')


def require_learning(what: str) -> None:
    """Raise a GrammarkitError saying how to install torch and safetensors if either is missing."""
    missing = []
    for name in ("torch", "safetensors"):
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise GrammarkitError(f"{what} needs {' and '.join(missing)}, which is not installed; install "
                              f"grammarkit's `learning` extra: {INSTALL}")
