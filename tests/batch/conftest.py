"""Batch tests: lots, datasets, resume and failures, on the local executor and on a real
multi-process Dask LocalCluster (2 workers)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def dask_executor():
    """One Dask LocalCluster of 2 worker processes for the whole session (it takes seconds to
    start); tests must leave it running."""
    from grammarkit.run.dask_executor import DaskExecutor

    ex = DaskExecutor(workers=2)
    yield ex
    ex.close()
