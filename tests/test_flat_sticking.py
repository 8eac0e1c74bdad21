"""FlatLayer orbits with sticking, touch-and-go and chatter contacts.

References (``validation/flat_sticking.py``) share no code with
``tps_solver.model.sticking``: an mpmath ball (30 digits for e = 0, 50 with chatter)
on the paper's first form of (18), landings by dense sampling + a bracketing
solver, chatter followed bounce by bounce down to 1e-18, and QUADPACK for the
Fourier coefficients.
"""
import math

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

import tps_solver as tps
from tps_solver.model import sticking
from validation.flat_sticking import (measure, quad_harmonics, reference_height, reference_orbit,
                                      reference_touch_landings, reference_velocity)

SQRT_PI2_4 = math.sqrt(math.pi ** 2 + 4.0)


def g(t, G):
    return math.sin(t) - 1.0 / G


# ----------------------------------------------------------------------------- acceptance

@pytest.mark.parametrize("Gamma, e", [(3.9, 0.0), (4.1, 0.0), (4.4, 0.0), (4.4, 0.1)])
def test_against_mpmath_ball(Gamma, e):
    r = measure(Gamma, e, M=2, N=16 if e == 0 else 8, n_samples=801)
    assert r["pattern"] == "stick"
    assert r["event_err"] <= 1e-12
    assert r["height_err"] <= 1e-12
    assert r["velocity_err"] <= 1e-12
    assert r["harmonics_err"] <= 1e-13
    assert np.all(r["multipliers"] == 0)
    if e == 0.0:
        assert r["sequence"] == "TS"
    else:
        assert r["sequence"] == "BC" and r["chatter_bound"] <= 1e-14


@pytest.mark.parametrize("Gamma", [3.9, 4.1, 4.4])
def test_default_pattern_for_e0_is_the_sticking_orbit(Gamma):
    fl = tps.FlatLayer(Gamma=Gamma, M=2, e=0.0)
    assert fl.pattern == "stick" and fl.is_stable and fl.branch == "stable"
    assert fl.t0 == pytest.approx(math.asin(1 / Gamma), abs=0) and fl.W0 == 0.0
    assert fl.period == 4 * math.pi
    kinds = [k for _, k in fl.events]
    assert kinds == ["liftoff", "impact", "liftoff", "impact", "stick"]
    (tl, _), (t1, _), _, (t2, _), _ = fl.events
    assert tl == fl.t0 and fl.t0 < t1 < t2 < fl.t0 + fl.period
    assert g(t1, Gamma) > 0 > g(t2, Gamma)            # touch-and-go, then stick
    assert math.cos(fl.t0) > 0 and g(fl.t0, Gamma) == pytest.approx(0, abs=1e-16)
    # at and around the events: zeta = 0, w = 0 after each contact, w < 0 just before
    for t in (t1, t2):
        assert abs(float(fl.height(t))) <= 1e-13 and float(fl.velocity(t)) == 0.0
        assert float(fl.velocity(t - 1e-6)) < -0.5
    # stuck until the lift-off, then T-periodic
    ts = np.linspace(t2, fl.t0 + fl.period, 7)[1:-1]
    assert np.all(fl.height(ts) == 0) and np.all(fl.velocity(ts) == 0)
    tt = np.linspace(0, 13, 30).reshape(3, 10)
    np.testing.assert_allclose(fl.height(tt + 3 * fl.period), fl.height(tt), atol=1e-12)
    assert fl.height(tt).shape == tt.shape and np.all(fl.height(tt) >= 0)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(Gamma=st.floats(3.86, 6.36))
def test_sticking_orbit_events_match_reference_across_the_interval(Gamma):
    """Anywhere inside the measured e = 0 interval [3.8569, 6.3623] the orbit exists and matches."""
    fl = tps.FlatLayer(Gamma, 2, e=0.0)
    assert fl.pattern == "stick" and fl.contact_sequence in ("TS", "S")
    ev, _ = reference_orbit(Gamma, 0.0, 2)
    assert [k for _, k in ev[:-1]] == [k for _, k in fl.events]
    assert max(abs(float(a) - b) for (a, _), (b, _) in zip(ev, fl.events)) <= 1e-12
    assert float(ev[-1][0]) == pytest.approx(fl.t0 + fl.period, abs=1e-12)
    c = fl.harmonics(5)
    np.testing.assert_allclose(c[::-1], np.conj(c), rtol=0, atol=1e-16)   # w is real
    assert abs(c[5]) <= 1e-15                                            # zero mean: w = dzeta/dt


def test_stick_multipliers_vanish_period_map_is_locally_constant():
    """Perturbed lift-off states (reference integrator) all return to the same lift-off."""
    G = 4.1
    fl = tps.FlatLayer(G, 2, e=0.0)
    for t_start, v_start in [(fl.t0 + 1e-4, 0.0), (fl.t0, 1e-4), (fl.t0 - 1e-3, 3e-3)]:
        ev, _ = reference_orbit(G, 0.0, 2, t_start=t_start, v_start=v_start)
        assert [k for _, k in ev] == ["liftoff", "impact", "liftoff", "impact", "stick", "liftoff"]
        assert float(ev[-1][0]) == pytest.approx(fl.t0 + fl.period, abs=1e-13)
    np.testing.assert_array_equal(fl.floquet_multipliers(), [0, 0])


# ----------------------------------------------------------------------------- chatter (e > 0)

def test_chatter_tail_bound_holds_and_is_not_vacuous():
    G, e = 4.4, 0.1
    ev_ref, flights = reference_orbit(G, e, 2)
    t_stick_ref = float([t for t, k in ev_ref if k == "stick"][0])
    t0 = math.asin(1 / G)
    for tol in (1e-6, 1e-9, 1e-14):
        segs, ev, end = sticking.trace(G, e, t0, 0.0, t0 + 4 * math.pi, tail_tol=tol)
        tail = [s for s in segs if s[0] == "tail"][0]
        err, bound = abs(end[1] - t_stick_ref), tail[3][3]
        assert end[0] == "stick" and bound <= tol
        assert err <= bound + 1e-14
        if tol >= 1e-9:
            assert err >= 1e-3 * bound        # the bound is within 3 decades of the truth
    fl = tps.FlatLayer(G, 2, e=e, pattern="stick")
    assert fl.events[-1][1] == "stick" and fl.chatter_error <= 1e-14
    # inside the summed tail: velocity and height of the constant-g chatter vs the resolved reference
    (_, a, b, (v, gam, _, _)) = [s for s in fl._orbit.segments if s[0] == "tail"][0]
    t = np.linspace(a, b, 41)[1:-1]
    hits = np.array([float(x) for x, k in ev_ref if k == "impact"])
    t = t[np.min(np.abs(t[:, None] - hits[None, :]), axis=1) > 1e-13]   # away from the jumps
    assert t.size > 30
    wr = np.array([float(x) for x in reference_velocity(flights, G, t)])
    zr = np.array([float(x) for x in reference_height(flights, G, t)])
    assert np.max(np.abs(wr)) > 0.1 * v and np.max(zr) > 0.01 * v * v / gam
    assert np.max(np.abs(fl.velocity(t) - wr)) <= 1e-5 * v
    assert np.max(np.abs(fl.height(t) - zr)) <= 1e-4 * v * v / gam
    assert fl.contact_sequence == "BC"     # one rebound, then a chatter sequence to rest
    impacts = [t for t, k in fl.events if k == "impact"]
    assert g(impacts[0], G) > 0 and all(g(t, G) < 0 for t in impacts[1:])


def test_auto_with_e_positive_falls_back_to_the_orbit_that_exists():
    # no single-bounce orbit at (4.4, 0.1): auto takes the sticking orbit that patterns() lists
    # (it raised here before), and .pattern says which it chose; pattern="bounce" still raises
    assert tps.FlatLayer.patterns(4.4, 2, 0.1)["stick"][0]
    fl = tps.FlatLayer(4.4, 2, e=0.1)
    assert fl.pattern == "stick" and fl.t0 == tps.FlatLayer(4.4, 2, e=0.1, pattern="stick").t0
    with pytest.raises(ValueError, match=r"Gamma is too small.*patterns that exist.*'stick'"):
        tps.FlatLayer(4.4, 2, e=0.1, pattern="bounce")
    fl = tps.FlatLayer(2.5, e=0.45)          # M defaults to 2; the bounce orbit as before
    assert fl.M == 2 and fl.pattern == "bounce" and fl.events == [(fl.t0, "impact")]
    assert fl.contact_sequence == "B"
    ref = tps.FlatLayer(2.5, 2, e=0.45)
    assert (fl.t0, fl.W0) == (ref.t0, ref.W0)
    np.testing.assert_array_equal(fl.harmonics(8), ref.harmonics(8))


# ----------------------------------------------------------------------------- touch-and-go orbits

def test_touch_orbit_against_reference_and_finite_differences():
    G = 3.8
    fl = tps.FlatLayer(G, 2, e=0.0)                  # no bounce, no stick: the stable touch orbit
    assert fl.pattern == "touch" and fl.contact_sequence == "TT"
    contacts = [t for t, k in fl.events if k == "liftoff"]
    assert len(contacts) == 2 and all(g(t, G) > 0 for t in contacts)
    with mp.workdps(30):
        L = reference_touch_landings(G, fl.t0, 2)
        assert float(L[0]) == pytest.approx(contacts[1], abs=1e-12)
        assert float(L[1]) == pytest.approx(fl.t0 + fl.period, abs=1e-12)
        h = mp.mpf("1e-7")
        dL = (reference_touch_landings(G, fl.t0 + h, 2)[1]
              - reference_touch_landings(G, fl.t0 - h, 2)[1]) / (2 * h)
    mu = fl.floquet_multipliers()
    assert mu[1] == 0 and abs(mu[0].imag) == 0
    assert mu[0].real == pytest.approx(float(dL), abs=1e-8)
    assert fl.is_stable == (abs(mu[0]) < 1) and fl.is_stable
    # harmonics: closed form vs QUADPACK on the reference flights
    flights = [(fl.t0, contacts[1], 0.0), (contacts[1], fl.t0 + fl.period, 0.0)]
    np.testing.assert_allclose(fl.harmonics(12), quad_harmonics(flights, G, 2, 12), rtol=0, atol=1e-13)


def test_sqrt_pi2_plus_4_is_where_the_period_two_touch_orbit_is_born():
    """The M = 1 touch-and-go orbit has multiplier 1 - Gamma sin t0 = -1 at sqrt(pi^2 + 4)."""
    for side, stable in [(1 - 1e-6, True), (1 + 1e-6, False)]:
        G = SQRT_PI2_4 * side
        (orb,) = sticking.touch_orbits(G, 1)
        t0 = math.acos(math.pi / G)                 # (19) with e = 0, M = 1
        assert orb.t0 == pytest.approx(t0, abs=1e-9)
        assert orb.multipliers[0].real == pytest.approx(1 - G * math.sin(t0), abs=1e-8)
        assert (abs(orb.multipliers[0]) < 1) == stable
    assert sticking.touch_orbits(SQRT_PI2_4 * (1 - 1e-3), 2) == []
    (orb2,) = sticking.touch_orbits(SQRT_PI2_4 * (1 + 1e-3), 2)
    assert 0.9 < abs(orb2.multipliers[0]) < 1.0        # born at multiplier 1 from the flip


# ----------------------------------------------------------------------------- harmonics

def test_height_harmonics_against_quadrature():
    fl = tps.FlatLayer(4.1, 2, e=0.0)
    N, T = 6, fl.period
    z = fl.height_harmonics(N)
    (tl, _), (t1, _), _, (t2, _), _ = fl.events
    for j, n in enumerate(range(-N, N + 1)):
        nu = n / 2
        val = 0.0
        for a, b in [(tl, t1), (t1, t2)]:
            val += integrate.quad(lambda t: float(fl.height(t)) * math.cos(nu * t), a, b,
                                  epsabs=1e-13, epsrel=1e-13)[0]
            val -= 1j * integrate.quad(lambda t: float(fl.height(t)) * math.sin(nu * t), a, b,
                                       epsabs=1e-13, epsrel=1e-13)[0]
        assert abs(z[j] - val / T) <= 1e-13
    # the velocity harmonics are i n alpha times the height harmonics (zeta is continuous)
    w = fl.harmonics(N)
    n = np.arange(-N, N + 1)
    np.testing.assert_allclose(w, 1j * n / 2 * z, rtol=0, atol=1e-14)


# ----------------------------------------------------------------------------- bad input

def test_pattern_that_does_not_exist():
    with pytest.raises(ValueError, match=r"pattern='stick' does not exist.*period 2\*pi\*5.*'bounce'"):
        tps.FlatLayer(2.5, 2, e=0.45, pattern="stick")
    with pytest.raises(ValueError, match=r"pattern='touch' does not exist.*e = 0"):
        tps.FlatLayer(4.4, 2, e=0.1, pattern="touch")
    with pytest.raises(ValueError, match=r"Gamma is too small.*patterns that exist.*'stick'"):
        tps.FlatLayer(4.1, 2, e=0.0, pattern="bounce")
    with pytest.raises(ValueError, match=r"does not lift off.*patterns that exist"):
        tps.FlatLayer(20.0, 2, e=0.0)
    with pytest.raises(ValueError, match=r"^pattern must be one of"):
        tps.FlatLayer(4.1, 2, e=0.0, pattern="sticking")
    with pytest.raises(ValueError, match=r"^t0 can only be given"):
        tps.FlatLayer(4.1, 2, t0=0.2, pattern="stick")


@pytest.mark.parametrize("kwargs, name", [
    (dict(Gamma=4.1, M=2, e=-0.1, pattern="stick"), "e"),
    (dict(Gamma=4.1, M=2, e=-0.1), "e"),
    (dict(Gamma=4.1, M=2.5, e=0.0), "M"),
    (dict(Gamma=4.1, M=0.0, e=0.0), "M"),
    (dict(Gamma=4.1, M=math.nan, e=0.0), "M"),
    (dict(Gamma=-4.1, M=2, e=0.0, pattern="stick"), "Gamma"),
])
def test_bad_input(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name} "):
        tps.FlatLayer(**kwargs)


def test_integral_float_M():
    a = tps.FlatLayer(4.1, 2.0, e=0.0)
    b = tps.FlatLayer(4.1, np.float64(2), e=0.0)
    assert a.M == b.M == 2 and isinstance(a.M, int) and a.events == b.events


def test_impact_map_jacobian_needs_a_point_for_contact_patterns():
    fl = tps.FlatLayer(4.1, 2, e=0.0)
    with pytest.raises(ValueError, match="^t and v must be given"):
        fl.impact_map_jacobian()


def test_patterns_table():
    t = tps.FlatLayer.patterns(4.1, 2, e=0.0)
    assert t["stick"] == (True, ["stable"]) and not t["bounce"][0] and not t["touch"][0]
    t = tps.FlatLayer.patterns(2.5, 2, e=0.45)
    assert t["bounce"] == (True, ["stable", "unstable"])
    assert t["stick"] == (False, "the sticking orbit has period 2*pi*5 (M = 5)")
    assert tps.FlatLayer.patterns(3.8, 2, e=0.0)["touch"] == (True, ["stable"])
    # every pattern the table reports can be constructed, with the stated branch
    for pat, (ok, info) in tps.FlatLayer.patterns(20.0, 2, e=0.0).items():
        if ok:
            assert tps.FlatLayer(20.0, 2, e=0.0, pattern=pat, branch=info[0]).pattern == pat
    with pytest.raises(ValueError, match="^e "):
        tps.FlatLayer.patterns(4.1, 2, e=-0.5)
