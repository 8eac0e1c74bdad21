"""Tests of the impact-and-stick TPS (tps_solver.solvers.tps.stick)."""
import math

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss

import tps_solver as tps
from tps_solver.solvers.tps import stick as ts
from tps_solver.solvers.tps import stick_pattern as tsp
from tps_solver.solvers.tps import stick_problem as sp
from tps_solver.operators.modal import ModalBasis, kernel, kernel_integral
from tps_solver.operators.helmholtz import LatticeHelmholtz

GAMMAS = (3.9, 4.1, 4.4)


def _flights(orb):
    """Flight intervals [a, b) of the closed-form e = 0 orbit, each from rest at a."""
    out, start = [], orb.t_liftoff
    for k in range(orb.t.size):
        out.append((start, orb.t[k]))
        start = orb.t[k] if orb.kind[k] == "bounce" else orb.tau[k]
    return out


def _reference_w(orb, t):
    """Independent closed form (17) with W0 = 0: w = cos a - cos t - (t - a)/Gamma in flight, else 0."""
    T, G = orb.period, orb.Gamma
    ph = orb.t_liftoff + np.mod(np.asarray(t) - orb.t_liftoff, T)
    w = np.zeros_like(ph)
    for a, b in _flights(orb):
        m = (ph >= a) & (ph < b)
        w[m] = np.cos(a) - np.cos(ph[m]) - (ph[m] - a) / G
    return w


@pytest.mark.parametrize("Gamma", GAMMAS)
def test_flat_orbit_against_fda(Gamma):
    """Closed-form landings and lift-off against the event-driven FDA (second method)."""
    orb = ts.flat_stick_orbit(Gamma, 2)
    assert abs(math.sin(orb.t_liftoff) - 1 / Gamma) < 1e-15 and math.cos(orb.t_liftoff) > 0
    assert list(orb.kind) == ["bounce", "stick"]
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    t0 = orb.t_liftoff + 0.3
    a = orb.t_liftoff
    z0 = math.cos(a) * 0.3 + math.sin(a) - math.sin(t0) - 0.09 / (2 * Gamma)
    run = tps.simulate(lat, Gamma, 0.0, np.full(3, _reference_w(orb, np.array([t0]))[0]),
                       np.full(3, z0), t_start=t0, t_end=t0 + 2 * orb.period)
    ev = run.events[run.events.node == 1]
    impacts = np.sort(ev.t[ev.kind != "liftoff"])
    lifts = np.sort(ev.t[ev.kind == "liftoff"])
    want = np.sort(np.concatenate([orb.t, orb.t + orb.period]))
    assert impacts.size == want.size
    assert np.max(np.abs(impacts - want)) < 1e-9
    want_l = orb.tau[orb.kind == "stick"]
    assert np.min(np.abs(lifts - want_l[0])) < 1e-9


@pytest.mark.parametrize("Gamma", GAMMAS)
def test_flat_tps_reproduces_closed_form(Gamma):
    """Uniform perturbed start -> the flat e = 0 orbit, times to <= 1e-10, w and zeta exact."""
    orb = ts.flat_stick_orbit(Gamma, 2)
    sol = ts.solve_stick_flat(Gamma, 2, perturbation=1e-2)
    assert sol.converged and sol.status == 0 and sol.nit >= 2
    assert np.max(np.abs(sol.contact_times[0] - orb.t)) <= 1e-10
    assert np.nanmax(np.abs(sol.liftoff_times[0] - orb.tau)) <= 1e-10
    assert list(sol.contact_kinds[0]) == ["bounce", "stick"]
    t = np.linspace(0.0, 4 * np.pi, 301)
    assert np.max(np.abs(sol.velocity(t)[:, 0] - _reference_w(orb, t))) < 1e-12
    assert sol.checks.all_pass
    # impulses: J = -w(t^-) of the closed-form flight
    assert np.max(np.abs(sol.impulses[0] + orb.w_minus)) < 1e-12


def test_flat_tps_on_coupled_lattice():
    """On a 4-node Neumann lattice the uniform orbit is a solution; Newton returns to it."""
    orb = ts.flat_stick_orbit(4.1, 2)
    sol = ts.solve_stick_flat(4.1, 2, n_nodes=4, length=6.0, perturbation=1e-3)
    assert sol.converged
    assert np.max(np.abs(sol.contact_times - orb.t[None, :])) < 1e-10
    assert np.nanmax(np.abs(sol.liftoff_times - orb.tau[None, :])) < 1e-10


def test_flat_w_hat_against_quadrature():
    """w_hat (closed-form source, Helmholtz per harmonic) against Gauss quadrature of the flights."""
    orb = ts.flat_stick_orbit(4.1, 2)
    sol = ts.solve_stick_flat(4.1, 2, n_harmonics=12)
    T, G, N = orb.period, orb.Gamma, 12
    x, wq = leggauss(60)
    ref = np.zeros(2 * N + 1, dtype=complex)
    n = np.arange(-N, N + 1)
    for a, b in _flights(orb):
        s = a + (b - a) * (1 + x) / 2
        f = np.cos(a) - np.cos(s) - (s - a) / G
        ref += (np.exp(-1j * np.outer(n / 2, s)) @ (wq * f)) * (b - a) / 2 / T
    assert np.max(np.abs(sol.w_hat[:, 0] - ref)) < 1e-13


def test_kernel_is_the_fourier_series():
    """H(lambda, tau) has Fourier coefficients 1/(T (i n alpha - lambda)) (the all-orders sum)."""
    T = 4 * np.pi
    x, wq = leggauss(200)
    tau = T * (1 + x) / 2
    for lam in (0.0, -0.05, -3.0):
        H = kernel(np.array(lam), tau, T, at_jump="right")
        for n in (0, 1, 3, 7):
            c = np.sum(wq * H * np.exp(-1j * n * tau / 2)) / 2
            want = 0.0 if n == 0 else 1.0 / (T * (1j * n / 2 - lam))
            assert abs(c - want) < 1e-12
        Hi = kernel_integral(np.array(lam), tau, T)
        d = np.gradient(Hi, tau)
        assert np.max(np.abs(d[5:-5] - H[5:-5])) < 1e-3


def test_lattice_kernel_matches_lattice_helmholtz():
    """V diag(H) V^-1 on a lattice has the harmonics of the per-harmonic lattice Helmholtz solve."""
    lat = tps.Lattice.planar(n_nodes=6, length=5.0)
    T = 4 * np.pi
    md = ModalBasis(lat, period=T)
    x, wq = leggauss(200)
    tau = T * (1 + x) / 2
    H = kernel(md.lam[None, :], tau[:, None], T, at_jump="right")                  # (Q, P)
    R = np.einsum("jp,qp,pi->qji", md.V, H, md.Vinv)            # (Q, j, i)
    N = 4
    solver = LatticeHelmholtz(lat, M=2, N=N)
    q = np.zeros((N, 6), dtype=complex)
    q[:, 2] = 1.0 / T
    u = solver.solve(q)                                          # (L - i n alpha) u = q
    for n in range(1, N + 1):
        c = np.einsum("q,qj->j", wq * np.exp(-1j * n * tau / 2), R[:, :, 2]) / 2
        assert np.max(np.abs(c + u[n - 1])) < 1e-12


def test_bad_input():
    with pytest.raises(ValueError, match="e"):
        ts.solve_stick_flat(4.1, e=-0.1)
    with pytest.raises(ValueError, match="Gamma"):
        ts.flat_stick_orbit(0.9)
    with pytest.raises(ValueError, match="K >= 1"):
        tsp.make_pattern([0], ["stick"], [1.0], [1.0], [2.0], [-1], [0], 2, 4 * np.pi)
    with pytest.raises(ValueError, match="does not exist"):
        tsp.make_pattern([0, 0], ["stick", "bounce"], [1.0, 1.5], [1.0, 1.0], [2.0, np.nan],
                         [-1, -1], [0, 0], 1, 4 * np.pi)
    with pytest.raises(ValueError, match="kind"):
        tsp.make_pattern([0], ["slide"], [1.0], [1.0], [2.0], [-1], [0], 1, 4 * np.pi)
    with pytest.raises(ValueError, match="K >= 1"):
        tsp.make_pattern([], [], [], [], [], [], [], 1, 4 * np.pi)
    lat = tps.Lattice.planar(n_nodes=5, length=8.0, boundary="pinned")
    with pytest.raises(ValueError, match="neumann"):
        ts.solve_stick_lattice(lat, 4.1)
    with pytest.raises(ValueError, match="n_basis"):
        ts.solve_stick_flat(4.1, n_basis=0)
    with pytest.raises(ValueError, match="close"):
        ts.flat_stick_orbit(4.1, M=1)


def test_newton_failure_is_reported():
    sol = ts.solve_stick_flat(4.1, perturbation=1e-2, max_iter=1)
    assert not sol.converged and sol.status == 1
    assert "iteration limit" in sol.message and "last iterate" in sol.message
    assert sol.residual > 1e-10 and sol.residual_history.size == 2


@pytest.mark.slow
def test_lattice_kink_against_fda():
    """dx = 2, L = 40: the TPS kink integrated by the FDA keeps its contact and lift-off times."""
    lat = tps.Lattice.planar(n_nodes=21, length=40.0)
    sol = ts.solve_stick_lattice(lat, 4.1, periods=20, n_basis=6, tol=1e-10)
    assert sol.converged and sol.checks.all_pass
    assert sol.K == 2
    chk = ts.check_with_fda(sol, periods=2)
    assert np.all(chk.events_per_period == 2)
    assert chk.contact_error < 1e-8 and chk.liftoff_error < 1e-8


@pytest.mark.slow
def test_lattice_kink_gamma_4p4_against_fda():
    """Gamma = 4.4, dx = 2: pattern from a 160-period FDA run; the FDA keeps the TPS times."""
    lat = tps.Lattice.planar(n_nodes=21, length=40.0)
    sol = ts.solve_stick_lattice(lat, 4.4, periods=160, n_basis=6, tol=1e-10)
    assert sol.converged and sol.checks.all_pass
    chk = ts.check_with_fda(sol, periods=2)
    assert chk.contact_error < 1e-8 and chk.liftoff_error < 1e-8


def _small_orbit():
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    return lat, tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, multipliers=False)


def test_pattern_from_shooting_orbit_is_the_closed_form():
    """Pattern and TPS from a shooting orbit of the uniform lattice: the closed-form flat orbit."""
    lat, orb = _small_orbit()
    assert orb.converged
    flat = ts.flat_stick_orbit(4.1, 2)
    p = ts.pattern_from_orbit(orb, lat)
    for j in range(3):
        assert list(p.kind[p.node == j]) == ["bounce", "stick"]
        assert np.max(np.abs(p.t[p.node == j] - flat.t)) < 1e-9
    sol = ts.solve_stick_lattice(lat, 4.1, pattern=orb)
    assert sol.converged and sol.pattern_source.startswith("shooting orbit")
    assert np.max(np.abs(sol.contact_times - flat.t[None, :])) < 1e-12
    assert np.nanmax(np.abs(sol.liftoff_times - flat.tau[None, :])) < 1e-12


def test_shooting_orbit_input_is_validated():
    lat, orb = _small_orbit()
    other = tps.Lattice.planar(n_nodes=4, length=2.0)
    with pytest.raises(ValueError, match="pattern.*this lattice"):
        ts.solve_stick_lattice(other, 4.1, pattern=orb)
    with pytest.raises(ValueError, match="pattern.*Gamma = 4.2"):
        ts.solve_stick_lattice(lat, 4.2, pattern=orb)
    with pytest.raises(ValueError, match="lattice must be the orbit's lattice"):
        ts.pattern_from_orbit(orb, other)
    with pytest.raises(ValueError, match="orbit must be a ShootingOrbit"):
        ts.pattern_from_orbit(ts.flat_stick_orbit(4.1))
    with pytest.raises(ValueError, match="StickPattern or a ShootingOrbit"):
        ts.solve_stick_lattice(lat, 4.1, pattern=(orb.w0, orb.zeta0))


def test_evaluate_nodes_is_the_pairwise_evaluation():
    """The modal-first evaluation at all nodes equals the request-by-request one (a kink on 6
    nodes: impulses, stick segments and times inside them); the antiderivative's low modes
    cancel, so its agreement is a multiple of eps times ~1/(lambda_1^2 T)."""
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    sol = tps.solve_kink(4.1, e=0.0, lattice=lat)
    assert sol.converged
    pr, x = sol.problem, sol.unknowns
    p = sol.pattern
    inside = np.nan_to_num(0.5 * (p.t + p.tau), nan=1.0)       # mid-stick times (and others)
    times = np.concatenate([np.linspace(0.0, sol.period, 97, endpoint=False), p.t, p.t + 1e-9, inside])
    n = lat.n_nodes
    nodes, rep = np.tile(np.arange(n), times.size), np.repeat(times, n)
    eps = np.finfo(float).eps
    lam1 = float(np.max(pr.m.lam[pr.m.lam < -1e-12]))
    for W, bound in ((False, 64 * eps), (True, 64 * eps / (lam1 ** 2 * sol.period))):
        ref = pr.evaluate(x, nodes, rep, np.full(nodes.size, W)).reshape(times.size, n)
        got = pr.evaluate_nodes(x, times, W)
        assert got.shape == (times.size, n)
        assert np.max(np.abs(got - ref)) <= bound * max(1.0, float(np.max(np.abs(ref))))


def _e0_kink_orbit(Gamma, dx):
    from validation.shooting import e0_kink_guess

    lat = tps.Lattice.planar(n_nodes=int(round(40.0 / dx)) + 1, length=40.0)
    run = e0_kink_guess(lat, Gamma, 2, 10)
    orb = tps.find_periodic_orbit(lat, Gamma=Gamma, M=2, e=0.0, guess=run, max_iter=80, multipliers=False)
    assert orb.converged
    return lat, orb


@pytest.mark.slow
@pytest.mark.parametrize("Gamma, dx", [(3.9, 2.0), (4.1, 1.0), (4.1, 0.5)])
def test_lattice_kink_from_shooting_against_fda(Gamma, dx):
    """Pattern from the shooting orbit: the stick TPS converges (Gamma = 3.9 stalled with the FDA
    pattern, dx = 1 too; dx = 0.5 takes minutes) and the FDA started on it keeps its contact and
    lift-off times to 1e-8."""
    lat, orb = _e0_kink_orbit(Gamma, dx)
    sol = ts.solve_stick_lattice(lat, Gamma, pattern=orb, tol=1e-10)
    assert sol.converged and sol.checks.all_pass and sol.K == 2
    chk = ts.check_with_fda(sol, periods=2)
    assert np.all(chk.events_per_period == 2)
    assert chk.contact_error < 1e-8 and chk.liftoff_error < 1e-8
    # and the shooting orbit's own contacts (an independent Newton solve of the period map)
    T = sol.period
    for j in range(lat.n_nodes):
        d = np.mod(orb.contact_times[j][:, None] - sol.contact_times[j][None, :] + T / 2, T) - T / 2
        assert np.max(np.min(np.abs(d), axis=1)) < 1e-8


@pytest.mark.slow
def test_lattice_kink_newton_continuation_in_gamma():
    """The Gamma = 4.1 kink pattern as the start at Gamma = 4.11 (times move by ~0.02): Newton
    converges (the time columns of the Jacobian are right), and the FDA keeps the new orbit."""
    lat, orb = _e0_kink_orbit(4.1, 2.0)
    pattern = ts.pattern_from_orbit(orb)
    sol = ts.solve_stick_lattice(lat, 4.11, pattern=pattern, tol=1e-11, max_iter=30, refresh=0)
    assert sol.converged and sol.nit >= 3 and sol.checks.all_pass
    T = sol.period
    assert np.max(np.abs(np.mod(sol.pattern.t - pattern.t + T / 2, T) - T / 2)) > 1e-3
    chk = ts.check_with_fda(sol, periods=2)
    assert chk.contact_error < 1e-8 and chk.liftoff_error < 1e-8
