"""Fourier convention, forcing harmonics and the flat layer's closed-form coefficients.

References: QUADPACK oscillatory quadrature of the paper's (17)-(18) (first form), a direct
double loop for the synthesis, and fitted convergence slopes of partial sums.
"""
import math

import numpy as np
import pytest

from tps_solver.model.flat import FlatLayer
from tps_solver.model.harmonics import evaluate, flat_w_hat, g_hat, mode_numbers
from validation.flat_layer_analytics import mpmath_coefficient, paper_flight, quad_coefficients

EPS = np.finfo(float).eps

CASES = [  # (Gamma, M, e, branch)
    (2.5, 2, 0.45, "stable"),
    (2.5, 2, 0.45, "unstable"),
    (1.9, 1, 0.3, "stable"),
    (4.8, 4, 0.45, "stable"),
    (0.8, 4, 0.9, "stable"),
]


def _layer(Gamma, M, e, branch):
    return FlatLayer(Gamma, M, e=e, branch=branch)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("which, N", [(0, 30), (1, 12)], ids=["W", "zeta"])
def test_closed_form_harmonics_equal_quadrature(case, which, N):
    """harmonics(N) (which = 0) and height_harmonics(N) (which = 1) vs QUADPACK of (17)-(18)."""
    fl = _layer(*case)
    ref, _ = quad_coefficients(lambda s: float(paper_flight(s, fl.t0, fl.W0, fl.Gamma)[which]),
                               fl.t0, fl.period, fl.M, N)
    c = fl.harmonics(N) if which == 0 else fl.height_harmonics(N)
    assert c.shape == (2 * N + 1,) and c.dtype == complex
    np.testing.assert_array_equal(c[::-1], np.conj(c))  # real function
    nz = mode_numbers(N) != 0 if which == 0 else slice(None)
    assert np.max(np.abs(c[nz] - ref[nz]) / np.abs(c[nz])) <= 1e-12
    if which == 0:
        assert c[N] == 0 and abs(ref[N]) <= 1e-13      # zero mean, (44)


@pytest.mark.parametrize("case, n, which", [
    (CASES[0], 30, "height"), (CASES[3], -25, "velocity"),
])
def test_high_harmonics_equal_mpmath(case, n, which):
    """Past n ~ 20 the zeta_n are below QUADPACK's round-off floor (about 1e-12 relative);
    mpmath at 24 digits shows the closed form is exact there too."""
    fl = _layer(*case)
    N = abs(n)
    c = (fl.harmonics(N) if which == "velocity" else fl.height_harmonics(N))[N + n]
    assert abs(c - mpmath_coefficient(*case, n, which)) <= 1e-13 * abs(c)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("N", [4, 16, 64, 256])
def test_partial_sum_at_jump_is_jump_mean(case, N):
    """At a contact t0 + kT the symmetric partial sum equals the jump's mean
    (W0 + W(t0+T-))/2 = -cos t0 exactly (up to round-off) once N >= M: the sawtooth's
    symmetric partial sums vanish at its jump."""
    fl = _layer(*case)
    if N < fl.M:
        pytest.skip("the forcing harmonic n = M is not resolved")
    mean_jump = 0.5 * (fl.W0 + fl.impact_velocity)
    assert mean_jump == pytest.approx(-math.cos(fl.t0), rel=1e-13, abs=1e-15)
    t = fl.t0 + fl.period * np.array([0.0, 1.0, -3.0])
    S = evaluate(fl.harmonics(N), t, fl.M)
    np.testing.assert_allclose(S, mean_jump, rtol=0, atol=4 * EPS * N * (1 + np.abs(t)).max())


@pytest.mark.parametrize("case", CASES[:3])
def test_partial_sums_converge_away_from_jump(case):
    fl = _layer(*case)
    Ns = np.array([16, 32, 64, 128, 256])
    inner = fl.t0 + fl.period * np.linspace(0.125, 0.875, 801)   # bounded away from the jump
    full = fl.t0 + fl.period * np.linspace(0.0, 1.0, 801)
    w_err, z_err = [], []
    for N in Ns:
        w_err.append(np.max(np.abs(evaluate(fl.harmonics(N), inner, fl.M) - fl.velocity(inner))))
        z_err.append(np.max(np.abs(evaluate(fl.height_harmonics(N), full, fl.M) - fl.height(full))))
    # W: pointwise O(1/N) away from the jump; zeta (continuous, kinked): uniform O(1/N)
    assert np.polyfit(np.log(Ns), np.log(w_err), 1)[0] == pytest.approx(-1.0, abs=0.1)
    assert np.polyfit(np.log(Ns), np.log(z_err), 1)[0] == pytest.approx(-1.0, abs=0.1)
    assert w_err[-1] < 0.02 and z_err[-1] < 0.02


def test_parseval(flat_factory):
    """sum |W_n|^2 (exact tail added) equals the period mean of W^2 by quadrature."""
    fl = flat_factory()
    N = 400
    w = fl.harmonics(N)
    from scipy import integrate
    msq = integrate.quad(lambda s: float(paper_flight(s, fl.t0, fl.W0, fl.Gamma)[0]) ** 2,
                         fl.t0, fl.t0 + fl.period, epsabs=1e-13, epsrel=1e-13)[0] / fl.period
    # for |n| > N > M, |W_n|^2 = (M / (n Gamma))^2; both signs: 2 (M/Gamma)^2 (psi'(N+1))
    from scipy.special import polygamma
    tail = 2 * (fl.M / fl.Gamma) ** 2 * float(polygamma(1, N + 1))
    assert np.sum(np.abs(w) ** 2) + tail == pytest.approx(msq, rel=1e-12)


@pytest.mark.parametrize("N, M, Gamma", [(5, 2, 2.5), (8, 3, 0.7), (1, 1, 4.0), (3, 4, 2.5)])
def test_g_hat_equals_quadrature(N, M, Gamma):
    ref, _ = quad_coefficients(lambda s: math.sin(s) - 1.0 / Gamma, 0.3, 2 * math.pi * M, M, N)
    g = g_hat(N, M, Gamma)
    assert g.shape == (2 * N + 1,)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-13)
    assert g[N] == -1.0 / Gamma
    if N < M:           # forcing harmonic not representable
        assert np.count_nonzero(g) == 1


def test_evaluate_matches_direct_sum():
    rng = np.random.default_rng(7)
    N, M, n_nodes = 6, 3, 4
    half = rng.normal(size=(N, n_nodes)) + 1j * rng.normal(size=(N, n_nodes))
    c = np.zeros((2 * N + 1, n_nodes), dtype=complex)
    c[N] = rng.normal(size=n_nodes)
    c[N + 1:] = half
    c[:N] = np.conj(half[::-1])
    t = rng.uniform(-20, 20, size=9)
    direct = np.zeros((t.size, n_nodes))
    for i, ti in enumerate(t):
        for j in range(n_nodes):
            acc = 0j
            for n in range(-N, N + 1):
                acc += c[N + n, j] * complex(math.cos(n * ti / M), math.sin(n * ti / M))
            direct[i, j] = acc.real
            assert abs(acc.imag) < 1e-12
    got = evaluate(c, t, M)
    assert got.shape == (t.size, n_nodes)
    np.testing.assert_allclose(got, direct, rtol=0, atol=1e-13)
    np.testing.assert_allclose(evaluate(c[:, 1], t, M), direct[:, 1], rtol=0, atol=1e-13)
    assert evaluate(c[:, 0], 1.5, M).shape == (1,)


@pytest.mark.parametrize("case", CASES)
def test_flat_w_hat_equals_flat_layer_harmonics(case):
    fl = _layer(*case)
    np.testing.assert_array_equal(flat_w_hat(17, fl.M, fl.Gamma, fl.t0), fl.harmonics(17))


@pytest.mark.parametrize("M, Gamma, tc", [(3, 2.0, 1.0), (1, 5.0, -2.0), (2, 0.9, 4.0)])
def test_flat_w_hat_any_contact_time(M, Gamma, tc):
    """For any tc (not only the (19) phase), flat_w_hat is the zero-mean sawtooth
    T/(2 Gamma) - cos t - (t - tc)/Gamma on (tc, tc + T)."""
    T = 2 * math.pi * M
    N = 10
    ref, _ = quad_coefficients(lambda s: T / (2 * Gamma) - math.cos(s) - (s - tc) / Gamma, tc, T, M, N)
    w = flat_w_hat(N, M, Gamma, tc)
    n = mode_numbers(N)
    np.testing.assert_allclose(w[n != 0], ref[n != 0], rtol=1e-12)
    assert w[N] == 0


def test_mode_numbers():
    np.testing.assert_array_equal(mode_numbers(3), [-3, -2, -1, 0, 1, 2, 3])


BAD = [
    (lambda: mode_numbers(0), "N"),
    (lambda: mode_numbers(True), "N"),
    (lambda: g_hat(0, 2, 2.5), "N"),
    (lambda: g_hat(-1, 2, 2.5), "N"),
    (lambda: g_hat(2.5, 2, 2.5), "N"),
    (lambda: g_hat(4, 0, 2.5), "M"),
    (lambda: g_hat(4, 2, 0.0), "Gamma"),
    (lambda: g_hat(4, 2, math.nan), "Gamma"),
    (lambda: g_hat(4, 2, math.inf), "Gamma"),
    (lambda: flat_w_hat(0, 2, 2.5, 0.3), "N"),
    (lambda: flat_w_hat(4, True, 2.5, 0.3), "M"),
    (lambda: flat_w_hat(4, 2, -2.5, 0.3), "Gamma"),
    (lambda: flat_w_hat(4, 2, 2.5, math.nan), "tc"),
    (lambda: evaluate(np.zeros(5), [0.0], 0), "M"),
    (lambda: evaluate(np.zeros(5), [0.0], 1.5), "M"),
]


@pytest.mark.parametrize("call, name", BAD)
def test_bad_input(call, name):
    with pytest.raises(ValueError, match=rf"^{name} "):
        call()
