"""Tests of the point-impact integrator with carried modal amplitudes (tps_solver.solvers.fda.point).

Until the driver's method registry constructs :class:`PointIntegrator`, the runs use
``_run`` below: a copy of the loop body of ``tps_solver.solvers.fda.driver.simulate`` (advance,
then the shared event layer: contacts, pull-off, lift-off).
"""
import math

import mpmath
import numpy as np
import pytest
from scipy.optimize import brentq

import tps_solver as tps
from tps_solver.solvers.fda import flat_state, kink_state
from tps_solver.solvers.fda.events import EventLog, apply_contacts, apply_liftoff, make_impact_rule, pulled_off
from tps_solver.solvers.fda.point import PointIntegrator

GAMMA, E, M = 2.5, 0.45, 2


def _run(lattice, Gamma, e, w0, zeta0, t_start, t_end, stuck0=None, time_tol=1e-12,
         stick_velocity=1e-6, integrator=None):
    """The driver loop of ``simulate`` around a :class:`PointIntegrator`; returns (events, w, zeta, stuck, prop)."""
    n = lattice.n_nodes
    w, zeta = np.array(w0, dtype=float), np.array(zeta0, dtype=float)
    stuck = np.zeros(n, dtype=bool) if stuck0 is None else np.array(stuck0, dtype=bool)
    rule, _ = make_impact_rule("point")
    log = EventLog(t_start, 100 * n)
    prop = integrator or PointIntegrator(lattice, Gamma, e, time_tol=time_tol)
    t = t_start
    while t < t_end:
        step = prop.advance(t, w, zeta, stuck, t_end)
        t, w, zeta, contact, liftoff = step.t, step.w, step.zeta, step.contact, step.liftoff
        if contact.size:
            apply_contacts(t, w, zeta, stuck, contact, lattice, Gamma, e, rule, stick_velocity, log)
            liftoff = np.union1d(liftoff, pulled_off(t, w, stuck, lattice, Gamma))
        if liftoff.size:
            liftoff = liftoff[stuck[liftoff]]
            apply_liftoff(t, w, zeta, stuck, liftoff, log)
        assert not log.exceeded
    return log.to_array(), w, zeta, stuck, prop


def _flat():
    return tps.FlatLayer(Gamma=GAMMA, M=M, e=E)


# ------------------------------------------------------------- flat orbit
@pytest.mark.parametrize("n_nodes", [21, 101])
def test_flat_orbit_contact_times_do_not_drift(n_nodes):
    # started on the flat orbit the layer stays flat: the exact contacts are t0 + kT
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=10.0)
    t0 = fl.t0 + 1e-6
    w, z = flat_state(lat, fl, t0)
    periods = 10
    ev, w_end, z_end, stuck, prop = _run(lat, GAMMA, E, w, z, t0, t0 + periods * fl.period + 0.5)
    times = np.unique(ev.t)
    assert times.size == periods and ev.size == periods * n_nodes      # one set (54) per period
    assert set(ev.kind) == {"impact"}
    np.testing.assert_allclose(times, fl.t0 + fl.period * np.arange(1, periods + 1), rtol=0, atol=1e-13)
    np.testing.assert_allclose(ev.w_before, fl.impact_velocity, rtol=0, atol=1e-12)
    # no modal round trip: only the first segment projects; every impact is a rank-k update
    assert prop.n_projections == 1 and prop.n_decompositions == 1
    t_end = t0 + periods * fl.period + 0.5
    assert np.max(np.abs(z_end - fl.height(t_end))) <= 1e-12
    assert np.max(np.abs(w_end - fl.velocity(t_end))) <= 1e-12
    assert np.ptp(z_end) <= 1e-13                     # still flat (to the round-off of V @ c)


@pytest.mark.parametrize("make", [
    lambda: tps.Lattice.planar(n_nodes=11, length=8.0, boundary="pinned"),
    lambda: tps.Lattice.axisymmetric(n_nodes=30, r_max=20.0, grid="quasilog"),
], ids=["planar-pinned", "radial-quasilog"])
def test_flat_orbit_on_other_lattices(make):
    fl = _flat()
    lat = make()
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    ev, *_ = _run(lat, GAMMA, E, w, z, t0, t0 + 20 * fl.period)
    np.testing.assert_allclose(np.unique(ev.t), fl.t0 + fl.period * np.arange(1, 21), rtol=0, atol=1e-12)
    assert ev.size == 20 * lat.n_nodes


# --------------------------------------------------- certified contact search
def _flat_flight(t0, z0, w0):
    """Exact flat flight: w' = g = sin t - 1/Gamma from (z0, w0) at t0."""
    def height(t):
        d = t - t0
        return z0 + (w0 + math.cos(t0)) * d - (math.sin(t) - math.sin(t0)) - d * d / (2 * GAMMA)
    return height


@pytest.mark.parametrize("dip", [1e-10, -1e-10])
def test_shallow_double_crossing_is_found_and_near_miss_is_not(dip):
    # while g > 0 a slowly descending layer turns round just above (near miss) or just below
    # (two crossings ~1e-5 apart) the plate: the search must neither invent nor step over them
    t0, v = math.pi / 2, 1e-3
    # z0 such that the analytic minimum height is -dip (dip > 0: two crossings ~4e-5 apart)
    height = _flat_flight(t0, 0.0, -v)
    t_min = brentq(lambda t: -v + math.cos(t0) - math.cos(t) - (t - t0) / GAMMA, t0, t0 + 1.0, xtol=1e-16)
    z0 = -height(t_min) - dip
    height = _flat_flight(t0, z0, -v)
    assert abs(height(t_min) + dip) < 1e-15
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    prop = PointIntegrator(lat, GAMMA, E)
    step = prop.advance(t0, np.full(5, -v), np.full(5, z0), np.zeros(5, dtype=bool), t0 + 0.5)
    if dip > 0:
        t_hit = brentq(height, t0, t_min, xtol=1e-16)
        np.testing.assert_array_equal(step.contact, np.arange(5))
        assert abs(step.t - t_hit) <= 1e-11
    else:
        assert step.contact.size == 0 and step.t == t0 + 0.5
        np.testing.assert_allclose(step.zeta, height(t0 + 0.5), rtol=0, atol=1e-13)


# ------------------------------------------------------ sticking, lift-off
def _inelastic_cycle(Gamma):
    """Bouncing-ball analytics for e = 0: lift-off where sin t = 1/Gamma, flight, landing."""
    t_l = math.asin(1.0 / Gamma)
    height = _flat_flight(t_l, 0.0, 0.0)
    ts = t_l + np.linspace(1e-3, 4 * math.pi, 4001)
    k = int(np.flatnonzero(np.array([height(t) for t in ts]) < 0)[0])
    t_land = brentq(height, ts[k - 1], ts[k], xtol=1e-15, rtol=1e-15)
    v_land = math.cos(t_l) - math.cos(t_land) - (t_land - t_l) / Gamma
    return t_l, t_land, v_land


def test_inelastic_layer_lifts_off_lands_and_sticks():
    t_l, t_land, v_land = _inelastic_cycle(GAMMA)
    lat = tps.Lattice.planar(n_nodes=7, length=6.0)
    cycles = 3
    ev, w, z, stuck, _ = _run(lat, GAMMA, 0.0, np.zeros(7), np.zeros(7), 0.0, 2 * math.pi * cycles,
                              stuck0=np.ones(7, dtype=bool))
    assert ev.size == 2 * 7 * cycles and np.all(stuck)
    for k in range(cycles):
        lift = ev[(ev.kind == "liftoff") & (np.abs(ev.t - (t_l + 2 * math.pi * k)) <= 1e-12)]
        land = ev[(ev.kind == "stick") & (np.abs(ev.t - (t_land + 2 * math.pi * k)) <= 1e-12)]
        assert lift.size == 7 and land.size == 7
        np.testing.assert_allclose(land.w_before, v_land, rtol=0, atol=1e-10)


# ---------------------------------------------------- against method="exact"
def _kink_events(n_nodes, periods):
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_end = t0 + periods * fl.period
    ref = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t_end, method="exact")
    ev, w_end, z_end, stuck, prop = _run(lat, GAMMA, E, w, z, t0, t_end)
    return ref, ev, w_end, z_end, stuck, prop


def _assert_same_events(ref, ev, w_end, z_end, stuck):
    assert ref.success and ref.n_events == ev.size
    np.testing.assert_array_equal(ref.events.node, ev.node)
    np.testing.assert_array_equal(ref.events.kind, ev.kind)
    np.testing.assert_allclose(ev.t, ref.events.t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ev.w_before, ref.events.w_before, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(stuck, ref.stuck)
    np.testing.assert_allclose(z_end, ref.zeta, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w_end, ref.w, rtol=0, atol=1e-8)


def test_kink_events_match_exact_short():
    ref, ev, w_end, z_end, stuck, prop = _kink_events(21, 1)
    assert {"impact", "stick", "liftoff"} <= set(ev.kind)
    _assert_same_events(ref, ev, w_end, z_end, stuck)
    # most segments start from a rank-k update, not a projection
    assert prop.n_projections < ev.size / 2


@pytest.mark.slow
def test_kink_events_match_exact_41_nodes_2_periods():
    _assert_same_events(*_kink_events(41, 2)[:5])


def test_rank_k_update_equals_fresh_projection():
    # the same run with the carried amplitudes and with a projection at every segment
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=15, length=10.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_end = t0 + 0.5 * fl.period

    class Fresh(PointIntegrator):
        def advance(self, *args, **kw):
            self._carry = None
            return super().advance(*args, **kw)

    a = _run(lat, GAMMA, E, w, z, t0, t_end)
    b = _run(lat, GAMMA, E, w, z, t0, t_end, integrator=Fresh(lat, GAMMA, E))
    assert a[4].n_projections < b[4].n_projections
    np.testing.assert_array_equal(a[0].node, b[0].node)
    np.testing.assert_allclose(a[0].t, b[0].t, rtol=0, atol=1e-11)
    np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-11)
    np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-10)


# ------------------------------------------------------------ interface
def test_step_and_samples():
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    t_eval = np.array([t0 + 0.5, t0 + 2.0, t0 + 30.0])
    prop = PointIntegrator(lat, GAMMA, E)
    assert prop.impulsive and prop.name == "point"
    step = prop.advance(t0, w, z, np.zeros(5, dtype=bool), t0 + 40.0, t_eval)
    assert abs(step.t - (fl.t0 + fl.period)) <= 1e-13
    assert [s[0] for s in step.samples] == [t0 + 0.5, t0 + 2.0]
    for ts, ws, zs in step.samples:
        np.testing.assert_allclose(zs, fl.height(ts), rtol=0, atol=1e-13)
        np.testing.assert_allclose(ws, fl.velocity(ts), rtol=0, atol=1e-13)


def test_bad_options():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    with pytest.raises(ValueError, match="rtol"):
        PointIntegrator(lat, GAMMA, E, rtol=1e-9)
    with pytest.raises(ValueError, match="time_tol"):
        PointIntegrator(lat, GAMMA, E, time_tol=0.0)
    with pytest.raises(ValueError, match="max_steps"):
        PointIntegrator(lat, GAMMA, E, max_steps=0)


def test_search_bound_raises():
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    prop = PointIntegrator(lat, GAMMA, E, max_steps=2)
    with pytest.raises(RuntimeError, match="2 steps"):
        prop.advance(t0, w, z, np.zeros(5, dtype=bool), t0 + 40.0)


def test_phi2_against_mpmath():
    from tps_solver.model.flight import phi2_expm1 as _phi2

    z = np.concatenate((-np.logspace(-20, 1.5, 200), [0.0], np.logspace(-12, -1.01, 30),
                        -np.linspace(0.09, 0.11, 21)))
    with mpmath.workdps(40):
        ref = np.array([float((mpmath.expm1(mpmath.mpf(x)) - mpmath.mpf(x)) / mpmath.mpf(x) ** 2) if x
                        else 0.5 for x in z])
    np.testing.assert_allclose(_phi2(z, np.expm1(z)), ref, rtol=2e-15, atol=0)


@pytest.mark.parametrize("stuck_nodes", [[], [3, 4, 9]])
def test_closed_form_flight_matches_exact_segment(stuck_nodes):
    # the rewritten forced response against method="exact"'s Segment (forced_response)
    from tps_solver.solvers.fda.exact import Segment
    from tps_solver.solvers.fda.point import _FreeSet, _Segment

    lat = tps.Lattice.planar(n_nodes=13, length=6.0, boundary="pinned")
    free = np.ones(13, dtype=bool)
    free[stuck_nodes] = False
    rng = np.random.default_rng(1)
    fs = _FreeSet(lat, free, GAMMA)
    w0, z0 = rng.normal(size=fs.nf), rng.uniform(0.5, 1.5, size=fs.nf)
    t_c = 0.7
    ref = Segment(fs.modes, t_c, w0, z0, GAMMA)
    seg = _Segment(fs, fs.Vinv @ w0, z0, t_c, GAMMA)
    assert fs.zero_only == (not stuck_nodes)
    for tau in (0.0, 1e-7, 0.03, 0.9, 4.0):
        w_ref, z_ref = ref.state(tau)
        w, z, _ = seg.state(tau)
        np.testing.assert_allclose(w, w_ref, rtol=0, atol=1e-13)
        np.testing.assert_allclose(z, z_ref, rtol=0, atol=1e-13)
        np.testing.assert_allclose(fs.V @ seg.velocity_amplitudes(tau), w, rtol=0, atol=1e-13)


@pytest.mark.parametrize("stuck_nodes", [[], [3, 4, 9]])
def test_derivative_bounds_hold_for_all_later_times(stuck_nodes):
    # the certificate of the search: D_1 >= |w'|, D_2 >= |w''| from tau_1 on (zero modes: G, 1)
    from tps_solver.solvers.fda.point import _FreeSet, _Segment

    lat = tps.Lattice.planar(n_nodes=13, length=6.0, boundary="neumann")
    free = np.ones(13, dtype=bool)
    free[stuck_nodes] = False
    fs = _FreeSet(lat, free, GAMMA)
    rng = np.random.default_rng(2)
    a = fs.Vinv @ rng.normal(size=fs.nf)
    seg = _Segment(fs, a, np.ones(fs.nf), 0.3, GAMMA)
    worst = 0.0
    for tau1 in (0.0, 0.5, 2.0):
        decay = np.exp(fs.lam * tau1) * np.abs(a)
        D = (fs.absV_lam12 @ decay).reshape(2, fs.nf) + fs.forcing_T
        for tau in tau1 + np.linspace(0.0, 12.0, 401):
            t = 0.3 + tau
            g, dg = math.sin(t) - 1 / GAMMA, math.cos(t)
            cw = seg.velocity_amplitudes(tau)
            dcw = fs.lam * cw + g * fs.s
            d2cw = fs.lam * dcw + dg * fs.s
            ratio = np.abs(np.vstack((fs.V @ dcw, fs.V @ d2cw))) / D
            worst = max(worst, float(ratio.max()))
    assert worst <= 1.0 and worst > 0.3          # valid, and not vacuous


def test_proposed_search_points_on_a_periodic_orbit_give_the_same_events():
    # on the flat orbit each segment repeats the last one: from the third period the search
    # points proposed by the previous segment are evaluated in one product; the events and the
    # final state agree with the purely sequential search
    fl = _flat()
    lat = tps.Lattice.planar(n_nodes=21, length=10.0)
    t0 = fl.t0 + 1e-6
    w, z = flat_state(lat, fl, t0)
    t_end = t0 + 6 * fl.period + 0.5

    class Sequential(PointIntegrator):
        def _free_set(self, stuck):
            key, fs = super()._free_set(stuck)
            fs.confirmed = False
            return key, fs

    # the batched walk belongs to the numpy path (the compiled search steps one by one)
    a = _run(lat, GAMMA, E, w, z, t0, t_end, integrator=PointIntegrator(lat, GAMMA, E, compiled=False))
    b = _run(lat, GAMMA, E, w, z, t0, t_end, integrator=Sequential(lat, GAMMA, E, compiled=False))
    fs = next(iter(a[4]._cache.values()))
    assert fs.confirmed and len(fs.proposal) == 4          # proposals in use (4 points after 0)
    assert a[4].n_steps == b[4].n_steps                      # the same number of search points
    np.testing.assert_array_equal(a[0].node, b[0].node)
    np.testing.assert_allclose(a[0].t, b[0].t, rtol=0, atol=1e-14)
    np.testing.assert_allclose(a[0].t[::21], fl.t0 + fl.period * np.arange(1, 7), rtol=0, atol=1e-13)
    np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-14)
