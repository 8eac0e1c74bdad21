"""Shared fixtures. The repository root is put on ``sys.path`` so tests can import ``validation.*``."""
import os
import sys

import pytest

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _ROOT not in sys.path:
    sys.path.insert(0, _ROOT)


@pytest.fixture
def flat_factory():
    """Return a factory building a fresh :class:`tps_solver.FlatLayer` (stable interior preset by default)."""
    from tps_solver.flat import FlatLayer

    def make(Gamma=2.5, M=2, e=0.45, t0=None, branch="stable"):
        if t0 is not None:
            e = None
        return FlatLayer(Gamma, M, e=e, t0=t0, branch=branch)

    return make
