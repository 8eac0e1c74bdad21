"""Shared fixtures. The repository root is put on ``sys.path`` so tests can import ``validation.*``.

Property-based tests are reproducible: the hypothesis profile ``"ci"`` (loaded here) is
derandomized (examples come from a fixed seed derived from the test), keeps no example
database, and prints the reproducing blob of any failure, so a run can never fail by chance.
A failure found this way is kept as an explicit ``@example``.
"""
import os
import sys

import pytest
from hypothesis import settings

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _ROOT not in sys.path:
    sys.path.insert(0, _ROOT)

settings.register_profile("ci", derandomize=True, database=None, print_blob=True, deadline=None)
# HYPOTHESIS_PROFILE=explore draws fresh random examples (to hunt for new failures locally, never in CI)
settings.register_profile("explore", derandomize=False, max_examples=500, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def flat_factory():
    """Return a factory building a fresh :class:`tps_solver.FlatLayer` (stable interior preset by default)."""
    from tps_solver.model.flat import FlatLayer

    def make(Gamma=2.5, M=2, e=0.45, t0=None, branch="stable"):
        if t0 is not None:
            e = None
        return FlatLayer(Gamma, M, e=e, t0=t0, branch=branch)

    return make
