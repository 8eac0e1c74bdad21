"""Periodic orbits by shooting (tps_solver.solvers.shooting.periodic.find_periodic_orbit).

References: the exact single-contact lattice cycle (solve_lattice_cycle, closed form), the
closed-form e = 0 flat orbit (lift-off at sin t = 1/Gamma, touch-and-go, stick), check_stability's
one-sided period-map Jacobian and perturbation growth, and the soft flat orbit's per-mode
monodromy (slow).
"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import tps_solver as tps
from tps_solver.solvers.shooting.periodic import ShootingOrbit, find_periodic_orbit

G, E, M = 2.5, 0.45, 2


@pytest.fixture(scope="module")
def coarse():
    lat = tps.Lattice.planar(n_nodes=8, length=140.0)
    return lat, tps.solve_lattice_cycle(lat, Gamma=G, M=M, e=E, t0=None)


@pytest.fixture(scope="module")
def coarse_orbit(coarse):
    lat, cyc = coarse
    return find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=cyc)


def _pdist(a, b, T):
    return np.abs(np.mod(np.asarray(a) - np.asarray(b) + 0.5 * T, T) - 0.5 * T)


def _ten_periods(orb, periods=10):
    t_eval = orb.t_start + orb.period * np.arange(periods + 1)
    run = tps.simulate(orb.lattice, orb.Gamma, orb.e, orb.w0, orb.zeta0, t_start=orb.t_start, t_end=t_eval[-1],
                       stuck0=orb.stuck0, t_eval=t_eval)
    return np.maximum(np.max(np.abs(run.w_eval - run.w_eval[0]), axis=1),
                      np.max(np.abs(run.zeta_eval - run.zeta_eval[0]), axis=1))[1:]


# ------------------------------------------------------------ single-contact reference

def test_reproduces_lattice_cycle_from_a_perturbed_guess(coarse, coarse_orbit):
    lat, cyc = coarse
    rng = np.random.default_rng(3)
    o = coarse_orbit
    guess = (o.w0 + 1e-2 * rng.standard_normal(8), o.zeta0 + 1e-2 * rng.standard_normal(8))
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=guess, t_start=o.t_start, multipliers=False)
    assert orb.converged and orb.status == 0 and orb.residual <= 1e-11
    assert orb.residual_history[0] > 1e-3 and orb.nit >= 2           # it really iterated
    assert orb.contacts_per_node.tolist() == [1] * 8 and orb.sticking_intervals == []
    tc = np.array([c[0] for c in orb.contact_times])
    assert np.max(_pdist(tc, cyc.tc, cyc.period)) <= 1e-10
    assert np.max(np.abs(orb.w0 - cyc.velocity([orb.t_start])[0])) <= 1e-10
    assert np.max(np.abs(orb.zeta0 - cyc.height([orb.t_start])[0])) <= 1e-10


def test_multipliers_agree_with_check_stability(coarse, coarse_orbit):
    lat, cyc = coarse
    orb = coarse_orbit
    assert orb.differentiable and orb.multipliers_kind == "all (dense)" and orb.multipliers.size == 16
    chk = tps.check_stability(cyc, periods=2, jacobian=True)
    assert chk.differentiable
    k = 6
    a = np.sort_complex(orb.multipliers[:k])
    b = np.sort_complex(chk.multipliers[:k])
    assert np.max(np.abs(a - b)) < 1e-5
    assert abs(abs(orb.multipliers[0]) - 0.457) < 1e-3
    assert np.all(np.diff(np.abs(orb.multipliers)) <= 1e-12)          # by decreasing modulus
    assert not orb.neutral


def test_arnoldi_leading_multipliers_match_the_dense_spectrum(coarse, coarse_orbit):
    lat, _ = coarse
    o = coarse_orbit
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=o, dense_max=0, n_multipliers=4)
    assert orb.converged and orb.multipliers_kind == "leading (Arnoldi)" and orb.multipliers.size == 4
    assert np.max(np.abs(np.abs(orb.multipliers) - np.abs(o.multipliers[:4]))) < 1e-5
    assert np.max(np.abs(np.sort_complex(orb.multipliers) - np.sort_complex(o.multipliers[:4]))) < 1e-5


def test_unstable_cycle_defect_grows_like_leading_multiplier():
    lat = tps.Lattice.planar(n_nodes=8, length=140.0)
    t0u = tps.FlatLayer(G, M, e=E, branch="unstable").t0
    cyc = tps.solve_lattice_cycle(lat, Gamma=G, M=M, e=E, t0=t0u)
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=cyc)
    assert orb.converged
    mu1 = abs(orb.multipliers[0])
    assert mu1 > 1.5
    d = _ten_periods(orb)
    assert d[0] <= 1e-11
    ratio = (d[8] / d[4]) ** 0.25
    assert abs(ratio - mu1) / mu1 < 0.02


# ------------------------------------------------------------ several contacts and sticking

def _e0_flat_reference(Gamma):
    """Closed form: lift-off at sin t = 1/Gamma, free flight from rest, touch-and-go at the first
    landing (g > 0 there), stick at the second (g < 0) until the next lift-off."""
    tl = math.asin(1.0 / Gamma)

    def height_from_rest(t, ta):
        return -math.sin(t) + math.sin(ta) + (t - ta) * math.cos(ta) - (t - ta) ** 2 / (2.0 * Gamma)

    def landing(ta):
        ts = ta + np.linspace(1e-3, 4.0 * math.pi, 40001)
        z = np.array([height_from_rest(t, ta) for t in ts])
        i = int(np.flatnonzero(z < 0)[0])
        return brentq(height_from_rest, ts[i - 1], ts[i], args=(ta,), xtol=1e-15)

    t1 = landing(tl)
    t2 = landing(t1)
    return tl, t1, t2, height_from_rest


def test_e0_flat_orbit_two_contacts_and_a_stick_match_closed_form():
    Gamma = 4.1
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    tl, t1, t2, zf = _e0_flat_reference(Gamma)
    assert math.sin(t1) > 1.0 / Gamma and math.sin(t2) < 1.0 / Gamma      # touch-and-go, then stick
    T = 2 * math.pi * M
    s = tl + 1.0                                            # a flight time; the guess is off by 1e-3
    guess = (np.full(3, -math.cos(s) + math.cos(tl) - (s - tl) / Gamma + 1e-3), np.full(3, zf(s, tl) + 1e-3))
    orb = find_periodic_orbit(lat, Gamma=Gamma, M=M, e=0.0, guess=guess, t_start=s)
    assert orb.converged, orb.message
    assert orb.contacts_per_node.tolist() == [2, 2, 2]
    for j in range(3):
        got = np.sort(np.mod(orb.contact_times[j], T))
        assert np.max(_pdist(got, np.sort(np.mod([t1, t2], T)), T)) <= 1e-10
    stick = [iv for iv in orb.sticking_intervals if iv[0] == 0]
    assert len(stick) == 1
    assert _pdist(stick[0][1], t2, T) <= 1e-10 and _pdist(stick[0][2], tl, T) <= 1e-10
    # sticking erases the state: the monodromy vanishes
    assert orb.multipliers.size == 6 and np.max(np.abs(orb.multipliers)) < 1e-6
    assert np.max(_ten_periods(orb)) <= 1e-10


@pytest.mark.slow
def test_e0_kink_has_two_contacts_per_node_and_is_confirmed_by_ten_periods():
    from validation.shooting import e0_kink_guess

    lat = tps.Lattice.planar(n_nodes=9, length=32.0)
    run = e0_kink_guess(lat, 4.1, M, periods=6)
    steps = []
    orb = find_periodic_orbit(lat, Gamma=4.1, M=M, e=0.0, guess=run, callback=lambda s: steps.append((s.iteration, s.residual)))
    assert orb.converged, orb.message
    assert [s[0] for s in steps] == list(range(orb.nit + 1))
    assert np.allclose([s[1] for s in steps], orb.residual_history)
    assert np.all(orb.contacts_per_node >= 2)
    assert {0, lat.n_nodes - 1} <= {iv[0] for iv in orb.sticking_intervals}      # the far fields stick
    d = _ten_periods(orb)
    assert np.max(d) <= 1e-10
    # a kink, not a flat layer: the two halves are half a period apart
    assert abs(orb.zeta0[0] - orb.zeta0[-1]) > 0.1
    # the leading multiplier (front mode) against the decay of a perturbation in time stepping
    mu1 = abs(orb.multipliers[0])
    assert 0.5 < mu1 < 1.0
    x = np.concatenate((orb.w0, orb.zeta0))
    v = np.zeros_like(x)
    v[lat.n_nodes:] = 1e-6 * np.sign(lat.nodes)
    t_eval = orb.t_start + orb.period * np.arange(11)
    pert = tps.simulate(lat, 4.1, 0.0, orb.w0 + v[:9], orb.zeta0 + v[9:], t_start=orb.t_start, t_end=t_eval[-1],
                        t_eval=t_eval)
    dist = np.max(np.abs(pert.zeta_eval - orb.zeta0), axis=1) + np.max(np.abs(pert.w_eval - orb.w0), axis=1)
    assert abs((dist[10] / dist[6]) ** 0.25 - mu1) < 0.01


# ------------------------------------------------------------ non-smooth map: fallback

def test_point_impact_flat_layer_is_not_differentiable_and_falls_back_to_growth():
    fl = tps.FlatLayer(G, M, e=E)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t_s = fl.t0 + 0.5 * fl.period                      # check_stability's section for a flat layer
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=fl, t_start=t_s, section="fixed", growth_periods=6)
    assert orb.converged and orb.residual <= 1e-11
    assert orb.simultaneous_contacts
    assert orb.differentiable is False and orb.multipliers.size == 0 and orb.multipliers_kind == "none"
    assert "not differentiable" in orb.message and "docs/design.md, hazard 7" in orb.message
    chk = tps.check_stability(fl, periods=6, n_nodes=5, length=4.0)
    assert np.isfinite(orb.growth_factor)
    assert abs(orb.growth_factor - chk.growth_factor) < 1e-6 * chk.growth_factor   # the same protocol


# ------------------------------------------------------------ guesses, bounds, interruption

def test_guess_types_give_the_same_orbit(coarse, coarse_orbit):
    lat, cyc = coarse
    o = coarse_orbit
    run = tps.simulate(lat, G, E, o.w0, o.zeta0, t_start=o.t_start, t_end=o.t_start + 3 * o.period)
    for guess in (run, o):
        orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=guess, multipliers=False)
        assert orb.converged
        assert np.max(np.abs(orb.height([o.t_start])[0] - o.zeta0)) <= 1e-10
    assert isinstance(o, ShootingOrbit) and isinstance(o, tps.PeriodicOrbit)
    # a spectral TPS solution (truncated at N = 16, so off the orbit by ~1e-2) as the guess
    spec = tps.solve_lattice(lat, Gamma=G, M=M, e=E, t0=None, n_harmonics=16)
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=spec, multipliers=False)
    assert orb.converged and orb.residual_history[0] > 1e-3
    tc = np.array([c[0] for c in orb.contact_times])
    assert np.max(_pdist(tc, cyc.tc, cyc.period)) <= 1e-10
    # the orbit is itself a periodic solution that check_stability accepts
    assert tps.check_stability(orb, periods=3).initial_defect.max() <= 1e-10
    # the orbit's velocity/height sample the cycle
    ts = o.t_start + np.array([0.3, 5.0, 11.0])
    assert np.max(np.abs(o.height(ts) - cyc.height(ts))) <= 1e-10


def test_iteration_limit_reports_history_and_advice(coarse, coarse_orbit):
    lat, _ = coarse
    o = coarse_orbit
    rng = np.random.default_rng(5)
    guess = (o.w0 + 0.05 * rng.standard_normal(8), o.zeta0 + 0.05 * np.abs(rng.standard_normal(8)))
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=guess, t_start=o.t_start, max_iter=1)
    assert not orb.converged and orb.status == 1 and orb.nit == 1
    assert orb.residual_history.size == 2 and orb.residual_history[1] < orb.residual_history[0]
    assert "max_iter" in orb.message and orb.multipliers.size == 0


def test_keyboard_interrupt_returns_the_last_iterate(coarse, coarse_orbit):
    lat, _ = coarse
    o = coarse_orbit
    guess = (o.w0 + 1e-2, o.zeta0 + 1e-2)
    seen = []

    def cb(state):
        seen.append(state.residual)
        if state.iteration == 1:
            raise KeyboardInterrupt

    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=guess, t_start=o.t_start, callback=cb)
    assert not orb.converged and orb.status == 5 and orb.status_text == "interrupted"
    assert "interrupted" in orb.message and orb.nit == 1 and len(seen) == 2
    assert orb.residual == seen[1] and orb.residual < seen[0]
    assert orb.w0.shape == (8,) and not np.allclose(orb.w0, guess[0])


def test_event_bound_stops_with_a_clear_message(coarse):
    lat, cyc = coarse
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=cyc, max_events_per_period=5)
    assert not orb.converged and orb.status == 6
    assert "max_events_per_period" in orb.message


@pytest.mark.parametrize("kwargs, name", [
    (dict(guess=(np.zeros(7), np.ones(8)), t_start=1.0), "w0"),
    (dict(guess=(np.zeros(8), -np.ones(8)), t_start=1.0), "zeta0"),
    (dict(guess=(np.zeros(8), np.full(8, np.nan)), t_start=1.0), "zeta0"),
    (dict(guess=(np.zeros(8), np.ones(8))), "t_start"),
    (dict(cutoff=0.0), "cutoff"),
    (dict(cutoff=-1.0), "cutoff"),
    (dict(Gamma=-1.0), "Gamma"),
    (dict(e=1.0), "e"),
    (dict(M=0), "M"),
    (dict(method="rk4"), "method"),
    (dict(guess="flat"), "guess"),
    (dict(tol=0.0), "tol"),
])
def test_bad_input_raises_valueerror_naming_the_parameter(coarse, kwargs, name):
    lat, _ = coarse
    with pytest.raises(ValueError, match=name):
        find_periodic_orbit(lat, **{"Gamma": G, "M": M, "e": E, **kwargs})


def test_guess_from_another_lattice_is_rejected(coarse):
    lat, cyc = coarse
    other = tps.Lattice.planar(n_nodes=9, length=140.0)
    with pytest.raises(ValueError, match="guess"):
        find_periodic_orbit(other, Gamma=G, M=M, e=E, guess=cyc)
    shifted = tps.Lattice.planar(n_nodes=8, length=120.0)
    run = tps.simulate(shifted, G, E, np.zeros(8), np.ones(8), t_end=1.0)
    with pytest.raises(ValueError, match="another lattice"):
        find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=run)
    with pytest.raises(ValueError, match="lattice"):
        find_periodic_orbit("not a lattice", Gamma=G, M=M, e=E, guess=cyc)


# ------------------------------------------------------------ other period maps (slow)

@pytest.mark.slow
def test_ode_method_finds_the_same_cycle(coarse, coarse_orbit):
    lat, cyc = coarse
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, guess=cyc, method="ode", multipliers=False)
    assert orb.converged and orb.method == "ode"
    tc = np.array([c[0] for c in orb.contact_times])
    assert np.max(_pdist(tc, cyc.tc, cyc.period)) <= 1e-8


@pytest.mark.slow
def test_soft_flat_orbit_and_multipliers_match_per_mode_monodromy():
    from tps_solver.model.soft_flat import SoftFlatOrbit
    from tps_solver.operators.lattice import lattice_eigenvalues

    ell = 0.3
    lat = tps.Lattice.planar(n_nodes=3, length=1.0)
    ref = SoftFlatOrbit(G, M, E, ell)
    s = ref.t_exit + 0.5 * ref.flight
    w, z = ref.state(s)
    guess = (np.full(3, float(w)) + 1e-4 * np.array([1.0, -1.0, 0.5]), np.full(3, float(z)))
    orb = find_periodic_orbit(lat, Gamma=G, M=M, e=E, cutoff=ell, guess=guess, t_start=s, section="fixed")
    assert orb.converged and orb.method == "soft", orb.message
    assert np.max(np.abs(orb.w0 - w)) < 1e-6 and np.max(np.abs(orb.zeta0 - z)) < 1e-6
    assert orb.contacts_per_node.tolist() == [1, 1, 1]
    mono = ref.monodromy(lattice_eigenvalues(lat), t_section=s)
    want = np.concatenate([np.linalg.eigvals(Mk) for Mk in mono])
    want = want[np.argsort(-np.abs(want))]
    assert orb.multipliers.size == 6
    assert orb.differentiable is None                   # smooth by construction, not tested
    dist = np.abs(orb.multipliers[:, None] - want[None, :])
    assert max(dist.min(axis=0).max(), dist.min(axis=1).max()) < 1e-3


def test_point_method_gives_the_exact_cycle_too():
    coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    orb = find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=cyc, method="point")
    assert orb.converged and orb.residual <= 1e-11
    assert abs(abs(orb.multipliers[0]) - 0.457175) < 1e-5


def test_soft_flat_multipliers_match_the_closed_form_monodromy():
    """Acceptance: soft-contact multipliers of a flat lattice within 1e-8 of the closed form."""
    from validation.shooting import soft_flat_multipliers

    rows = soft_flat_multipliers()
    assert [r["kind"] for r in rows] == ["full period map", "all (exact)"]
    assert max(r["error"] for r in rows) <= 1e-8


def test_orbit_sampling_accepts_repeated_and_unsorted_times():
    """``height``/``velocity`` at times with repeats (and one period apart) return one row per time."""
    coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    orb = tps.find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=cyc, multipliers=False)
    t = orb.t_start + np.array([3.0, 1.0, 3.0, 1.0 + orb.period])
    z = orb.height(t)
    assert z.shape == (4, 8)
    assert np.array_equal(z[0], z[2]) and np.max(np.abs(z[1] - z[3])) < 1e-12
    assert np.max(np.abs(orb.velocity(t[:2])[0] - orb.velocity(t[:1])[0])) == 0.0


@pytest.mark.slow
def test_section_choice_survives_a_grid_time_on_a_soft_switch():
    """The 200-node soft kink at spacing 12 after 10 periods: a sample of the 512-point section grid
    falls on a switch to round-off and the soft contact search stalls there; the second grid works."""
    from validation.soft_kinks import benchmark

    row = benchmark(dx=12.0, periods=10)
    assert row["converged"] and row["residual"] <= 1e-10
