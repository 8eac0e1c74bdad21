"""The one contact-pattern vocabulary (tps_solver.core.pattern) and the dense output of FDA runs."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core.pattern import KINDS, LETTERS, ContactPattern
from tps_solver.solvers.fda import flat_state
from tps_solver.solvers.fda.dense import PiecewiseFlow

T = 4 * math.pi


@pytest.mark.parametrize("kw, match", [
    (dict(node=[0], t=[1.0], kind=["hop"]), "kind must be one of"),
    (dict(node=[2], t=[1.0], kind=["bounce"]), "node must lie in"),
    (dict(node=[0], t=[math.nan], kind=["bounce"]), "t must be finite"),
    (dict(node=[0], t=[1.0], kind=["stick"]), "liftoff must be finite"),
    (dict(node=[0], t=[1.0], kind=["stick"], liftoff=[0.5]), "liftoff must be finite and >= t"),
    (dict(node=[0, 1], t=[1.0], kind=["bounce"]), "one length"),
    (dict(node=[0], t=[1.0], kind=["stick"], liftoff=[2.0], ended_by=["triggered"]), "triggering node"),
])
def test_invalid_patterns_are_refused_by_name(kw, match):
    with pytest.raises(ValueError, match=match):
        ContactPattern.from_contacts(n_nodes=2, period=T, **kw)


def test_window_sorting_and_letters():
    p = ContactPattern.from_contacts([1, 0, 0], [T + 1.0, 3.0, -1.0], ["S", "T", "bounce"], 2, T,
                                     liftoff=[T + 2.5, math.nan, math.nan])
    # times wrapped into [0, T), the lift-off moves with its contact
    assert p.t.tolist() == [3.0, T - 1.0, 1.0] and p.node.tolist() == [0, 0, 1]
    assert p.liftoff[2] == 2.5 and p.sequences() == ["TB", "S"]
    assert p.rest_times().tolist() == [0.0, 0.0, 1.5]
    assert set(LETTERS) == set(KINDS)
    with pytest.raises(ValueError, match="single-contact"):
        p.tc
    with pytest.raises(ValueError):
        p.t[0] = 0.0                     # read-only fields


@pytest.mark.parametrize("kw", [dict(Gamma=4.1, e=0.0), dict(Gamma=4.4, e=0.1, pattern="stick"),
                                dict(Gamma=2.5, M=2, e=0.45), dict(Gamma=3.8, e=0.0, pattern="touch")])
def test_flat_layer_pattern_matches_its_sequence_and_events(kw):
    fl = tps.FlatLayer(**kw)
    p = fl.contacts(3)
    assert p.sequences() == [fl.contact_sequence] * 3
    landings = [t for t, k in fl.events if k == "impact"]
    assert p.t[0] == landings[0]
    rest = np.isin(p.kind, ("stick", "chatter"))
    # the rest ends at the next lift-off, where g = sin t - 1/Gamma turns positive
    assert np.all(np.abs(np.sin(p.liftoff[rest]) - 1 / fl.Gamma) < 1e-14)


def test_stick_tps_pattern_against_the_closed_form_flat_layer():
    sol = tps.solve_stick_flat(4.1, perturbation=1e-3)
    assert sol.converged
    tps_p, exact = sol.contacts, tps.FlatLayer(4.1, e=0.0).contacts()
    assert tps_p.sequences() == exact.sequences() == ["TS"]
    assert tps_p.max_phase_distance(exact) < 1e-11


def test_single_contact_results_carry_their_pattern():
    sol = tps.solve_oscillon()
    assert sol.contacts.single_contact and np.array_equal(sol.contacts.tc, np.mod(sol.tc, sol.period))


def _kink():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4)
    assert orb.converged
    return lat, orb


@pytest.mark.parametrize("method, tol", [("exact", 1e-13), ("point", 1e-13), ("ode", 1e-10)])
def test_dense_output_reproduces_the_run_samples(method, tol):
    lat, orb = _kink()
    t = orb.t_start + np.linspace(0.0, orb.period, 97)[1:]
    run = tps.simulate(lat, 4.1, 0.0, orb.w0, orb.zeta0, t_start=orb.t_start, t_end=orb.t_start + orb.period,
                       stuck0=orb.stuck0, t_eval=t, record_segments=True, method=method)
    w, z = PiecewiseFlow(lat, 4.1, run.segments, run.t)(t)
    assert np.max(np.abs(w - run.w_eval)) < tol and np.max(np.abs(z - run.zeta_eval)) < tol
    assert run.segments.t.size == 1 + len(np.unique(run.events.t))


def test_dense_output_against_the_flat_layer_closed_form():
    fl = tps.FlatLayer(4.1, e=0.0)
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    t0 = fl.t0 + 0.5
    run = tps.simulate(lat, 4.1, 0.0, *flat_state(lat, fl, t0), t_start=t0, t_end=t0 + 2 * fl.period,
                       record_segments=True)
    t = t0 + np.linspace(0.0, 2 * fl.period, 301)
    w, z = PiecewiseFlow(lat, 4.1, run.segments, run.t)(t)
    assert np.max(np.abs(z - fl.height(t)[:, None])) < 1e-12
    assert np.max(np.abs(w - fl.velocity(t)[:, None])) < 1e-12
    with pytest.raises(ValueError, match="recorded interval"):
        PiecewiseFlow(lat, 4.1, run.segments, run.t)([t0 - 1.0])
    assert tps.simulate(lat, 4.1, 0.0, *flat_state(lat, fl, t0), t_start=t0, t_end=t0 + 1.0).segments is None


def test_shooting_orbit_evaluates_from_its_stored_period(monkeypatch):
    lat, orb = _kink()
    t = orb.t_start + np.linspace(-1.0, 2 * orb.period, 64)
    z, w = orb.height(t), orb.velocity(t)
    stored = orb.pop("segments")
    z_sim, w_sim = orb.height(t), orb.velocity(t)        # the old path: integrate the period
    orb.segments = stored
    assert np.max(np.abs(z - z_sim)) < 1e-13 and np.max(np.abs(w - w_sim)) < 1e-13

    import tps_solver.solvers.fda as fda

    def no_stepping(*a, **k):
        raise AssertionError("velocity/height must not time-step")

    monkeypatch.setattr(fda, "simulate", no_stepping)
    assert np.array_equal(orb.height(t), z)


# ----------------------------------------------------------------------------- patterns from FDA events
from tps_solver.solvers.fda.patterns import pattern_from_events  # noqa: E402


def _events(rows):
    return np.rec.fromrecords(rows, names="t,node,kind")


def test_pattern_from_events_manufactured():
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    ev = _events([(1.0, 2, "impact"), (1.0, 2, "liftoff"),            # e = 0 touch-and-go
                  (2.0, 1, "stick"),                                  # lone stick: lands to rest
                  (2.0 + 5e-10, 0, "liftoff"),                        # triggered by node 1
                  (7.0, 0, "impact"), (7.0, 0, "stick"),              # rest across the section
                  (8.0, 1, "liftoff"), (9.0, 2, "impact"), (9.0, 2, "stick"), (10.0, 2, "liftoff")])
    p = pattern_from_events(ev, lat, T, 0.0, stuck0=[True, False, False])
    assert p.sequences() == ["S", "S", "TS"]
    assert p.liftoff[0] == 2.0 + 5e-10 + T and p.ended_by[0] == "triggered" and p.trigger[0] == 1
    assert p.liftoff[1] == 8.0 and p.ended_by[1] == "smooth"
    assert p.liftoff[3] == 10.0 and p.ended_by[3] == "smooth"
    # not triggered beyond the tolerance
    q = pattern_from_events(ev, lat, T, 0.0, stuck0=[True, False, False], trigger_tol=1e-10)
    assert q.ended_by[0] == "smooth"
    with pytest.raises(ValueError, match="no landing to rest"):
        pattern_from_events(ev, lat, T, 0.0)
    with pytest.raises(ValueError, match="never lifts off"):
        pattern_from_events(_events([(1.0, 0, "stick")]), lat, T, 0.0)


def test_shooting_kink_pattern_against_the_impact_and_stick_tps():
    """Two methods, one orbit: the shooting kink's events against the spectral impact-and-stick TPS."""
    lat, orb = _kink()
    c = orb.contacts
    assert sorted(set(c.sequences())) == ["ST", "TS"] and np.all(c.counts == 2)
    sol = tps.solve_stick_lattice(lat, 4.1, pattern=orb)
    assert sol.converged
    assert c.max_phase_distance(sol.contacts) < 1e-9


def test_single_contact_shooting_orbit_has_the_cycle_tc():
    coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    orb = tps.find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=cyc, multipliers=False)
    d = np.mod(orb.tc - cyc.tc, orb.period)
    assert np.max(np.minimum(d, orb.period - d)) < 1e-9
    assert orb.contacts.sequences() == ["B"] * 8
