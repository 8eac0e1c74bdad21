"""The long-wave thickness model (docs/thickness.md) against the varicose roots of (35)."""
import numpy as np
import pytest
from scipy.special import jn_zeros

import tps_solver as tps
from tps_solver.model.thickness import long_wave_rates
from tps_solver.solvers.thickness import ThicknessLattice, simulate_thickness


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


# ----------------------------------------------------------------------------- the integrator


def _start(G, e, lat, amp=0.05):
    fl = tps.FlatLayer(G, 2, e=e)
    t0 = fl.t0 + 1.0
    x = lat.nodes - lat.nodes[0]
    w0 = np.full(lat.n_nodes, fl.velocity(t0)) + amp * np.cos(np.pi * x / x[-1])
    return fl, t0, w0, np.full(lat.n_nodes, fl.height(t0))


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
@pytest.mark.parametrize("G, e", [(2.5, 0.45), (4.1, 0.0)])
def test_uniform_thickness_without_push_is_todays_fda(geometry, G, e):
    # chi = 0, h uniform: u stays 0, h stays uniform, and the run is the exact FDA's (events,
    # sticks and triggered lift-offs included) to the ODE tolerance
    lat = (tps.Lattice.planar(n_nodes=11, length=10.0) if geometry == "planar"
           else tps.Lattice.axisymmetric(n_nodes=11, r_max=10.0, grid="uniform"))
    fl, t0, w0, z0 = _start(G, e, lat)
    a = tps.simulate(lat, G, e, w0, z0, t_start=t0, t_end=t0 + 2 * fl.period, method="exact")
    b = simulate_thickness(lat, G, e, w0, z0, np.ones(11), chi=0.0, t_start=t0, t_end=t0 + 2 * fl.period)
    assert b.success and np.all(b.u == 0.0) and np.all(b.h == 1.0)
    ea = sorted((int(r.node), str(r.kind), float(r.t)) for r in a.events)
    eb = sorted((n, k, t) for t, n, k in b.events)
    assert [x[:2] for x in ea] == [x[:2] for x in eb]
    assert max(abs(x[2] - y[2]) for x, y in zip(ea, eb)) < 5e-9
    assert np.max(np.abs(a.w - b.w)) < 1e-9 and np.max(np.abs(a.zeta - b.zeta)) < 1e-9


def test_antiplane_operator_is_the_lattice_laplacian_for_uniform_thickness():
    for lat in (tps.Lattice.planar(n_nodes=9, length=8.0), tps.Lattice.axisymmetric(n_nodes=9, r_max=8.0)):
        op = ThicknessLattice(lat)
        w = np.sin(0.7 * lat.nodes) + 0.1 * lat.nodes
        ref = lat.operator @ w
        assert np.max(np.abs(op.antiplane(w, np.full(9, 2.5)) - ref)) < 64 * np.finfo(float).eps * np.max(np.abs(ref))


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
def test_mass_is_conserved_with_push_and_varying_thickness(geometry):
    lat = (tps.Lattice.planar(n_nodes=13, length=10.0) if geometry == "planar"
           else tps.Lattice.axisymmetric(n_nodes=13, r_max=10.0, grid="quasilog"))
    fl, t0, w0, z0 = _start(4.1, 0.0, lat, amp=0.2)
    x = lat.nodes - lat.nodes[0]
    h0 = 1.0 + 0.3 * np.cos(np.pi * x / x[-1])
    r = simulate_thickness(lat, 4.1, 0.0, w0, z0, h0, chi=1.0, t_start=t0, t_end=t0 + fl.period)
    assert r.success and r.n_events > 20
    assert np.ptp(r.mass) / r.mass[0] < 1e-14                  # to rounding
    assert np.max(np.abs(r.u)) > 1e-3 and np.max(np.abs(r.h - h0)) > 1e-3   # the push moved mass


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
def test_stretching_rates_converge_to_the_long_wave_rates(geometry):
    # the lattice's stretching operator (uniform h): its slowest rates against -4 k^2 (planar
    # k = m pi / L; axisymmetric k = j_{1,m} / R), second order in dx
    errs = []
    for n in (21, 41, 81):
        lat = (tps.Lattice.planar(n_nodes=n, length=10.0) if geometry == "planar"
               else tps.Lattice.axisymmetric(n_nodes=n, r_max=10.0, grid="uniform"))
        op = ThicknessLattice(lat)
        A = np.column_stack([op.stretching(np.eye(n - 1)[i], np.ones(n)) for i in range(n - 1)])
        rates = np.sort(np.linalg.eigvals(A).real)[::-1][:3]
        k = np.arange(1, 4) * np.pi / 10.0 if geometry == "planar" else jn_zeros(1, 3) / 10.0
        errs.append(np.max(np.abs(rates / long_wave_rates(k)["stretching"] - 1.0)))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.05) and errs[-1] < 2e-3


def test_bad_input():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    with pytest.raises(ValueError, match="h0 must be > 0"):
        simulate_thickness(lat, 2.5, 0.45, np.zeros(5), np.ones(5), np.zeros(5), t_end=1.0)
    with pytest.raises(ValueError, match="chi must be"):
        simulate_thickness(lat, 2.5, 0.45, np.zeros(5), np.ones(5), np.ones(5), chi=-1.0, t_end=1.0)


@pytest.mark.slow
def test_e0_core_collapses_with_and_without_the_push():
    # validation/thickness_oscillons.py: the e = 0, Gamma = 4.1 core of radius 10 collapses within
    # 12 periods with the push off (the antiplane model) and on (chi = 1); mass kept to rounding
    from validation.thickness_oscillons import core_run
    for chi in (0.0, 1.0):
        r = core_run(4.1, 0.0, chi, periods=12)
        assert r["fate"] == "collapses" and r["R_dR"] < 0 and r["mass_drift"] < 1e-13


def test_thickness_restitution():
    # e(v, h) = e_v(v) min(1, 2 / (1 + (h/h_e)^2)): at h <= h_e the speed law itself (the same run
    # event for event), and a deep node rebounds less
    from tps_solver.model.restitution import ThicknessRestitution
    law = ThicknessRestitution(0.45, h_e=1.0)
    assert law(2.0, 3.0) == pytest.approx(0.45 * 2.0 / 10.0, rel=1e-15) and law(2.0, 0.5) == 0.45
    lat = tps.Lattice.planar(n_nodes=7, length=6.0)
    fl, t0, w0, z0 = _start(2.5, 0.45, lat)
    a = simulate_thickness(lat, 2.5, 0.45, w0, z0, np.ones(7), chi=0.0, t_start=t0, t_end=t0 + fl.period)
    b = simulate_thickness(lat, 2.5, law, w0, z0, np.ones(7), chi=0.0, t_start=t0, t_end=t0 + fl.period)
    assert a.events == b.events and np.array_equal(a.w, b.w)
    deep = simulate_thickness(lat, 2.5, law, w0, z0, np.full(7, 3.0), chi=0.0, t_start=t0, t_end=t0 + fl.period)
    t_imp, j, _ = next(ev for ev in a.events if ev[2] == "impact")
    # right after the first impact the deep node rises at e(v, 3) = 0.09 of its landing speed
    rd = simulate_thickness(lat, 2.5, law, w0, z0, np.full(7, 3.0), chi=0.0, t_start=t0, t_end=t_imp + 1e-9)
    ra = simulate_thickness(lat, 2.5, 0.45, w0, z0, np.full(7, 3.0), chi=0.0, t_start=t0, t_end=t_imp + 1e-9)
    assert rd.w[j] == pytest.approx(ra.w[j] * 0.09 / 0.45, rel=1e-6)
    assert deep.success
