"""The fast soft-contact integrator (fda/soft.py) against closed forms and the Radau reference."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.fda import kink_state
from tps_solver.solvers.fda import simulate
from tps_solver.model.soft_flat import SoftFlatOrbit, soft_contact_parameters
from tps_solver.solvers.fda.soft import SoftIntegrator, radau_iia


def simulate_soft(lattice, Gamma, e, w0, zeta0, t_start, t_end, **kw):
    """The Radau reference of the soft contact (``simulate(..., method="soft-radau")``)."""
    return simulate(lattice, Gamma, e, w0, zeta0, t_start, t_end, method="soft-radau", **kw)



GAMMA, E, M, ELL = 2.5, 0.45, 2, 0.3


def drive(integ, t, w, z, t_end, t_eval=(), stuck=None):
    """The driver loop in miniature: advance until t_end, collecting events and samples."""
    stuck = np.zeros(w.size, bool) if stuck is None else stuck
    events, samples = [], []
    while t < t_end:
        s = integ.advance(t, w, z, stuck, t_end, t_eval)
        t, w, z, stuck = s.t, s.w, s.zeta, s.stuck
        events += s.events
        samples += s.samples
    return t, w, z, stuck, events, samples


def flat_start(n, orb):
    ts = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(ts)
    return ts, np.full(n, w), np.full(n, z)


def test_radau_iia_tableau_matches_the_closed_form_for_three_stages():
    c, A = radau_iia(3)
    r6 = math.sqrt(6.0)
    assert np.allclose(c, [(4 - r6) / 10, (4 + r6) / 10, 1.0], rtol=0, atol=1e-15)
    assert np.allclose(A[-1], [(16 - r6) / 36, (16 + r6) / 36, 1 / 9], rtol=0, atol=1e-15)
    assert np.allclose(A[0], [(88 - 7 * r6) / 360, (296 - 169 * r6) / 1800, (-2 + 3 * r6) / 225],
                       rtol=0, atol=1e-15)


@pytest.mark.parametrize("periods", [10, pytest.param(50, marks=pytest.mark.slow)])
def test_flat_orbit_contact_times_match_the_closed_form(periods):
    """Entry at t_exit + F (mod T), exit tau_c later, for every node and every period, to 1e-12."""
    orb = SoftFlatOrbit(GAMMA, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    ts, w, z = flat_start(3, orb)
    t_eval = ts + orb.period * np.arange(1, periods + 1)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL)
    _, w, z, _, events, samples = drive(integ, ts, w, z, t_eval[-1], t_eval)
    imp = np.array([ev[0] for ev in events if ev[2] == "impact"])
    out = np.array([ev[0] for ev in events if ev[2] == "liftoff"])
    assert imp.size == out.size == 3 * periods                 # every node, once per period
    k = np.round((imp - orb.t_exit - orb.flight) / orb.period)
    t_in = orb.t_exit + orb.flight + k * orb.period
    assert np.max(np.abs(imp - t_in)) < 1e-12
    assert np.max(np.abs(out - (t_in + orb.tau_c))) < 1e-12
    speeds = np.array([ev[3] for ev in events if ev[2] == "impact"])
    assert np.max(np.abs(speeds + orb.V)) < 1e-11
    wf, zf = orb.state(t_eval[-1])
    assert len(samples) == periods
    assert np.max(np.abs(samples[-1][1] - wf)) < 1e-11 and np.max(np.abs(samples[-1][2] - zf)) < 1e-11


def test_uniform_contact_lasts_tau_c_and_restitutes_e():
    """A uniform layer (L w = 0): the contact is the damped oscillator, exit after tau_c at -e w_in."""
    lat = tps.Lattice.planar(n_nodes=4, length=3.0)
    tau_c, _, _ = soft_contact_parameters(E, ELL)
    for V in (0.3, 3.4):
        integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL)
        t0, z0 = 0.2, 1e-3
        s = integ.advance(t0, np.full(4, -V), np.full(4, z0), None, 5.0)
        assert [ev[2] for ev in s.events] == ["impact"] * 4 and s.stuck.all()
        t_in, w_in = s.t, s.w[0]
        s = integ.advance(s.t, s.w, s.zeta, s.stuck, 5.0)
        assert [ev[2] for ev in s.events] == ["liftoff"] * 4 and not s.stuck.any()
        assert abs(s.t - t_in - tau_c) < 1e-12
        assert abs(s.w[0] + E * w_in) < 1e-12 * V


def test_sticking_rule_holds_a_slow_node_and_releases_it_where_g_turns_positive():
    """A layer arriving at 1e-10 while g < 0 is held (w = zeta = 0) and released at sin t = 1/Gamma."""
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL)
    t0 = -1.0                                            # g(t0) < 0
    s = integ.advance(t0, np.full(3, -1e-10), np.full(3, 1e-20), None, 3.0)
    assert [ev[2] for ev in s.events] == ["stick"] * 3
    assert np.all(s.w == 0.0) and np.all(s.zeta == 0.0) and s.stuck.all()
    s = integ.advance(s.t, s.w, s.zeta, s.stuck, 3.0)
    assert [ev[2] for ev in s.events] == ["liftoff"] * 3 and not s.stuck.any()
    assert abs(s.t - math.asin(1.0 / GAMMA)) < 1e-12
    s = integ.advance(s.t, s.w, s.zeta, s.stuck, s.t + 0.5)          # flies off (g > 0)
    assert not s.events and np.all(s.zeta > 0.0)


def test_micro_chatter_ends_in_sticking():
    """Slow landing: the bounce speed falls by e per contact until it is below stick_speed."""
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, stick_speed=1e-6)
    t, w, z, stuck = -1.3, np.full(3, -1e-3), np.full(3, 1e-6), None
    kinds, speeds = [], []
    while not kinds or kinds[-1] != "stick":
        s = integ.advance(t, w, z, stuck, 0.0)
        assert s.t < 0.0
        t, w, z, stuck = s.t, s.w, s.zeta, s.stuck
        kinds += [ev[2] for ev in s.events[:1]]
        speeds += [abs(ev[3]) for ev in s.events[:1]]
    imp = np.array([v for k, v in zip(kinds, speeds) if k == "impact"])
    assert np.allclose(imp[1:] / imp[:-1], E, rtol=1e-3)     # restitution per bounce
    assert imp[-1] * E <= 1e-6 < imp[-1]                      # captured on the first slow arrival


def test_state_matches_radau_on_a_small_kink():
    """Independent reference: scipy Radau (dense state, rtol 1e-11) through the first contact."""
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_end = t0 + 0.5 * fl.period
    ref = simulate_soft(lat, GAMMA, E, w, z, t0, t_end, cutoff=ELL, rtol=1e-11, atol=1e-12)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, stick_speed=0.0)     # Radau has no sticking rule
    _, wf, zf, stuck, events, _ = drive(integ, t0, w, z, t_end)
    assert ref.n_events == sum(ev[2] == "impact" for ev in events) >= 1
    assert np.max(np.abs(wf - ref.w)) < 1e-8 and np.max(np.abs(zf - ref.zeta)) < 1e-8
    assert np.array_equal(stuck, ref.stuck)
    assert abs(events[0][0] - ref.events.t[0]) < 1e-8


@pytest.mark.slow
def test_state_matches_radau_on_a_nine_node_kink_over_one_period():
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=9, length=8.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_eval = t0 + fl.period * np.arange(1, 5) / 4
    ref = simulate_soft(lat, GAMMA, E, w, z, t0, t_eval[-1], cutoff=ELL, t_eval=t_eval,
                        rtol=1e-11, atol=1e-12)
    _, _, _, _, events, samples = drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL, stick_speed=0.0),
                                        t0, w, z, t_eval[-1], t_eval)
    assert ref.n_events == sum(ev[2] == "impact" for ev in events)
    for k, (ts, ws, zs) in enumerate(samples):
        assert ts == t_eval[k]
        assert np.max(np.abs(ws - ref.w_eval[k])) < 1e-8 and np.max(np.abs(zs - ref.zeta_eval[k])) < 1e-8


def test_simultaneous_entry_of_a_flat_region_is_one_event_set():
    orb = SoftFlatOrbit(GAMMA, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=7, length=6.0)
    ts, w, z = flat_start(7, orb)
    s = SoftIntegrator(lat, GAMMA, E, cutoff=ELL).advance(ts, w, z, np.zeros(7, bool), ts + orb.period)
    assert sorted(ev[1] for ev in s.events) == list(range(7))
    assert abs(s.t - (orb.t_exit + orb.flight)) < 1e-12


@pytest.mark.parametrize("dz, off", [(1e-13, 3e-14), (2e-13, 1e-14), (1e-12, 3e-13)])
def test_output_time_just_after_a_simultaneous_exit(dz, off):
    """Nodes that leave the contact in one event set sit up to time_tol on the wrong side of their
    own exit; an output time a few ulps later used to start a switch search in a sliver where the
    violation is positive throughout, which stalled (RuntimeError).  The sample must be the flat
    orbit's state there and the events those of the run without output times."""
    orb = SoftFlatOrbit(GAMMA, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    ts, w, z = flat_start(3, orb)
    z[1] += dz
    *_, ref, _ = drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL), ts, w.copy(), z.copy(), ts + orb.period)
    te = next(ev[0] for ev in ref if ev[2] == "liftoff")
    *_, events, samples = drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL), ts, w.copy(), z.copy(),
                                ts + orb.period, t_eval=[te + off])
    assert [ev[1:3] for ev in events] == [ev[1:3] for ev in ref]
    assert max(abs(a[0] - b[0]) for a, b in zip(events, ref)) <= 1e-13
    (t_s, w_s, z_s), = samples
    w_o, z_o = orb.state(t_s)
    assert t_s == te + off
    assert np.max(np.abs(w_s - w_o)) <= 1e-10 and np.max(np.abs(z_s - z_o)) <= 1e-11


def test_event_bound_raises_runtime_error_with_advice():
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, max_events=1, stick_speed=0.0)
    with pytest.raises(RuntimeError, match="max_events"):
        drive(integ, -1.3, np.full(3, -1e-3), np.full(3, 1e-6), 0.0)


@pytest.mark.parametrize("kwargs,match", [
    (dict(e=0.0, cutoff=0.3), "e must be in"),
    (dict(e=0.45), "cutoff must be given"),
    (dict(e=0.45, cutoff=-1.0), "cutoff"),
    (dict(e=0.45, cutoff=0.3, stages=0), "stages"),
    (dict(e=0.45, cutoff=0.3, stick_speed=-1.0), "stick_speed"),
    (dict(e=0.45, cutoff=0.3, rtol=0.0), "rtol"),
    (dict(e=0.45, cutoff=0.3, impact="kernel"), "impact"),
])
def test_bad_input_raises_value_error_naming_the_parameter(kwargs, match):
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    e = kwargs.pop("e")
    with pytest.raises(ValueError, match=match):
        SoftIntegrator(lat, GAMMA, e, **kwargs)
    with pytest.raises(ValueError, match="lattice"):
        SoftIntegrator(np.eye(3), GAMMA, 0.45, cutoff=0.3)


def test_class_attributes_for_the_driver_registry():
    assert SoftIntegrator.name == "soft" and SoftIntegrator.impulsive is False
    assert "cutoff" in SoftIntegrator.OPTIONS


@pytest.mark.parametrize("k", [3, 20])          # the float path (few roots) and the vectorised one
def test_collocation_root_polish_finds_the_roots_of_known_polynomials(k):
    """Roots of p(theta) = (theta - r)(theta + 2)^5 from its values at the step nodes (0, c)."""
    integ = SoftIntegrator(tps.Lattice.planar(n_nodes=3, length=2.0), GAMMA, E, cutoff=ELL)
    r = np.linspace(0.05, 0.95, k)
    vals = (integ._nodes[:, None] - r[None, :]) * (integ._nodes[:, None] + 2.0) ** 5
    lo, hi = r - 0.1, r + 0.1
    x = integ._poly_roots(vals, lo, hi, r + 0.05)
    assert np.max(np.abs(x - r)) < 1e-13          # round-off of the monomial form; the guess is 5e-2 off


def test_held_node_violation_is_the_free_acceleration_of_the_full_operator():
    """Held nodes (incl. both ends, on the non-symmetric axisymmetric operator): v = (L w)_i + g(t)."""
    lat = tps.Lattice.axisymmetric(n_nodes=7, r_max=3.0)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL)
    rng = np.random.default_rng(3)
    w, z = rng.standard_normal(7), rng.standard_normal(7)
    mode = np.array([2, 0, 1, 2, 2, 0, 2])
    w[mode == 2] = z[mode == 2] = 0.0
    cfg = integ._config(mode)
    t = 0.7
    v, dv = integ._violation(t, w, z, mode, cfg)
    held = mode == 2
    L = np.asarray(lat.operator, float)
    g = math.sin(t) - 1.0 / GAMMA
    assert np.allclose(v[held], (L @ w + g)[held], rtol=0, atol=1e-13)
    assert np.array_equal(v[~held], np.where(mode == 0, -z, z)[~held])
    dw = L @ w - 2 * integ.beta * (mode == 1) * w - integ.omega0_sq * (mode == 1) * z + g * (mode == 0)
    dw[held] = 0.0
    assert np.allclose(dv[held], (L @ dw + math.cos(t))[held], rtol=0, atol=1e-12)
    for j in range(7):
        assert integ._violation_at(j, t, w, z, cfg) == (v[j], dv[j])
