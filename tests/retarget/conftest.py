"""The retargeter's structured test models (built in code) and their principal offsets,
computed once per test session."""
from __future__ import annotations

import pytest

from grammarkit_retarget import testmodels
from grammarkit_retarget.offsets import principal_offsets


@pytest.fixture(scope="session")
def models():
    return {name: testmodels.build(name) for name in testmodels.MODELS}


@pytest.fixture(scope="session")
def offsets(models):
    return {name: principal_offsets(model.mesh) for name, model in models.items()}
