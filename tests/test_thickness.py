"""The long-wave thickness model (docs/thickness.md) against the varicose roots of (35)."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.model.thickness import long_wave_rates


def test_stretching_rate_is_the_long_wave_limit_of_the_varicose_roots():
    # the least-damped varicose root of (35) against -4 nu k^2: relative difference O((kh)^2),
    # measured slope of the log-log fit
    h = 1.0
    kh = np.array([0.1, 0.05, 0.025, 0.0125])
    rel = []
    for k in kh / h:
        root = float(np.max(np.asarray(tps.growth_rates(k=k, h=h, mode="varicose", n_modes=3))))
        model = float(long_wave_rates(k)["stretching"])
        rel.append(abs(root - model) / abs(model))
    slope = np.polyfit(np.log(kh), np.log(rel), 1)[0]
    assert slope == pytest.approx(2.0, abs=0.05)
    assert rel[-1] < 1e-4


def test_rates_reject_bad_input():
    with pytest.raises(ValueError, match="k must be"):
        long_wave_rates(-1.0)
