"""The one Floquet module: multipliers of a monodromy and the measured growth fit."""
import numpy as np
import pytest
from scipy.sparse.linalg import aslinearoperator

from tps_solver.solvers.shooting.floquet import fit_growth, multipliers


def _known_spectrum(n=30, seed=7):
    rng = np.random.default_rng(seed)
    mu = np.concatenate([[0.95, -0.8 + 0.3j, -0.8 - 0.3j], rng.uniform(-0.5, 0.5, n - 3)])
    # a real matrix with these eigenvalues: block-diagonal, then a similarity transform
    D = np.diag(mu.real.astype(float))
    D[1, 2], D[2, 1] = 0.3, -0.3
    S = rng.normal(size=(n, n)) + n * np.eye(n)
    return S @ D @ np.linalg.inv(S), mu


def test_dense_multipliers_of_a_known_spectrum():
    A, mu = _known_spectrum()
    got = multipliers(A)
    ref = mu[np.argsort(-np.abs(mu), kind="stable")]
    assert np.max(np.abs(np.sort_complex(got) - np.sort_complex(ref))) < 1e-12
    assert np.all(np.diff(np.abs(got)) <= 1e-15)


def test_leading_multipliers_by_arnoldi_agree_with_dense():
    A, _ = _known_spectrum()
    dense = multipliers(A)[:3]
    for M in (A, aslinearoperator(A)):
        lead = multipliers(M, k=3)
        assert np.max(np.abs(np.sort_complex(lead) - np.sort_complex(dense))) < 1e-12
    with pytest.raises(ValueError, match="k must be given"):
        multipliers(aslinearoperator(A))
    with pytest.raises(ValueError, match="square"):
        multipliers(np.ones((2, 3)))


def test_fit_growth_recovers_a_geometric_rate_and_stops_at_saturation():
    for rate in (0.3, 0.97, 1.4):
        d = 1e-9 * rate ** np.arange(40)
        g, (k0, k1) = fit_growth(d)
        assert abs(g - rate) < 1e-12 * rate
        assert np.all(d[:k1 + 1] < 1e-3) and (k1 == 39 or d[k1 + 1] >= 1e-3)
    assert np.isnan(fit_growth(np.array([1e-9, 1.0]))[0])          # no linear window
    assert np.isnan(fit_growth(np.array([1e-9, 0.0, 1e-9, 1e-9]))[0])
