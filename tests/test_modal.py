"""The all-orders kernel and the modal basis (tps_solver.operators.modal) against mpmath at 50 digits."""
import math

import mpmath as mp
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.operators.modal import KERNEL_ULPS, ModalBasis, kernel, kernel_integral

EPS = np.finfo(float).eps
T = 4 * math.pi
MUS = -np.logspace(-12, 3, 46)                    # lambda T from -1e-12 to -1e3
XS = np.concatenate([[1e-12, 1e-6, 1e-3], np.linspace(0.01, 0.99, 25), [1 - 1e-6, 1 - 1e-12]])


def _reference(lam, tau):
    """H, dH/dtau and the zero-mean antiderivative from the textbook forms at 50 digits."""
    with mp.workdps(50):
        l, t, TT = mp.mpf(lam), mp.mpf(tau), mp.mpf(T)
        h = -mp.exp(l * t) / mp.expm1(l * TT) + 1 / (l * TT)
        hi = -mp.exp(l * t) / (l * mp.expm1(l * TT)) + t / (l * TT) + 1 / (l * l * TT) - 1 / (2 * l)
        return h, l * h - 1 / TT, hi


@pytest.mark.parametrize("mu", MUS)
def test_kernel_and_integral_against_mpmath(mu):
    """Error <= KERNEL_ULPS eps (|K| + |tau K'|): the relative error away from the zero of K."""
    lam = mu / T
    tau = XS * T
    got_h = kernel(lam, tau, T)
    got_i = kernel_integral(lam, tau, T)
    for k, t in enumerate(tau):
        h, hp, hi = _reference(lam, float(t))
        assert abs(got_h[k] - h) <= KERNEL_ULPS * EPS * (abs(h) + abs(t * hp))
        assert abs(got_i[k] - hi) <= KERNEL_ULPS * EPS * (abs(hi) + abs(t * h))


def test_zero_mode_limit():
    tau = np.linspace(0.1, T - 0.1, 7)
    np.testing.assert_array_equal(kernel(0.0, tau, T), 0.5 - tau / T)
    with mp.workdps(50):
        want = [float(mp.mpf(T) * (mp.mpf(x) / 2 - mp.mpf(x) ** 2 / 2 - mp.mpf(1) / 12))
                for x in tau / T]
    np.testing.assert_allclose(kernel_integral(0.0, tau, T), want, rtol=0, atol=4 * EPS * T)
    assert float(kernel(0.0, 0.0, T)) == 0.0 and float(kernel(0.0, 0.0, T, at_jump="right")) == 0.5
    with pytest.raises(ValueError, match="at_jump"):
        kernel(0.0, 0.0, T, at_jump="left")


def test_the_old_separable_form_loses_digits_where_the_kernel_does_not():
    """A e^{lam tau} + B (the separable tables) cancels at lambda T = -1e-9; kernel() does not."""
    lat = tps.Lattice.planar(n_nodes=3, length=1.0)
    mb = ModalBasis(lat, period=T)
    mb.lam = np.array([-1e-9 / T])
    mb._tables = None
    A, B, C, D = mb.separable_table()
    tau = 0.3 * T
    h = float(_reference(mb.lam[0], tau)[0])
    sep = A[0] * math.exp(mb.lam[0] * tau) + B[0] + C[0] * tau + D[0] * tau ** 2
    assert abs(sep - h) > 1e-9 * abs(h)
    assert abs(float(kernel(mb.lam[0], tau, T)) - h) <= 2 * EPS * abs(h)


@pytest.mark.parametrize("scale", [1e-1, 1e-2, 1e-3, 1e-4])
def test_separable_table_error_grows_like_inverse_lambda_T(scale):
    """The separable tables on a lattice whose operator is scaled down (smallest |lambda T| = 7.7e-3 scale):
    the kernel's error is O(eps/|lambda T|), the integral's O(eps T/|lambda T|^2) (documented in
    separable_table), and the integral's is not smaller than that order's tenth at the smallest."""
    mb = ModalBasis(tps.Lattice.planar(n_nodes=11, length=40.0 / math.sqrt(scale)), period=T)
    nz = ~mb.zero_modes()
    mu = float(np.min(np.abs(mb.lam[nz] * T)))
    tau = np.linspace(0.01, T - 0.01, 50)[:, None]
    errs = []
    for W in (False, True):
        A, B, C, D = mb.separable_table(W)
        sep = A * np.exp(mb.lam * tau) + B + C * tau + D * tau ** 2
        ref = kernel_integral(mb.lam, tau, T) + np.where(mb.zero_modes(), T / 12, 0.0) if W else kernel(mb.lam, tau, T)
        errs.append(float(np.max(np.abs(sep - ref)[:, nz])))
    assert errs[0] <= 64 * EPS / mu
    assert errs[1] <= 64 * EPS * T / mu ** 2
    if scale == 1e-4:
        assert errs[1] >= 0.1 * EPS * T / mu ** 2          # the cancellation is real (7e-5 measured)


@pytest.mark.parametrize("kind", ["planar", "axisymmetric"])
def test_modal_basis_diagonalises_the_lattice(kind):
    lat = (tps.Lattice.planar(n_nodes=7, length=9.0) if kind == "planar"
           else tps.Lattice.axisymmetric(n_nodes=7, r_max=9.0, grid="uniform"))
    mb = ModalBasis(lat, coupling=0.5)
    np.testing.assert_allclose(mb.V @ np.diag(mb.lam) @ mb.Vinv, 0.5 * lat.operator, atol=1e-12)
    np.testing.assert_allclose(mb.V @ mb.Vinv, np.eye(7), atol=1e-12)
    assert np.all(mb.lam <= 0.0) and abs(mb.lam[-1]) < 1e-14
