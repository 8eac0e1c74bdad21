"""HelmholtzSolver against independent references: mpmath Green's-function integrals,
analytic piecewise solutions, manufactured smooth solutions (convergence slope)."""
import functools

import mpmath as mp
import numpy as np
import pytest

from tps_solver.operators.helmholtz import HelmholtzSolver
from validation import helmholtz as helmholtz_validation

EPS = np.finfo(float).eps


def _k(N, M):
    return 1j * np.arange(1, N + 1) / M


def _random_rhs(rng, N, n_nodes):
    q = rng.normal(size=(N, n_nodes)) + 1j * rng.normal(size=(N, n_nodes))
    q_inf = rng.normal(size=N) + 1j * rng.normal(size=N)
    return q, q_inf


def _random_nodes(rng, n_nodes, length):
    steps = rng.uniform(0.3, 1.7, n_nodes - 1)
    return np.concatenate([[0.0], np.cumsum(steps) * length / steps.sum()])


def _mpc(z):
    return mp.mpc(z.real, z.imag)


# ---------------------------------------------------------------- exactness class
def _planar_reference(x, q, q_inf, parity, M, at):
    """u(x_j), j in ``at``: int_0^inf [G(x_j - x') + parity G(x_j + x')] q(x') dx' by
    mpmath quad, q piecewise linear on the nodes and q_inf beyond; G = -exp(-beta|x|)/(2 beta)."""
    N, n = q.shape
    u = np.empty((N, len(at)), dtype=complex)
    with mp.workdps(20):
        for i in range(N):
            B = mp.sqrt(mp.mpc(0, (i + 1)) / M)
            sig = int(parity[i])
            for jj, j in enumerate(at):
                xj = mp.mpf(x[j])

                def green(t):
                    return -(mp.exp(-B * abs(xj - t)) + sig * mp.exp(-B * (xj + t))) / (2 * B)

                total = mp.quad(lambda t: green(t), [x[-1], mp.inf]) * _mpc(q_inf[i])
                for c in range(n - 1):
                    a, b = mp.mpf(x[c]), mp.mpf(x[c + 1])
                    qa, qb = _mpc(q[i, c]), _mpc(q[i, c + 1])
                    total += mp.quad(lambda t: green(t) * (qa * (b - t) + qb * (t - a)) / (b - a),
                                     [a, b])
                u[i, jj] = complex(total)
    return u


def _radial_reference(r, q, q_inf, M):
    """u(r_j) = -int_0^inf I0(beta r_<) K0(beta r_>) q(s) s ds at 30 digits, q piecewise
    constant on the dual cells and q_inf beyond, with the antiderivatives
    s I1(beta s)/beta and -s K1(beta s)/beta (checked against quad in test_kernels)."""
    N, n = q.shape
    mid = np.concatenate([[0.0], 0.5 * (r[1:] + r[:-1]), [r[-1]]])     # dual-cell edges
    u = np.empty((N, n), dtype=complex)
    with mp.workdps(30):
        for i in range(N):
            B = mp.sqrt(mp.mpc(0, (i + 1)) / M)

            @functools.lru_cache(maxsize=None)
            def prim_i(s):
                return s * mp.besseli(1, B * s) / B

            @functools.lru_cache(maxsize=None)
            def prim_k(s):
                return -1 / B**2 if s == 0 else -s * mp.besselk(1, B * s) / B

            for j in range(n):
                rj = mp.mpf(r[j])
                total = -mp.besseli(0, B * rj) * (0 - prim_k(mp.mpf(r[-1]))) * _mpc(q_inf[i])
                for c in range(n):
                    a, b = mp.mpf(mid[c]), mp.mpf(mid[c + 1])
                    qc = _mpc(q[i, c])
                    lo, hi = min(a, rj), min(b, rj)           # part with s <= r_j
                    if hi > lo:
                        total -= qc * mp.besselk(0, B * rj) * (prim_i(hi) - prim_i(lo))
                    lo, hi = max(a, rj), max(b, rj)           # part with s >= r_j
                    if hi > lo:
                        total -= qc * mp.besseli(0, B * rj) * (prim_k(hi) - prim_k(lo))
                u[i, j] = complex(total)
    return u


@pytest.mark.parametrize("seed, length, M, parity", [
    (0, 8.0, 2, (1, -1, 1)),
    (1, 30.0, 1, (-1, 1, -1)),
])
def test_planar_exact_for_piecewise_linear(seed, length, M, parity):
    rng = np.random.default_rng(seed)
    x = _random_nodes(rng, 9, length)
    q, q_inf = _random_rhs(rng, 3, x.size)
    u = HelmholtzSolver(x, "planar", M, 3).solve(q, q_inf, parity=np.array(parity))
    at = [0, 3, 8]
    ref = _planar_reference(x, q, q_inf, parity, M, at)
    assert np.max(np.abs(u[:, at] - ref)) <= 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("seed, length, M, N", [
    (0, 6.0, 2, 3),        # node spacing ~ 1/|beta|
    (1, 200.0, 2, 8),      # long domain, |beta| up to 2: e^{Re(beta) r} ~ 1e120
    (2, 0.5, 1, 2),        # fine cells near the origin
])
def test_radial_exact_for_dual_cell_constants(seed, length, M, N):
    rng = np.random.default_rng(seed)
    r = _random_nodes(rng, 9, length)
    q, q_inf = _random_rhs(rng, N, r.size)
    u = HelmholtzSolver(r, "axisymmetric", M, N).solve(q, q_inf)
    ref = _radial_reference(r, q, q_inf, M)
    assert np.max(np.abs(u - ref)) <= 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("R_index, M, N", [(20, 2, 4), pytest.param(150, 1, 6, marks=pytest.mark.slow)])
def test_radial_step_matches_analytic_solution(R_index, M, N):
    """q = q0 for r < R, q_inf beyond (R a dual-cell edge): u = -q0/k + A I0(beta r) inside,
    -q_inf/k + B K0(beta r) outside, with C^1 matching at R (analytic, no Green's function)."""
    r = np.linspace(0.0, 40.0, 401)
    R = 0.5 * (r[R_index] + r[R_index + 1])
    q0, q_inf = 1.0 - 0.5j, 0.3 + 0.2j
    q = np.where(r < R, q0, q_inf) * np.ones((N, 1))
    u = HelmholtzSolver(r, "axisymmetric", M, N).solve(q, np.full(N, q_inf))
    at = list(range(0, 401, 40)) + [R_index, R_index + 1]
    ref = np.empty((N, len(at)), dtype=complex)
    with mp.workdps(20):
        for i in range(N):
            k = mp.mpc(0, i + 1) / M
            B = mp.sqrt(k)
            jump = _mpc(q0 - q_inf)
            for j, rj in enumerate(r[at]):
                if rj < R:
                    val = -_mpc(q0) / k + jump * B * R * mp.besselk(1, B * R) * mp.besseli(0, B * rj) / k
                else:
                    val = -_mpc(q_inf) / k - jump * B * R * mp.besseli(1, B * R) * mp.besselk(0, B * rj) / k
                ref[i, j] = complex(val)
    assert np.max(np.abs(u[:, at] - ref)) <= 1e-10 * np.max(np.abs(ref))


def test_planar_jump_at_last_node_matches_analytic_solution():
    """q = q0 on [0, X], q_inf beyond; even: u = -q0/k + A cosh(beta x) for x <= X."""
    x = np.linspace(0.0, 5.0, 51)
    N, M = 3, 2
    q0, q_inf = 2.0 + 1.0j, -0.5 + 0.0j
    u = HelmholtzSolver(x, "planar", M, N).solve(np.full((N, x.size), q0), np.full(N, q_inf),
                                                 parity=np.ones(N, dtype=int))
    k = _k(N, M)[:, None]
    beta = np.sqrt(k)
    X = x[-1]
    # C^1 matching at X: A sinh(bX) = -B e^{-bX}, A cosh(bX) - B e^{-bX} = (q0 - q_inf)/k
    A = (q0 - q_inf) / k * np.exp(-beta * X)
    ref = -q0 / k + A * np.cosh(beta * x[None, :])
    assert np.max(np.abs(u - ref)) <= 1e-12 * np.max(np.abs(ref))


# ---------------------------------------------------------------- convergence order
@pytest.mark.parametrize("case, grid", [
    ("even", "uniform"), ("odd", "uniform"), ("axisymmetric", "uniform"),
    ("axisymmetric", "quasilog"), ("even", "quasilog"),
])
def test_second_order_convergence_for_smooth_rhs(case, grid):
    """Manufactured u = c + exp(-x^2) (even, radial) or x exp(-x^2) (odd): fitted slope 2."""
    study = helmholtz_validation.convergence_study(case, grid, sizes=(41, 81, 161, 321, 641))
    assert 1.9 <= study["slope"] <= 2.1, study
    assert study["errors"][-1] < 1e-4


# ---------------------------------------------------------------- far field, flat case
@pytest.mark.parametrize("geometry, parity", [("planar", 1), ("planar", -1), ("axisymmetric", None)])
def test_far_field_limit(geometry, parity):
    """A bump near the origin: u -> -q_inf/(i n alpha) exponentially far away."""
    x = np.linspace(0.0, 60.0, 601)
    N, M = 5, 2
    q_inf = np.array([1.0, -2.0j, 0.5, 3.0 + 1.0j, -1.0])
    q = q_inf[:, None] + np.exp(-(x - 2.0) ** 2)[None, :] * (1.0 + 2.0j)
    par = None if parity is None else np.full(N, parity)
    u = HelmholtzSolver(x, geometry, M, N).solve(q, q_inf, parity=par)
    u_inf = -q_inf / _k(N, M)
    far = x >= 40.0
    # decay rate of the slowest harmonic is Re(beta_1) = 0.5: e^{-0.5 * 35} ~ 2.5e-8
    assert np.max(np.abs(u[:, far] - u_inf[:, None])) <= 1e-7
    # and close to the bump the solution differs from the far field: the test can fail
    assert np.min(np.max(np.abs(u[:, x < 5] - u_inf[:, None]), axis=1)) > 1e-2


@pytest.mark.parametrize("geometry, parity", [("planar", 1), ("planar", -1), ("axisymmetric", None)])
def test_flat_rhs_gives_constant_solution(geometry, parity):
    """q = q_inf everywhere (N = 256, alpha = 1/2, length 200): u = -q_inf/(i n alpha) to
    round-off (odd planar harmonics: u_inf (1 - e^{-beta x}), the odd continuation)."""
    N, M = 256, 2
    x = np.linspace(0.0, 200.0, 400)
    rng = np.random.default_rng(5)
    q_inf = rng.normal(size=N) + 1j * rng.normal(size=N)
    par = None if parity is None else np.full(N, parity)
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        u = HelmholtzSolver(x, geometry, M, N).solve(q_inf[:, None] * np.ones(x.size), q_inf,
                                                     parity=par)
    k = _k(N, M)
    ref = np.broadcast_to((-q_inf / k)[:, None], u.shape)
    if parity == -1:
        ref = ref * (1.0 - np.exp(-np.sqrt(k)[:, None] * x[None, :]))
    scale = np.abs(-q_inf / k)[:, None]
    assert np.all(np.abs(u - ref) <= 8 * EPS * scale)


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
def test_no_warnings_n256_length200(geometry):
    N, M = 256, 2
    x = np.concatenate([[0.0], np.geomspace(1e-3, 200.0, 399)])
    rng = np.random.default_rng(11)
    q, q_inf = _random_rhs(rng, N, x.size)
    par = np.where(np.arange(N) % 2 == 0, 1, -1) if geometry == "planar" else None
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        u = HelmholtzSolver(x, geometry, M, N).solve(q, q_inf, parity=par)
    assert np.all(np.isfinite(u))
    # the Green's functions have L1 norm <= 2 sqrt(2)/|k| (image included), |k| >= 1/M
    q_max = max(np.max(np.abs(q)), np.max(np.abs(q_inf)))
    assert np.max(np.abs(u)) <= 4 * M * q_max


def test_odd_parity_vanishes_at_origin():
    rng = np.random.default_rng(3)
    x = _random_nodes(rng, 50, 10.0)
    q, q_inf = _random_rhs(rng, 4, x.size)
    u = HelmholtzSolver(x, "planar", 2, 4).solve(q, q_inf, parity=-np.ones(4, dtype=int))
    assert np.max(np.abs(u[:, 0])) <= 16 * EPS * np.max(np.abs(u))


def test_linearity_and_harmonic_independence():
    """Row n of u depends only on row n of q (vectorisation across harmonics is not mixing)."""
    rng = np.random.default_rng(4)
    r = _random_nodes(rng, 30, 10.0)
    q, q_inf = _random_rhs(rng, 3, r.size)
    solver = HelmholtzSolver(r, "axisymmetric", 2, 3)
    u = solver.solve(q, q_inf)
    q2 = q.copy()
    q2[1] = 0.0
    q_inf2 = q_inf.copy()
    q_inf2[1] = 0.0
    u2 = solver.solve(q2, q_inf2)
    np.testing.assert_array_equal(u2[[0, 2]], u[[0, 2]])
    assert np.all(u2[1] == 0)


# ---------------------------------------------------------------- bad input
_X = np.linspace(0.0, 5.0, 11)


@pytest.mark.parametrize("kwargs, name", [
    (dict(nodes=[0.0, 2.0, 1.0]), "nodes"),
    (dict(nodes=[0.0, 1.0, 1.0]), "nodes"),
    (dict(nodes=[0.5, 1.0, 2.0]), "nodes"),
    (dict(nodes=[0.0]), "nodes"),
    (dict(nodes=[[0.0, 1.0]]), "nodes"),
    (dict(nodes=[0.0, np.nan, 2.0]), "nodes"),
    (dict(nodes=[0.0, 1.0 + 1j]), "nodes"),
    (dict(geometry="spherical"), "geometry"),
    (dict(M=0), "M"),
    (dict(M=1.5), "M"),
    (dict(N=0), "N"),
    (dict(N=True), "N"),
])
def test_bad_constructor_input(kwargs, name):
    args = dict(nodes=_X, geometry="planar", M=2, N=3) | kwargs
    with pytest.raises(ValueError, match=name):
        HelmholtzSolver(**args)


@pytest.mark.parametrize("geometry, q, q_inf, parity, name", [
    ("planar", np.ones((2, 11)), np.ones(3), [1, 1, 1], "q"),
    ("planar", np.ones((3, 10)), np.ones(3), [1, 1, 1], "q"),
    ("planar", np.full((3, 11), np.nan), np.ones(3), [1, 1, 1], "q"),
    ("planar", np.ones((3, 11)), np.ones(2), [1, 1, 1], "q_inf"),
    ("planar", np.ones((3, 11)), [1.0, np.inf, 1.0], [1, 1, 1], "q_inf"),
    ("planar", np.ones((3, 11)), np.ones(3), None, "parity"),
    ("planar", np.ones((3, 11)), np.ones(3), [1, 0, 1], "parity"),
    ("planar", np.ones((3, 11)), np.ones(3), [1, -1], "parity"),
    ("planar", np.ones((3, 11)), np.ones(3), [1, np.nan, 1], "parity"),
    ("axisymmetric", np.ones((3, 11)), np.ones(3), [1, 1, 1], "parity"),
])
def test_bad_solve_input(geometry, q, q_inf, parity, name):
    solver = HelmholtzSolver(_X, geometry, 2, 3)
    with pytest.raises(ValueError, match=name):
        solver.solve(q, q_inf, parity=parity)


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
def test_rows_independent_of_N(geometry):
    """Harmonic n does not depend on N; N = 64 runs the plain sweep loop, N = 5 the chunked
    schedule, so this compares the two recursion schedules."""
    rng = np.random.default_rng(8)
    x = _random_nodes(rng, 120, 40.0)
    q, q_inf = _random_rhs(rng, 64, x.size)
    par = np.where(np.arange(64) % 2 == 0, -1, 1) if geometry == "planar" else None
    u_big = HelmholtzSolver(x, geometry, 2, 64).solve(q, q_inf, parity=par)
    u_small = HelmholtzSolver(x, geometry, 2, 5).solve(
        q[:5], q_inf[:5], parity=None if par is None else par[:5])
    assert np.max(np.abs(u_big[:5] - u_small)) <= 64 * EPS * np.max(np.abs(u_small))
