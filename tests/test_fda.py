"""Tests of the event-driven FDA (tps_solver.solvers.fda): lattices, both integrators, events."""
import math

import numpy as np
import pytest
import mpmath
from scipy.optimize import brentq
from scipy.special import j0, jn_zeros

import tps_solver as tps
from tps_solver.solvers.fda import flat_state, kink_state
from tps_solver.solvers.fda.events import EVENT_DTYPE, EventLog, apply_contacts, event_sets, point_impact
from tps_solver.solvers.fda.exact import Modes, Segment, forced_response

GAMMA, E, M = 2.5, 0.45, 2
EPS = np.finfo(float).eps


def stable_flat():
    return tps.FlatLayer(Gamma=GAMMA, M=M, e=E)


LATTICES = {
    "planar-neumann": lambda: tps.Lattice.planar(n_nodes=11, length=8.0),
    "planar-pinned": lambda: tps.Lattice.planar(n_nodes=11, length=8.0, boundary="pinned"),
    "radial-quasilog": lambda: tps.Lattice.axisymmetric(n_nodes=30, r_max=20.0, grid="quasilog"),
    "radial-uniform": lambda: tps.Lattice.axisymmetric(n_nodes=30, r_max=20.0, grid="uniform"),
}


# ----------------------------------------------------------------- lattices
def test_planar_interior_rows_are_eq63():
    lat = tps.Lattice.planar(n_nodes=9, length=4.0)
    dx = 0.5
    L = lat.operator
    for i in range(1, 8):
        row = np.zeros(9)
        row[[i - 1, i + 1]] = 1.0 / dx**2
        row[i] = -2.0 / dx**2
        np.testing.assert_array_equal(L[i], row)
    # Neumann ends by ghost reflection: (2u_1 - 2u_0)/dx^2
    np.testing.assert_array_equal(L[0, :2], [-2.0 / dx**2, 2.0 / dx**2])


@pytest.mark.parametrize("name", list(LATTICES))
def test_operator_is_symmetrisable_with_constant_null_vector(name):
    lat = LATTICES[name]()
    S = lat.volumes[:, None] * lat.operator
    interior = ~lat.autonomous
    Si = S[np.ix_(interior, interior)]
    np.testing.assert_allclose(Si, Si.T, rtol=0, atol=1e-12 * np.abs(Si).max())
    np.testing.assert_allclose(lat.operator @ np.ones(lat.n_nodes), 0.0, atol=1e-12 * np.abs(S).max())


def test_radial_operator_exact_on_r_squared():
    # conservative form on a uniform radial grid is exact for u = r^2 (Laplacian 4), axis included
    lat = tps.Lattice.axisymmetric(n_nodes=12, r_max=5.0, grid="uniform")
    Lu = lat.operator @ lat.nodes**2
    np.testing.assert_allclose(Lu[:-1], 4.0, rtol=1e-12)


def test_quasilog_grid_is_eq66():
    lat = tps.Lattice.axisymmetric(n_nodes=21, r_max=20.0, grid="quasilog")
    xi = np.log1p(lat.nodes)
    np.testing.assert_allclose(np.diff(xi), np.log(21.0) / 20, rtol=1e-12)


def test_pinned_modes_diagonalise_free_operator():
    lat = tps.Lattice.planar(n_nodes=9, length=4.0, boundary="pinned")
    free = np.ones(9, dtype=bool)
    free[[3, 4]] = False      # stuck nodes split the lattice
    md = Modes(lat, free)
    np.testing.assert_allclose(md.V @ md.Vinv, np.eye(7), atol=1e-13)
    np.testing.assert_allclose(md.L_FF @ md.V, md.V * md.lam, atol=1e-12)


@pytest.mark.parametrize("lam", [0.0, -0.3, -7.0])
@pytest.mark.parametrize("tau", [1e-3, 0.7, 5.0])
def test_forced_response_against_mpmath(lam, tau):
    # W = int_0^tau e^{lam(tau-u)} g(tc+u) du,  Z = int_0^tau g(tc+u) int_u^tau e^{lam(s-u)} ds du
    tc = 1.3
    with mpmath.workdps(30):
        lam_m, tau_m = mpmath.mpf(lam), mpmath.mpf(tau)

        def g(u):
            return mpmath.sin(tc + u) - 1 / mpmath.mpf(GAMMA)

        def kernel(d):
            return d if lam == 0 else mpmath.expm1(lam_m * d) / lam_m
        W = mpmath.quad(lambda u: mpmath.exp(lam_m * (tau_m - u)) * g(u), [0, tau_m])
        Z = mpmath.quad(lambda u: g(u) * kernel(tau_m - u), [0, tau_m])
    Wc, Zc = forced_response(np.array([lam]), tc, tau, GAMMA)
    assert abs(Wc[0] - float(W)) <= 8 * EPS * max(1.0, tau)
    assert abs(Zc[0] - float(Z)) <= 8 * EPS * max(1.0, tau) ** 2


def test_derivative_bounds_hold_along_a_segment():
    lat = tps.Lattice.planar(n_nodes=15, length=7.0, boundary="pinned")
    free = np.ones(15, dtype=bool)
    free[6] = False
    md = Modes(lat, free)
    rng = np.random.default_rng(1)
    seg = Segment(md, 0.4, rng.standard_normal(14), rng.random(14), GAMMA)
    t1 = 0.05
    A, B = seg.derivative_bound(t1, 1), seg.derivative_bound(t1, 2)
    h = 1e-4
    for tau in np.linspace(t1, 3.0, 40):
        wm, _ = seg.state(tau - h)
        w0, _ = seg.state(tau)
        wp, _ = seg.state(tau + h)
        assert np.all(np.abs((wp - wm) / (2 * h)) <= A * (1 + 1e-6))
        assert np.all(np.abs((wp - 2 * w0 + wm) / h**2) <= B * (1 + 1e-3) + 1e-4)


# ---------------------------------------------------------- flat layers
def _flat_run(lat, method, periods=50):
    """Run the stable flat layer from mid-flight; return it with its run, sampled once per period."""
    fl = stable_flat()
    T = fl.period
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    run = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + periods * T, method=method,
                       t_eval=t0 + T * np.arange(periods) + 0.5)
    assert run.success
    err = max(np.max(np.abs(run.zeta_eval - fl.height(run.t_eval)[:, None])),
              np.max(np.abs(run.w_eval - fl.velocity(run.t_eval)[:, None])))
    return fl, run, err


@pytest.mark.parametrize("name", list(LATTICES))
def test_exact_reproduces_flat_layer_50_periods(name):
    lat = LATTICES[name]()
    fl, run, err = _flat_run(lat, "exact")
    assert err <= 1e-10 * max(1.0, fl.peak_height)
    # one simultaneous set (54) per period: every node at the same instant, to <= 1e-12
    times = np.unique(run.events.t)
    assert times.size == 50 and run.n_events == 50 * lat.n_nodes
    np.testing.assert_allclose(times, fl.t0 + fl.period * np.arange(1, 51), rtol=0, atol=1e-12)
    assert set(run.events.kind) == {"impact"}
    np.testing.assert_allclose(run.events.w_before, fl.impact_velocity, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", ["planar-neumann", "planar-pinned", "radial-quasilog"])
def test_ode_reproduces_flat_layer_50_periods(name):
    lat = {"planar-neumann": lambda: tps.Lattice.planar(n_nodes=6, length=8.0),
           "planar-pinned": lambda: tps.Lattice.planar(n_nodes=6, length=8.0, boundary="pinned"),
           "radial-quasilog": lambda: tps.Lattice.axisymmetric(n_nodes=8, r_max=20.0)}[name]()
    fl, run, err = _flat_run(lat, "ode")
    assert err <= 1e-8
    np.testing.assert_allclose(np.unique(run.events.t), fl.t0 + fl.period * np.arange(1, 51), rtol=0, atol=1e-9)


def _inelastic_cycle(Gamma):
    """Bouncing-ball analytics for e = 0: lift-off where sin t = 1/Gamma (a rising), flight, landing."""
    t_l = math.asin(1.0 / Gamma)
    c = math.cos(t_l)

    def height(t):
        d = t - t_l
        return c * d - d * d / (2 * Gamma) + math.sin(t_l) - math.sin(t)
    # the flight height is positive until it returns; bracket the landing on a fine scan
    ts = t_l + np.linspace(1e-3, 4 * math.pi, 4001)
    hs = np.array([height(t) for t in ts])
    k = int(np.flatnonzero(hs < 0)[0])
    t_land = brentq(height, ts[k - 1], ts[k], xtol=1e-15, rtol=1e-15)
    v_land = c - math.cos(t_land) - (t_land - t_l) / Gamma
    return t_l, t_land, v_land


@pytest.mark.parametrize("method", ["exact", "ode"])
def test_inelastic_flat_layer_lifts_off_lands_and_sticks(method):
    t_l, t_land, v_land = _inelastic_cycle(GAMMA)
    assert math.sin(t_land) - 1 / GAMMA < 0 and t_land < t_l + 2 * math.pi   # sticks until next lift-off
    lat = tps.Lattice.planar(n_nodes=7, length=6.0)
    n_cycles = 5
    run = tps.simulate(lat, GAMMA, 0.0, np.zeros(7), np.zeros(7), t_start=0.0,
                       t_end=2 * math.pi * n_cycles, stuck0=np.ones(7, dtype=bool), method=method)
    assert run.success
    ev = run.events
    assert ev.size == 2 * 7 * n_cycles         # no event explosion: one lift-off and one landing each
    tol = 1e-12 if method == "exact" else 1e-9
    for k in range(n_cycles):
        lift = ev[(ev.kind == "liftoff") & (np.abs(ev.t - (t_l + 2 * math.pi * k)) <= tol)]
        land = ev[(ev.kind == "stick") & (np.abs(ev.t - (t_land + 2 * math.pi * k)) <= tol)]
        assert lift.size == 7 and land.size == 7
        np.testing.assert_allclose(land.w_before, v_land, rtol=0, atol=100 * tol)
    assert np.all(run.stuck)


@pytest.mark.parametrize("method", ["exact", "ode"])
def test_chatter_turns_into_sticking(method):
    # Gamma < 1: the plate never pulls the layer up; a dropped layer chatters and sticks
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    run = tps.simulate(lat, 0.8, 0.5, np.zeros(5), np.full(5, 0.3), t_start=0.0, t_end=20.0,
                       method=method, stick_velocity=1e-6)
    assert run.success and np.all(run.stuck)
    v = run.events.w_before[run.events.node == 0]
    # bounces decay geometrically (e times the previous speed, up to the drift of g)
    assert run.events.kind[-1] == "stick" and v.size < 40
    assert abs(v[-1]) <= 1e-6


def test_event_bound_stops_with_a_clear_error():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    run = tps.simulate(lat, 0.8, 0.5, np.zeros(5), np.full(5, 0.3), t_start=0.0, t_end=20.0,
                       max_events_per_cycle=12)
    assert not run.success and run.status == 6
    assert "event bound" in run.message and run.t < 20.0


def test_diffused_impact_with_tiny_length_is_the_point_rule():
    fl = stable_flat()
    lat = tps.Lattice.planar(n_nodes=21, length=10.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    kw = dict(t_start=t0, t_end=t0 + 0.5 * fl.period)
    a = tps.simulate(lat, GAMMA, E, w, z, **kw)
    b = tps.simulate(lat, GAMMA, E, w, z, impact="diffused", rho_c=1e-3, **kw)
    assert b.cutoff == {"kind": "diffused Stosslet (67)", "length": 1e-3}
    assert a.cutoff["length"] == lat.spacing
    np.testing.assert_array_equal(a.events.node, b.events.node)
    np.testing.assert_allclose(a.zeta, b.zeta, rtol=0, atol=1e-12)


# ------------------------------------------------ event layer (tps_solver.solvers.fda.events)
def test_event_log_blocks_expand_to_one_record_per_node():
    log = EventLog(0.0, max_events_per_cycle=4)
    log.add(1.0, np.array([3, 1]), "impact", np.array([-0.5, -0.25]))
    log.add(1.0, np.array([], dtype=int), "stick", np.array([]))          # an empty block logs nothing
    log.add(2.0, 2, "stick", -1e-7)
    log.add(3.0, np.array([0, 4]), "liftoff", 0.0)                           # one velocity for all
    assert log.exceeded and len(log) == 5                                    # 5 events in the first cycle
    ref = [(1.0, 3, "impact", -0.5), (1.0, 1, "impact", -0.25), (2.0, 2, "stick", -1e-7),
           (3.0, 0, "liftoff", 0.0), (3.0, 4, "liftoff", 0.0)]
    assert log.records == ref
    arr = log.to_array()
    assert isinstance(arr, np.recarray) and arr.dtype == EVENT_DTYPE
    assert arr.dtype.names == ("t", "node", "kind", "w_before")
    assert arr.tobytes() == np.array(ref, dtype=EVENT_DTYPE).tobytes()
    assert arr.kind.tolist() == ["impact", "impact", "stick", "liftoff", "liftoff"]
    log.add(2 * math.pi + 0.5, 1, "impact", -0.1)                            # a new cycle, a new count
    assert not log.exceeded
    empty = EventLog(0.0, 1).to_array()
    assert empty.shape == (0,) and empty.dtype == EVENT_DTYPE
    with pytest.raises(ValueError, match="w_before"):
        log.add(3.0, np.array([0, 1, 2]), "impact", np.array([-1.0, -2.0]))


def test_apply_contacts_mixed_set_logs_impacts_then_sticks():
    # 3 nodes, dx = 1, Neumann ends: L = [[-2, 2, 0], [1, -2, 1], [0, 2, -2]]; t = 0, g = -0.4.
    # Node 0 rebounds at w = 1; nodes 1, 2 land slower than 0.1 and are set to rest: node 1
    # feels g + w_0 = 0.6 > 0 and stays free (an impact), node 2 feels g = -0.4 and sticks.
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    w, zeta, stuck = np.array([-2.0, -0.05, -0.01]), np.zeros(3), np.zeros(3, dtype=bool)
    log = EventLog(0.0, 100)
    sticks = apply_contacts(0.0, w, zeta, stuck, np.array([0, 1, 2]), lat, 2.5, 0.5, point_impact, 0.1, log)
    assert sticks.tolist() == [2]
    assert w.tolist() == [1.0, 0.0, 0.0] and stuck.tolist() == [False, False, True]
    assert log.records == [(0.0, 0, "impact", -2.0), (0.0, 1, "impact", -0.05), (0.0, 2, "stick", -0.01)]


@pytest.mark.parametrize("t, on_plate", [(0.0, True), (math.pi / 2, False)])
def test_event_sets_node_at_rest_on_the_plate(t, on_plate):
    # w = zeta = 0 everywhere: a contact iff the free acceleration g(t) = sin t - 1/Gamma < 0
    L = tps.Lattice.planar(n_nodes=3, length=2.0).operator
    F, S = np.arange(3), np.arange(0)
    args = (t, np.zeros(3), np.zeros(3), F, S, L, L[:0], GAMMA, 1e-12, 1e-14, 1e-14)
    for kw in ({}, {"absL_FF": np.abs(L)}):
        contact, liftoff = event_sets(*args, **kw)
        assert contact.tolist() == ([0, 1, 2] if on_plate else []) and liftoff.size == 0


# ------------------------------------------------ cross-integrator, kink
def _agree_on_kink(n_nodes, stick_velocity):
    fl = stable_flat()
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=10.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    kw = dict(t_start=t0, t_end=t0 + 10 * fl.period, time_tol=1e-10, stick_velocity=stick_velocity)
    a = tps.simulate(lat, GAMMA, E, w, z, method="exact", **kw)
    b = tps.simulate(lat, GAMMA, E, w, z, method="ode", **kw)
    assert a.success and b.success
    assert a.n_events == b.n_events > 100
    np.testing.assert_array_equal(a.events.node, b.events.node)
    np.testing.assert_array_equal(a.events.kind, b.events.kind)
    assert {"impact", "stick", "liftoff"} <= set(a.events.kind)
    fast = np.abs(a.events.w_before) > 1e-3      # chatter tails have ill-conditioned times
    np.testing.assert_allclose(a.events.t[fast], b.events.t[fast], rtol=0, atol=1e-7)
    np.testing.assert_allclose(a.zeta, b.zeta, rtol=0, atol=1e-7)
    np.testing.assert_allclose(a.w, b.w, rtol=0, atol=1e-7)


@pytest.mark.slow
def test_integrators_agree_on_a_kink():
    """exact vs ode on an 11-node kink (slow: 5.6 s; point vs exact on a kink and exact vs ode on
    flat layers stay in the default suite)."""
    _agree_on_kink(11, 1e-3)


@pytest.mark.slow
def test_integrators_agree_on_a_finer_kink():
    _agree_on_kink(21, 1e-6)


@pytest.mark.parametrize("n_nodes", [41])
def test_kink_runs_without_hanging_short(n_nodes):
    fl = stable_flat()
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    run = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + fl.period)
    assert run.success and run.n_events > n_nodes
    assert np.all(run.zeta >= 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("n_nodes", [41, 81])
def test_kink_runs_20_periods_without_hanging(n_nodes):
    fl = stable_flat()
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    run = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + 20 * fl.period)
    assert run.success
    assert np.count_nonzero(run.events.kind == "stick") > 0


# ------------------------------------------------ manufactured convergence
def _slope(h, err):
    return np.polyfit(np.log(h), np.log(err), 1)[0]


def test_planar_grid_second_order_on_heat_kernel():
    # no impacts (zeta0 large): w = W_flat(t) + u, u the Gaussian heat-kernel solution
    errs, hs = [], []
    t1 = 1.0
    for n in (41, 81, 161, 321):
        lat = tps.Lattice.planar(n_nodes=n, length=20.0)
        x = lat.nodes
        u0 = np.exp(-x**2)
        run = tps.simulate(lat, GAMMA, E, u0, np.full(n, 50.0), t_start=0.0, t_end=t1)
        assert run.n_events == 0
        W = 1.0 - math.cos(t1) - t1 / GAMMA
        u = np.exp(-x**2 / (1 + 4 * t1)) / math.sqrt(1 + 4 * t1)
        errs.append(np.max(np.abs(run.w - W - u)))
        hs.append(lat.spacing)
    assert 1.8 <= _slope(hs, errs) <= 2.2


@pytest.mark.parametrize("grid", ["uniform", "quasilog"])
def test_radial_grid_second_order_on_bessel_mode(grid):
    R = 10.0
    k = jn_zeros(1, 1)[0] / R          # J0'(kR) = 0: Neumann at R
    t1 = 1.0
    errs, hs = [], []
    for n in (21, 41, 81, 161):
        lat = tps.Lattice.axisymmetric(n_nodes=n, r_max=R, grid=grid)
        r = lat.nodes
        run = tps.simulate(lat, GAMMA, E, j0(k * r), np.full(n, 50.0), t_start=0.0, t_end=t1)
        assert run.n_events == 0
        W = 1.0 - math.cos(t1) - t1 / GAMMA
        Z = 50.0 + (1.0 - math.cos(t1)) * 0 + (t1 - math.sin(t1)) - t1**2 / (2 * GAMMA)
        decay = math.exp(-k * k * t1)
        err_w = np.max(np.abs(run.w - W - decay * j0(k * r)))
        err_z = np.max(np.abs(run.zeta - Z - (1 - decay) / k**2 * j0(k * r)))
        errs.append(max(err_w, err_z))
        hs.append(1.0 / (n - 1))
    assert 1.8 <= _slope(hs, errs) <= 2.2


# ------------------------------------------------------------ bad input
def _ok_args():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    return lat, dict(Gamma=GAMMA, e=E, w0=np.zeros(5), zeta0=np.ones(5), t_start=0.0, t_end=1.0)


@pytest.mark.parametrize("factory, name", [
    (lambda: tps.Lattice([0.0, 2.0, 1.0]), "nodes"),
    (lambda: tps.Lattice.planar(n_nodes=2), "n_nodes"),
    (lambda: tps.Lattice.planar(n_nodes=5, length=-1.0), "length"),
    (lambda: tps.Lattice.planar(n_nodes=5, boundary="periodic"), "boundary"),
    (lambda: tps.Lattice.axisymmetric(n_nodes=5, grid="log"), "grid"),
    (lambda: tps.Lattice.axisymmetric(n_nodes=5, r_max=0.0), "r_max"),
    (lambda: tps.Lattice([1.0, 2.0, 3.0], geometry="axisymmetric"), "r = 0"),
])
def test_bad_lattice_input(factory, name):
    with pytest.raises(ValueError, match=name):
        factory()


@pytest.mark.parametrize("change, name", [
    (dict(method="rk4"), "method"),
    (dict(w0=np.zeros(4)), "w0"),
    (dict(zeta0=np.array([1.0, np.nan, 1.0, 1.0, 1.0])), "zeta0"),
    (dict(zeta0=-np.ones(5)), "zeta0"),
    (dict(impact="diffused", rho_c=-1.0), "rho_c"),
    (dict(impact="diffused"), "rho_c"),
    (dict(impact="soft"), "impact"),
    (dict(e=1.0), "e"),
    (dict(Gamma=0.0), "Gamma"),
    (dict(t_end=-1.0), "t_end"),
    (dict(stuck0=np.ones(5, dtype=bool)), "stuck0"),
    (dict(method="ode", ode_solver="Euler"), "ode_solver"),
])
def test_bad_simulate_input(change, name):
    lat, kw = _ok_args()
    kw.update(change)
    with pytest.raises(ValueError, match=name):
        tps.simulate(lat, **kw)


def test_bad_lattice_object():
    _, kw = _ok_args()
    with pytest.raises(ValueError, match="lattice"):
        tps.simulate("grid", **kw)
