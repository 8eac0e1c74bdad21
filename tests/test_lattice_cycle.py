"""Exact lattice cycles and the lattice TPS: TPS vs FDA on one discrete model."""
import math

import mpmath as mp
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.fda import simulate
from tps_solver.operators.modal import kernel as _H, kernel_integral as _H_int

EPS = np.finfo(float).eps


def make_lattice(kind, n=8, size=140.0):
    if kind == "planar":
        return tps.Lattice.planar(n_nodes=n, length=size, boundary="neumann")
    return tps.Lattice.axisymmetric(n_nodes=n, r_max=size, grid="uniform")


def make_cycle(kind, **kw):
    return tps.solve_lattice_cycle(make_lattice(kind), Gamma=2.5, M=2, e=0.45, t0=None, r_core=30.0, **kw)


def _mp_H(lam, tau, T):
    mp.mp.dps = 60
    l, t, TT = mp.mpf(lam), mp.mpf(tau), mp.mpf(T)
    if tau == 0:
        h = -(mp.e ** (l * TT) + 1) / (2 * (mp.e ** (l * TT) - 1)) + 1 / (l * TT)
    else:
        h = -mp.e ** (l * t) / (mp.e ** (l * TT) - 1) + 1 / (l * TT)
    hi = -mp.e ** (l * t) / (l * (mp.e ** (l * TT) - 1)) + t / (l * TT) + 1 / (l * l * TT) - 1 / (2 * l)
    return float(h), float(hi)


@pytest.mark.parametrize("lam", [-1e-9, -1e-5, -0.01, -0.0795, -0.0796, -0.7, -5.0, -60.0])
@pytest.mark.parametrize("tau", [0.0, 0.3, 6.0, 12.5])
def test_periodic_response_against_mpmath(lam, tau):
    """H and its antiderivative, including the cancellation-prone small |lambda T|."""
    T = 4 * math.pi
    h, hi = _mp_H(lam, tau, T)
    assert abs(float(_H(lam, tau, T)) - h) <= 8 * EPS * max(1.0, abs(h))
    assert abs(float(_H_int(lam, tau, T)) - hi) <= 64 * EPS * max(T, abs(hi))


def test_zero_mode_limit_is_the_sawtooth():
    T = 4 * math.pi
    tau = np.linspace(0.1, T - 0.1, 7)
    np.testing.assert_allclose(_H(0.0, tau, T), 0.5 - tau / T, atol=1e-15)
    assert float(_H(0.0, 0.0, T)) == 0.0


@pytest.mark.parametrize("kind", ["planar", "axisymmetric"])
def test_flat_layer_is_exact(kind):
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    lat = make_lattice(kind, n=6, size=10.0)
    cyc = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=0.45, t0=None,
                                  tc_initial=np.full(6, fl.t0), continuation=False)
    assert cyc.converged
    t = np.linspace(0.0, 2 * fl.period, 211)
    scale = fl.peak_height
    assert np.max(np.abs(cyc.velocity(t) - fl.velocity(t)[:, None])) <= 100 * EPS * scale
    assert np.max(np.abs(cyc.height(t) - fl.height(t)[:, None])) <= 100 * EPS * scale


@pytest.mark.parametrize("kind", ["planar", "axisymmetric"])
def test_fda_integrates_the_exact_cycle_to_round_off(kind):
    """The decisive cross-method check: the FDA's exact integrator, started on the TPS
    (N -> infinity) orbit of the same lattice, returns to it after one period."""
    cyc = make_cycle(kind)
    assert cyc.converged, cyc.message
    assert np.any(np.abs(np.mod(cyc.tc - cyc.t0 + 1, cyc.period) - 1) > 1.0)  # genuinely non-flat
    lat = cyc.lattice
    ts = cyc.t0 + 0.5 * cyc.period + 0.1
    w0, z0 = cyc.velocity([ts])[0], cyc.height([ts])[0]
    run = simulate(lat, 2.5, 0.45, w0, z0, t_start=ts, t_end=ts + cyc.period, method="exact")
    scale = max(np.max(np.abs(z0)), 1.0)
    assert np.max(np.abs(run.zeta - z0)) <= 1e-11 * scale
    assert np.max(np.abs(run.w - w0)) <= 1e-11 * scale
    impacts = run.events[run.events.kind == "impact"]
    assert impacts.size == lat.n_nodes                       # one contact per node and period
    d = np.abs(np.mod(impacts.t - cyc.tc[impacts.node] + cyc.period / 2, cyc.period) - cyc.period / 2)
    assert np.max(d) <= 1e-11


@pytest.mark.parametrize("kind", ["planar", "axisymmetric"])
def test_lattice_tps_converges_to_exact_cycle_at_first_order(kind):
    """Neighbours' impacts put kinks into w_j (coefficients ~ 1/n^2), so the truncated
    contact condition carries an O(1/N) tail: fitted slope of |tc_N - tc| about -1."""
    cyc = make_cycle(kind)
    Ns = np.array([16, 32, 64, 128])
    err = []
    for N in Ns:
        sol = tps.solve_lattice(cyc.lattice, Gamma=2.5, M=2, e=0.45, t0=None, n_harmonics=int(N),
                                tol=1e-12, r_core=30.0)
        assert sol.converged
        err.append(np.max(np.abs(np.mod(sol.tc - cyc.tc + cyc.period / 2, cyc.period) - cyc.period / 2)))
    slope = np.polyfit(np.log(Ns), np.log(err), 1)[0]
    assert -1.5 < slope < -0.6
    assert err[-1] < 2e-3


def test_branch_ends_on_the_papers_lattice():
    """The paper's kink lattice (41 nodes, L = 8, dx = 0.2): the single-contact branch from the
    decoupled limit ends at an effective spacing ~13.6 viscous lengths, far above dx."""
    lat = tps.Lattice.planar(n_nodes=41, length=8.0)
    cyc = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=0.45, t0=None)
    assert not cyc.converged and cyc.status == 4
    eff = lat.spacing / math.sqrt(cyc.coupling)
    assert 12.0 < eff < 15.5


def test_paper_preset_cannot_start_at_the_fold():
    lat = tps.Lattice.planar(n_nodes=12, length=8.0)
    cyc = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, t0=0.0)
    assert not cyc.converged and cyc.status == 2


@pytest.mark.parametrize("kwargs,match", [
    (dict(lattice="grid"), "lattice"),
    (dict(lattice=tps.Lattice.planar(n_nodes=5, length=4.0, boundary="pinned")), "boundary"),
    (dict(tc_initial=np.zeros(3)), "tc_initial"),
    (dict(tol=-1.0), "tol"),
    (dict(M=3, t0=None, e=0.45, Gamma=6.0), "odd M"),
])
def test_bad_input(kwargs, match):
    base = dict(lattice=tps.Lattice.planar(n_nodes=5, length=4.0), Gamma=2.5, M=2, t0=0.0)
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        tps.solve_lattice_cycle(**base)
