"""Tests of the spectral time-periodic solver (tps_solver.solvers.tps)."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.tps.engine import newton
from tps_solver.solvers.tps.problems import ContinuumProblem

EPS = np.finfo(float).eps


def make_flat(M=2, e=0.45, Gamma=None):
    """Flat layers inside the stability window (Gamma = 2.5 for M = 2)."""
    if Gamma is None:
        lo, hi = tps.FlatLayer.stability_window(e, M)
        Gamma = 0.5 * (lo + hi)
    return tps.FlatLayer(Gamma, M, e=e)


def make_problem(geometry="axisymmetric", h=0.5, n=12, N=6, coupling=1.0, symmetry="kink"):
    return ContinuumProblem(geometry, h, n, make_flat(), N, coupling=coupling, symmetry=symmetry)


# ------------------------------------------------------------ flat layer ---
@pytest.mark.parametrize("M", [1, 2, 4])
@pytest.mark.parametrize("geometry", ["oscillon", "planar-even"])
def test_flat_layer_reproduced(M, geometry):
    fl = make_flat(M)
    N = 4 * M + 3
    kw = dict(Gamma=fl.Gamma, M=M, e=fl.e, t0=None, n_harmonics=N, n_nodes=15,
              tc_initial=lambda x: np.full(x.size, fl.t0), continuation=False)
    if geometry == "oscillon":
        sol = tps.solve_oscillon(r_max=6.0, **kw)
    else:
        sol = tps.solve_kink(length=6.0, symmetry="even", **kw)
    assert sol.converged, sol.message
    assert np.max(np.abs(sol.tc - fl.t0)) <= 1e-10
    ref = fl.harmonics(N)[:, None]
    assert np.max(np.abs(sol.w_hat - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert sol.checks.all_pass
    # with the closed-form jump tail the flat orbit is exact in time, for any N
    t = np.linspace(0.0, 2 * fl.period, 301)
    scale = np.max(np.abs(fl.height(t)))
    assert np.max(np.abs(sol.height(t) - fl.height(t)[:, None])) <= 200 * EPS * scale
    assert np.max(np.abs(sol.velocity(t) - fl.velocity(t)[:, None])) <= 200 * EPS * scale


def test_tail_correction_removes_order_one_over_n_error():
    """Without the tail the truncated velocity has an O(1) Gibbs error near the jump, with it none."""
    fl = make_flat(2)
    errors = {}
    for tail in (False, True):
        sol = tps.solve_oscillon(Gamma=fl.Gamma, M=2, e=fl.e, t0=None, n_harmonics=10, n_nodes=8,
                                 r_max=4.0, tc_initial=lambda x: np.full(x.size, fl.t0),
                                 continuation=False, tail_correction=tail)
        t = fl.t0 + np.linspace(0.01, 0.5, 50)
        errors[tail] = np.max(np.abs(sol.velocity(t)[:, 0] - fl.velocity(t)))
    assert errors[False] > 0.05          # Gibbs overshoot of the sawtooth near its jump
    assert errors[True] < 1e-12


# --------------------------------------------------------------- Newton ---
@pytest.mark.parametrize("geometry,symmetry", [("axisymmetric", "kink"), ("planar", "kink"),
                                               ("planar", "even")])
def test_jacobian_matches_finite_differences(geometry, symmetry):
    problem = make_problem(geometry, symmetry=symmetry)
    rng = np.random.default_rng(1)
    tc = problem.t0 + 0.3 * rng.standard_normal(problem.x.size)
    F, w, phase = problem.residual(tc)
    J, _ = problem.jacobian_operator(tc, w, phase)
    v = rng.standard_normal(tc.size)
    h = 1e-6
    fd = (problem.residual(tc + h * v)[0] - problem.residual(tc - h * v)[0]) / (2 * h)
    assert np.max(np.abs(J.matvec(v) - fd)) <= 1e-7 * np.max(np.abs(fd))


def test_newton_converges_quadratically_near_flat():
    problem = make_problem("axisymmetric", h=0.5, n=12, N=6)
    tc = problem.t0 + 0.2 * np.exp(-problem.x ** 2)
    tc_out, _, status, message, nit, history = newton(problem, tc, 1e-12, 20)
    assert status == 0, message
    assert np.max(np.abs(tc_out - problem.t0)) < 1e-10
    h = np.asarray(history)
    # quadratic: the last contraction factors shrink (e_{k+1} / e_k -> 0)
    ratios = h[1:] / h[:-1]
    assert ratios[-1] < 1e-2 and ratios[-1] < ratios[0]


@pytest.mark.parametrize("N", [4, 8])
def test_fixed_point_rate_matches_theory_and_schemes_agree(N):
    """Weakly coupled nodes (wide spacing): the plain fixed point (root selection each sweep)
    contracts linearly at rho = (2N/Gamma) / (2N/Gamma + sin t0) -- from linearising
    J saw_N(t - tc) - cos t = level -- i.e. 1 - O(1/N): more harmonics, slower iteration.
    Newton converges in a few steps; all schemes reach the same tc."""
    fl = make_flat(2)
    kw = dict(Gamma=fl.Gamma, M=2, e=fl.e, t0=None, n_harmonics=N, n_nodes=6, length=180.0,
              tol=1e-11, tc_initial=lambda x: np.full(x.size, fl.t0 + 0.05))
    newton = tps.solve_kink(scheme="newton", max_iter=30, continuation=False, **kw)
    picard = tps.solve_kink(scheme="picard", max_iter=1000, **kw)
    paper = tps.solve_kink(scheme="paper", max_iter=3000, **kw)
    for sol in (newton, picard, paper):
        assert sol.converged, (sol.scheme, sol.message)
    assert newton.nit <= 6
    h = picard.residual_history
    rate = (h[-1] / h[-21]) ** (1 / 20)
    rho = (2 * N / fl.Gamma) / (2 * N / fl.Gamma + math.sin(fl.t0))
    assert abs(rate - rho) < 0.02
    assert picard.nit > 10 * newton.nit
    for sol in (picard, paper):
        d = np.abs(np.mod(sol.tc - newton.tc + fl.period / 2, fl.period) - fl.period / 2)
        assert np.max(d) < 1e-8, sol.scheme


def test_kink_symmetry_to_round_off():
    fl = make_flat(2)
    sol = tps.solve_kink(Gamma=fl.Gamma, M=2, e=fl.e, t0=None, n_harmonics=8, n_nodes=8,
                         length=120.0, tol=1e-11)
    t = np.linspace(0.0, fl.period, 97)
    w = sol.velocity(t)
    w_shift = sol.velocity(t + fl.period / 2)
    scale = np.max(np.abs(w))
    assert np.max(np.abs(w_shift[:, ::-1] - w)) <= 1e3 * EPS * scale


def test_unconverged_run_reports_instead_of_raising():
    sol = tps.solve_kink(Gamma=2.5, M=2, t0=0.0, n_harmonics=8, n_nodes=20, length=5.0,
                         max_iter=2, continuation=False)
    assert not sol.converged and not sol.success
    assert sol.status in (1, 2)
    assert isinstance(sol.message, str) and sol.message
    assert sol.residual > sol.residual_history.min() * 0.999 and sol.residual > 1e-10


def test_save_load_round_trip(tmp_path):
    fl = make_flat(2)
    sol = tps.solve_oscillon(Gamma=fl.Gamma, M=2, e=fl.e, t0=None, n_harmonics=6, n_nodes=10,
                             r_max=4.0, tc_initial=lambda x: np.full(x.size, fl.t0),
                             continuation=False)
    path = tmp_path / "sol.npz"
    sol.save(path)
    again = tps.load(path)
    t = np.linspace(0, fl.period, 17)
    assert again.converged == sol.converged and again.geometry == sol.geometry
    np.testing.assert_array_equal(again.w_hat, sol.w_hat)
    np.testing.assert_array_equal(again.tc, sol.tc)
    np.testing.assert_allclose(again.height(t), sol.height(t), rtol=0, atol=1e-14)
    assert again.checks.all_pass == sol.checks.all_pass


# ------------------------------------------------------------ bad input ---
BAD = [
    (dict(n_harmonics=0), "n_harmonics"),
    (dict(n_harmonics=2.5), "n_harmonics"),
    (dict(Gamma=-1.0), "Gamma"),
    (dict(Gamma=float("nan")), "Gamma"),
    (dict(M=0), "M"),
    (dict(e=1.2, t0=None), "e"),
    (dict(e=0.3, t0=0.0), "inconsistent"),
    (dict(scheme="jacobi"), "scheme"),
    (dict(paper_sign=2), "paper_sign"),
    (dict(tol=0.0), "tol"),
    (dict(max_iter=-1), "max_iter"),
    (dict(n_nodes=2), "n_nodes"),
    (dict(tc_initial=np.zeros(3)), "tc_initial"),
    (dict(tc_initial=np.full(10, np.nan)), "tc_initial"),
    (dict(continuation="yes"), "continuation"),
]


@pytest.mark.parametrize("kwargs,match", BAD)
@pytest.mark.parametrize("solver", ["kink", "oscillon"])
def test_bad_input_names_parameter(solver, kwargs, match):
    base = dict(Gamma=2.5, M=2, t0=0.0, n_harmonics=4, n_nodes=10)
    if solver == "oscillon":
        base["r_core"] = 2.0
    base.update(kwargs)
    fn = tps.solve_kink if solver == "kink" else tps.solve_oscillon
    with pytest.raises(ValueError, match=match):
        fn(**base)


@pytest.mark.parametrize("kwargs,match", [
    (dict(length=0.0), "length"), (dict(length=-3.0), "length"), (dict(symmetry="odd"), "symmetry")])
def test_bad_kink_domain(kwargs, match):
    with pytest.raises(ValueError, match=match):
        tps.solve_kink(Gamma=2.5, M=2, t0=0.0, n_harmonics=4, n_nodes=10, **kwargs)


@pytest.mark.parametrize("kwargs,match", [
    (dict(r_max=0.0), "r_max"), (dict(r_core=200.0), "r_core"), (dict(r_core=-1.0), "r_core")])
def test_bad_oscillon_domain(kwargs, match):
    with pytest.raises(ValueError, match=match):
        tps.solve_oscillon(Gamma=2.5, M=2, t0=0.0, n_harmonics=4, n_nodes=10, **kwargs)


def test_oscillon_solution_regular_at_origin():
    """For a smooth radial right-hand side the solution has zero slope at r = 0: the one-sided
    slope (u(r1) - u(0))/r1 vanishes like O(h) (a leaked K0 term would give a log singularity)."""
    from tps_solver.operators.helmholtz import HelmholtzSolver

    N, M = 6, 2
    slopes = []
    hs = [0.1, 0.05, 0.025]
    for h in hs:
        r = np.arange(0.0, 12.0 + h / 2, h)
        solver = HelmholtzSolver(r, "axisymmetric", M, N)
        q = np.exp(-r ** 2)[None, :] * (1.0 + 1j * np.arange(1, N + 1))[:, None]
        u = solver.solve(q, np.zeros(N, dtype=complex))
        slopes.append(np.max(np.abs(u[:, 1] - u[:, 0]) / h))
    order = np.polyfit(np.log(hs), np.log(slopes), 1)[0]
    assert 0.8 < order < 1.2           # slope ~ u''(0) h, i.e. u'(0) = 0


@pytest.mark.parametrize("parity", [1, -1])
def test_planar_dual_cells_exact_for_a_step(parity):
    """interpolation='cells' is exact when q is constant on the dual cells: a step at a cell edge
    (midpoint between nodes) against the analytic solution of u'' - beta^2 u = q, q = 1 on [0, a)."""
    from tps_solver.operators.helmholtz import HelmholtzSolver

    M, N, a = 2, 6, 3.05
    x = np.arange(0.0, 20.0 + 1e-9, 0.1)
    q = np.where(x < a, 1.0, 0.0)[None, :] * np.ones((N, 1), dtype=complex)
    u = HelmholtzSolver(x, "planar", M, N, interpolation="cells").solve(q, np.zeros(N), np.full(N, parity))
    b = np.sqrt(1j * np.arange(1, N + 1) / M)[:, None]
    X = x[None, :]
    if parity == 1:      # u'(0) = 0
        ref = np.where(X < a, -1 / b**2 + np.exp(-b * a) * np.cosh(b * X) / b**2,
                       -np.sinh(b * a) * np.exp(-b * X) / b**2)
    else:                # u(0) = 0: inside -1/b^2 + cosh(bx)/b^2 + B sinh(bx), outside D e^{-bx}
        B = (np.exp(-b * a) - 1) / b**2
        inside = lambda y: -1 / b**2 + np.cosh(b * y) / b**2 + B * np.sinh(b * y)
        D = inside(a) * np.exp(b * a)
        ref = np.where(X < a, inside(X), D * np.exp(-b * X))
    assert np.max(np.abs(u - ref)) <= 1e-13


def test_interpolation_choice_is_validated():
    from tps_solver.operators.helmholtz import HelmholtzSolver

    with pytest.raises(ValueError, match="interpolation"):
        HelmholtzSolver(np.linspace(0, 1, 5), "axisymmetric", 2, 3, interpolation="linear")
    with pytest.raises(ValueError, match="interpolation"):
        HelmholtzSolver(np.linspace(0, 1, 5), "planar", 2, 3, interpolation="spline")
