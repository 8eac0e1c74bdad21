"""Cell integrals of the Helmholtz Green's functions against mpmath at 40 digits."""
import mpmath as mp
import numpy as np
import pytest

from tps_solver.operators.kernels import (exp_moments, helmholtz_beta, radial_half_cell_moments, radial_moment_i, radial_moment_k)

DPS = 40
RTOL = 1e-12


def _random_cases(seed, count):
    """Random (beta, a, b): |beta| in [0.02, 12], |arg beta| <= pi/3, a in [0, 200], h in [1e-3, 30]."""
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(count):
        mod = rng.uniform(0.02, 12.0)
        arg = np.pi / 4 if i % 3 == 0 else rng.uniform(-np.pi / 3, np.pi / 3)
        beta = mod * np.exp(1j * arg)
        a = [0.0, rng.uniform(0.0, 2.0), rng.uniform(0.0, 200.0)][i % 3]
        h = 10.0 ** rng.uniform(-3.0, np.log10(30.0))
        cases.append((complex(beta), float(a), float(a + h)))
    return cases


def _mpc(z):
    return mp.mpc(z.real, z.imag)


def _ref_moment_i(beta, a, b):
    with mp.workdps(DPS):
        B = _mpc(beta)
        val = (b * mp.besseli(1, B * b) - a * mp.besseli(1, B * a)) / B
        return complex(val * mp.exp(-B.real * b))


def _ref_moment_k(beta, a, b):
    with mp.workdps(DPS):
        B = _mpc(beta)
        near = 1 / B if a == 0 else a * mp.besselk(1, B * a)
        val = (near - b * mp.besselk(1, B * b)) / B
        return complex(val * mp.exp(B * a))


def _rel_err(value, ref):
    return abs(value - ref) / abs(ref)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_radial_moments_against_mpmath_closed_form(seed):
    cases = _random_cases(seed, 45)
    beta, a, b = (np.array(v) for v in zip(*cases))
    mi = radial_moment_i(beta, a, b)
    mk = radial_moment_k(beta, a, b)
    for j, (bt, aa, bb) in enumerate(cases):
        assert _rel_err(mi[j], _ref_moment_i(bt, aa, bb)) <= RTOL, (bt, aa, bb)
        assert _rel_err(mk[j], _ref_moment_k(bt, aa, bb)) <= RTOL, (bt, aa, bb)


def test_half_cell_moments_against_mpmath():
    """Solver weights: both halves of random cells, rescaled as documented, vs mpmath."""
    cases = _random_cases(3, 40)
    beta, a, b = (np.array(v) for v in zip(*cases))
    il, ir, kl, kr = radial_half_cell_moments(beta, a, b)
    with mp.workdps(DPS):
        for j, (bt, aa, bb) in enumerate(cases):
            B, m = _mpc(bt), 0.5 * (aa + bb)
            shift_i = complex(mp.exp(-B.real * (mp.mpf(bb) - mp.mpf(m))))
            shift_k = complex(mp.exp(-B * (mp.mpf(m) - mp.mpf(aa))))
            assert _rel_err(il[j], _ref_moment_i(bt, aa, m) * shift_i) <= RTOL, (bt, aa, bb)
            assert _rel_err(ir[j], _ref_moment_i(bt, m, bb)) <= RTOL, (bt, aa, bb)
            assert _rel_err(kl[j], _ref_moment_k(bt, aa, m)) <= RTOL, (bt, aa, bb)
            assert _rel_err(kr[j], _ref_moment_k(bt, m, bb) * shift_k) <= RTOL, (bt, aa, bb)


@pytest.mark.parametrize("beta, a, b", [
    (0.05 * np.exp(0.25j * np.pi), 150.0, 150.01),      # tiny |beta| h, far out: Taylor branch
    (12.0 * np.exp(0.25j * np.pi), 199.0, 199.1),       # large |beta|, far out: Taylor branch
    (3.0 * np.exp(0.25j * np.pi), 0.0, 1e-3),           # at the origin, series branch
    (3.0 * np.exp(0.25j * np.pi), 2e-3, 5e-3),          # near the origin, series branch
    (2.0 * np.exp(0.25j * np.pi), 60.0, 63.0),          # closed-form branch
])
def test_radial_moments_against_mpmath_quad(beta, a, b):
    """Independent reference: adaptive quadrature of the scaled integrands at 30 digits.

    The scale factors go inside the integrand: mpmath's quad judges convergence
    on the size of the integrand, which unscaled is ~exp(-1700) at r = 200.
    """
    with mp.workdps(30):
        B = _mpc(complex(beta))
        pts = list(np.linspace(a, b, 2 + int(abs(beta) * (b - a))))
        scale_i, scale_k = mp.exp(-B.real * b), mp.exp(B * a)
        ref_i = mp.quad(lambda s: s * mp.besseli(0, B * s) * scale_i, pts)
        ref_k = mp.quad(lambda s: s * mp.besselk(0, B * s) * scale_k, pts)
    assert _rel_err(radial_moment_i(beta, a, b), complex(ref_i)) <= RTOL
    assert _rel_err(radial_moment_k(beta, a, b), complex(ref_k)) <= RTOL


def test_exp_moments_against_mpmath():
    rng = np.random.default_rng(7)
    mods = np.concatenate([10.0 ** rng.uniform(-6, np.log10(2400.0), 200), [0.0, 0.4999, 0.5001]])
    args = rng.uniform(-np.pi / 3, np.pi / 3, mods.size)
    z = mods * np.exp(1j * args)
    phi0, phi1 = exp_moments(z)
    with mp.workdps(DPS):
        for j, zj in enumerate(z):
            Z = _mpc(zj)
            if zj == 0:
                r0, r1 = mp.mpf(1), mp.mpf(1) / 2
            else:
                e = mp.exp(-Z)
                r0, r1 = (1 - e) / Z, (1 - (1 + Z) * e) / Z**2
            assert _rel_err(phi0[j], complex(r0)) <= RTOL, zj
            assert _rel_err(phi1[j], complex(r1)) <= RTOL, zj


@pytest.mark.parametrize("z", [1e-3 * np.exp(0.25j * np.pi), 0.7 + 0.7j, 9.0 - 4.0j])
def test_exp_moments_against_quad(z):
    with mp.workdps(DPS):
        Z = _mpc(z)
        r0 = mp.quad(lambda t: mp.exp(-Z * t), [0, 1])
        r1 = mp.quad(lambda t: t * mp.exp(-Z * t), [0, 1])
    phi0, phi1 = exp_moments(z)
    assert _rel_err(phi0, complex(r0)) <= RTOL
    assert _rel_err(phi1, complex(r1)) <= RTOL


@pytest.mark.parametrize("N, M", [(1, 1), (5, 2), (256, 4)])
def test_helmholtz_beta(N, M):
    beta = helmholtz_beta(N, M)
    n = np.arange(1, N + 1)
    assert beta.shape == (N,)
    assert np.all(beta.real > 0)
    np.testing.assert_allclose(beta**2, 1j * n / M, rtol=4 * np.finfo(float).eps)
    np.testing.assert_allclose(np.angle(beta), np.pi / 4, rtol=4 * np.finfo(float).eps)


def test_no_floating_point_warnings_n256_length200():
    """Every branch, N = 256 at alpha = 1/2, cells up to r = 200: finite, no FP flags."""
    beta = helmholtz_beta(256, 2)[:, None]
    edges = np.concatenate([[0.0], np.geomspace(1e-3, 200.0, 300)])
    a, b = edges[:-1], edges[1:]
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        mi = radial_moment_i(beta, a, b)
        mk = radial_moment_k(beta, a, b)
        halves = radial_half_cell_moments(beta, a, b)
        phi0, phi1 = exp_moments(beta * 200.0)
    for arr in (mi, mk, phi0, phi1) + halves:
        assert np.all(np.isfinite(arr))
