"""Acceptance tests of FlatLayer, eqs. (17)-(19).

References are independent of ``tps_solver.model.flat``'s code paths (see
``validation/flat_layer_analytics.py``): the paper's first form of (18), an ODE
integration of the flight, QUADPACK, dense sampling + a local minimiser, central
differences and a bisection on the multiplier modulus.
"""
import math

import mpmath
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st
from scipy import integrate

from tps_solver.model.flat import FlatLayer
from validation.flat_layer_analytics import (
    JACOBIAN_CASES, fd_jacobian, interior_min_height, ode_impact_map, paper_flight,
    upper_end_by_bisection,
)

EPS = np.finfo(float).eps

# ----------------------------------------------------------------------------- strategies

admissible_draw = dict(
    e=st.floats(0.05, 0.95),
    M=st.sampled_from([1, 2, 3, 4]),
    frac=st.floats(1e-6, 1.5),
    branch=st.sampled_from(["stable", "unstable"]),
)


def _draw_layer(e, M, frac, branch):
    """Gamma = low + frac (high - low) from the stability window; skip inadmissible draws."""
    low, high = FlatLayer.stability_window(e, M)
    Gamma = low + frac * (high - low)
    try:
        return FlatLayer(Gamma, M, e=e, branch=branch)
    except ValueError:
        assume(False)


# ----------------------------------------------------------------------------- orbit identities

@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(**admissible_draw)
def test_orbit_identities(e, M, frac, branch):
    fl = _draw_layer(e, M, frac, branch)
    T, G, t0, W0 = fl.period, fl.Gamma, fl.t0, fl.W0
    assert T == 2 * math.pi * M
    zscale = T * T / G + 1.0          # magnitude of zeta and of its terms
    wscale = T / G + 1.0              # magnitude of W

    # (19): s = 2 Gamma cos t0 / T = (1-e)/(1+e) and W(t0+) = (1-s)/s cos t0
    s = 2.0 * G * math.cos(t0) / T
    assert s == pytest.approx((1 - e) / (1 + e), rel=1e-13)
    assert W0 == pytest.approx((1 - s) / s * math.cos(t0), rel=1e-12, abs=1e-14)
    assert (t0 >= 0) == (branch == "stable")

    # the paper's first form of (18) closes after one period: zeta(t0 + T) = 0
    W_end, z_end = paper_flight(t0 + T, t0, W0, G)
    assert abs(z_end) <= 64 * EPS * zscale
    # restitution W(t0+) = -e W(t0+T-)
    assert W_end == pytest.approx(fl.impact_velocity, rel=1e-13)
    assert -e * W_end == pytest.approx(W0, rel=1e-12, abs=64 * EPS * wscale)
    # ... and the left limit of FlatLayer.velocity at t0 + T is that pre-impact value
    assert float(fl.velocity(t0 + T - 1e-7)) == pytest.approx(W_end, abs=1e-6 * wscale)
    assert float(fl.velocity(t0)) == W0                      # post-impact at the contact instant

    # zeta(t0) = 0, also at other contact instants
    assert abs(float(fl.height(t0))) <= 4 * EPS * zscale
    for k in (-2, -1, 1, 3):
        assert abs(float(fl.height(t0 + k * T))) <= 64 * EPS * zscale * (1 + abs(k))

    # FlatLayer agrees with the paper's first form on the open period (second form in the code)
    t = t0 + T * np.linspace(0.0, 1.0, 101)[1:-1]
    W_ref, z_ref = paper_flight(t, t0, W0, G)
    np.testing.assert_allclose(fl.velocity(t), W_ref, rtol=0, atol=64 * EPS * wscale)
    np.testing.assert_allclose(fl.height(t), z_ref, rtol=0, atol=64 * EPS * zscale)

    # T-periodicity of the continuation, away from the jumps
    for k in (-1, 1, 2):
        np.testing.assert_allclose(fl.velocity(t + k * T), fl.velocity(t), rtol=0, atol=1e-12 * wscale)
        np.testing.assert_allclose(fl.height(t + k * T), fl.height(t), rtol=0, atol=1e-12 * zscale)

    # mean of W over a period vanishes (the n = 0 balance); quadrature of the paper's W
    mean, err = integrate.quad(lambda u: float(paper_flight(u, t0, W0, G)[0]), t0, t0 + T,
                               epsabs=1e-13 * T * wscale, epsrel=1e-13)
    assert abs(mean) / T <= 1e-12 * wscale
    # ... and of FlatLayer.velocity itself (wraps at the jump)
    mean2 = integrate.quad(fl.velocity, t0 - 0.3 * T, t0 + 0.7 * T, points=[t0],
                           epsabs=1e-12 * T * wscale, epsrel=1e-12)[0]
    assert abs(mean2) / T <= 1e-11 * wscale

    # admissible => zeta > 0 on the open period (independent dense sampling + minimiser)
    _, zmin = interior_min_height(G, t0, W0, T, n_samples=4001)
    assert zmin > 0.0


def test_mean_height_is_zero_mode(flat_factory):
    fl = flat_factory()
    T = fl.period
    mean = integrate.quad(lambda u: float(paper_flight(u, fl.t0, fl.W0, fl.Gamma)[1]),
                          fl.t0, fl.t0 + T, epsabs=1e-13, epsrel=1e-13)[0] / T
    assert fl.height_harmonics(3)[3].real == pytest.approx(mean, rel=1e-13)
    assert mean == pytest.approx(T * T / (12 * fl.Gamma) + math.sin(fl.t0), rel=1e-13)


def test_peak_height_and_impact_velocity(flat_factory):
    fl = flat_factory()
    # peak at the interior zero of W (independent: bounded maximisation of the paper's zeta)
    from scipy.optimize import minimize_scalar
    res = minimize_scalar(lambda u: -float(paper_flight(u, fl.t0, fl.W0, fl.Gamma)[1]),
                          bounds=(fl.t0, fl.t0 + fl.period), method="bounded", options={"xatol": 1e-12})
    assert fl.peak_height == pytest.approx(-res.fun, rel=1e-12)
    assert fl.impact_velocity == pytest.approx(-fl.W0 / fl.e, rel=1e-13)


@pytest.mark.parametrize("k", [1, 2, -1])
@pytest.mark.parametrize("args", [(2.5, 2, 0.45, "stable"), (2.5, 2, 0.45, "unstable"), (1.9, 1, 0.3, "stable")])
def test_velocity_post_impact_at_contact_instants(args, k):
    G, M, e, branch = args
    fl = FlatLayer(G, M, e=e, branch=branch)
    assert float(fl.velocity(fl.t0 + k * fl.period)) == pytest.approx(fl.W0, rel=1e-12)


@pytest.mark.parametrize("args, k", [
    ((2.1972030563843026, 3, 0.6232655185893089), 5),
    ((1.61907672819211, 3, 0.7428112037297729), 3),
])
def test_velocity_post_impact_after_rounding(args, k):
    G, M, e = args
    fl = FlatLayer(G, M, e=e)
    assert float(fl.velocity(fl.t0 + k * fl.period)) == pytest.approx(fl.W0, rel=1e-12)


def test_t0_constructor_roundtrip(flat_factory):
    fl = flat_factory(Gamma=2.5, M=2, e=0.45, branch="unstable")
    again = FlatLayer(2.5, 2, t0=fl.t0)
    assert again.e == pytest.approx(0.45, rel=1e-14)
    assert again.branch == "unstable"
    both = FlatLayer(2.5, 2, e=0.45, t0=fl.t0)           # consistent e and t0 are accepted
    assert both.t0 == fl.t0
    wrapped = FlatLayer(2.5, 2, t0=fl.t0 + 2 * math.pi)  # t0 is wrapped into (-pi, pi]
    assert wrapped.t0 == pytest.approx(fl.t0, abs=1e-14)


# ----------------------------------------------------------------------------- presets

def test_interior_preset_is_stable_complex_pair(flat_factory):
    fl = flat_factory(Gamma=2.5, M=2, e=0.45)
    mu = fl.floquet_multipliers()
    assert fl.is_stable
    np.testing.assert_allclose(np.abs(mu), [0.45, 0.45], rtol=1e-13)   # |mu|^2 = det J = e^2
    assert abs(mu[0].imag) > 0.1 and mu[0] == pytest.approx(np.conj(mu[1]), abs=1e-15)
    # the saddle at the same parameters
    assert not flat_factory(Gamma=2.5, M=2, e=0.45, branch="unstable").is_stable


def test_paper_preset_sits_at_the_fold(flat_factory):
    """The paper's far-field preset t0 = 0, Gamma = 2.5, M = 2 (Sec. 6) gives, by (19),
    s = 2 Gamma / T = 5 / (4 pi), e = (1-s)/(1+s) = 0.43073..., and cos t0 = 1 is the fold
    of the flat orbit: the two branches t0 = +-arccos(sT/2Gamma) merge and one Floquet
    multiplier equals +1 (the other is det J / 1 = e^2).  The preset is therefore only
    marginally stable; e = 0.45 is the interior stable choice (hazard 6 of docs/design.md)."""
    fl = flat_factory(Gamma=2.5, M=2, t0=0.0)
    mpmath.mp.dps = 30
    s = mpmath.mpf(5) / (4 * mpmath.pi)
    assert fl.e == pytest.approx(float((1 - s) / (1 + s)), rel=1e-15)
    assert round(fl.e, 4) == 0.4307
    mu = fl.floquet_multipliers()
    assert mu[0] == pytest.approx(1.0, abs=1e-12)
    assert mu[1] == pytest.approx(fl.e ** 2, rel=1e-12)
    # e fixed at the preset's value: Gamma = 2.5 is the lower end of the stability window
    assert FlatLayer.stability_window(fl.e, 2)[0] == pytest.approx(2.5, rel=1e-14)


# ----------------------------------------------------------------------------- impact map

@pytest.mark.parametrize("Gamma, M, e, branch", JACOBIAN_CASES)
def test_jacobian_matches_central_differences(Gamma, M, e, branch):
    fl = FlatLayer(Gamma, M, e=e, branch=branch)
    for t, v in ((fl.t0, fl.W0), (fl.t0 + 0.01, 1.02 * fl.W0)):
        J = fl.impact_map_jacobian(t, v)
        Jfd = fd_jacobian(fl, t, v, h=1e-6)
        assert np.max(np.abs(J - Jfd)) <= 1e-7 * np.max(np.abs(J))
    # det J = e^2 on the periodic orbit ...
    assert np.linalg.det(fl.impact_map_jacobian()) == pytest.approx(e * e, abs=1e-10)
    # ... and det = -e v / W(t'-) off it (checked with the FD Jacobian and the paper's W)
    t, v = fl.t0 + 0.01, 1.02 * fl.W0
    t_next, _ = fl.impact_map(t, v)
    u = float(paper_flight(t_next, t, v, Gamma)[0])
    assert np.linalg.det(fd_jacobian(fl, t, v)) == pytest.approx(-e * v / u, rel=1e-7)


@pytest.mark.parametrize("Gamma, M, e, branch", JACOBIAN_CASES[::2] + JACOBIAN_CASES[1::4])
def test_impact_map_matches_ode_integration(Gamma, M, e, branch):
    fl = FlatLayer(Gamma, M, e=e, branch=branch)
    t_next, v_next = fl.impact_map(fl.t0, fl.W0)
    assert t_next == pytest.approx(fl.t0 + fl.period, abs=1e-12 * fl.period)
    assert v_next == pytest.approx(fl.W0, rel=1e-11)
    t, v = fl.t0 + 0.05, 0.9 * fl.W0
    ref = ode_impact_map(Gamma, e, t, v, 4 * fl.period)
    np.testing.assert_allclose(fl.impact_map(t, v), ref, rtol=0, atol=1e-9)


def _phase_error(fl, t, v, k):
    return math.hypot(t - (fl.t0 + k * fl.period), v - fl.W0)


def test_iterated_map_converges_on_stable_branch(flat_factory):
    fl = flat_factory(Gamma=2.5, M=2, e=0.45)
    t, v = fl.t0 + 1e-4, fl.W0 * (1 - 1e-4)
    d0 = _phase_error(fl, t, v, 0)
    for _ in range(30):
        t, v = fl.impact_map(t, v)
    d30 = _phase_error(fl, t, v, 30)
    # |mu| = 0.45 for the complex pair: the distance shrinks like 0.45^k up to a bounded factor
    rate = (d30 / d0) ** (1 / 30)
    assert rate == pytest.approx(0.45, rel=0.1)


def test_iterated_map_departs_on_unstable_branch(flat_factory):
    fl = flat_factory(Gamma=2.5, M=2, e=0.45, branch="unstable")
    mu_max = fl.floquet_multipliers()[0].real
    t, v = fl.t0 + 1e-10, fl.W0 + 1e-10
    d = [_phase_error(fl, t, v, 0)]
    for k in range(1, 9):
        t, v = fl.impact_map(t, v)
        d.append(_phase_error(fl, t, v, k))
    assert d[-1] > 100 * d[0]
    # after the transient, the growth per period is the unstable multiplier 2.7153
    assert d[-1] / d[-2] == pytest.approx(mu_max, rel=1e-3)


# ----------------------------------------------------------------------------- stability window

@pytest.mark.parametrize("e, M", [(0.45, 1), (0.45, 2), (0.45, 4), (0.2, 3), (0.8, 1)])
def test_stability_window_endpoints(e, M):
    low, high = FlatLayer.stability_window(e, M)
    # upper end: independent bisection on max |mu| = 1 reproduces the trace criterion
    assert upper_end_by_bisection(e, M) == pytest.approx(high, rel=1e-10)
    # ... and the critical multiplier there is -1 (period doubling)
    for side in (1 - 1e-9, 1 + 1e-9):
        mu = FlatLayer(high * side, M, e=e).floquet_multipliers()[0]
        assert abs(mu.imag) == 0.0 and mu.real == pytest.approx(-1.0, abs=1e-6)
    assert FlatLayer(high * (1 - 1e-7), M, e=e).is_stable
    assert not FlatLayer(high * (1 + 1e-7), M, e=e).is_stable
    # lower end = the fold s pi M: no orbit below, a multiplier -> +1 like sqrt(Gamma - low) above
    s = (1 - e) / (1 + e)
    assert low == pytest.approx(s * math.pi * M, rel=1e-15)
    with pytest.raises(ValueError, match="Gamma"):      # the single-bounce orbit (auto falls back)
        FlatLayer(low * (1 - 1e-9), M, e=e, pattern="bounce")
    deltas = np.array([1e-6, 1e-8, 1e-10])
    gaps = []
    for d in deltas:
        mu = FlatLayer(low * (1 + d), M, e=e).floquet_multipliers()
        assert mu[0].imag == 0.0 and 0.0 < mu[0].real < 1.0
        gaps.append(1.0 - mu[0].real)
        mu_saddle = FlatLayer(low * (1 + d), M, e=e, branch="unstable").floquet_multipliers()[0]
        assert mu_saddle.real > 1.0 and mu_saddle.real - 1.0 == pytest.approx(gaps[-1], rel=0.05)
    slope = np.polyfit(np.log(deltas), np.log(gaps), 1)[0]
    assert slope == pytest.approx(0.5, abs=0.01)
    assert gaps[-1] < 1e-3
    # the interior of the window is stable
    for frac in (0.01, 0.5, 0.99):
        assert FlatLayer(low + frac * (high - low), M, e=e).is_stable


# ----------------------------------------------------------------------------- admissibility

INADMISSIBLE = [
    # (Gamma, M, e, branch): (19) has a solution but the flight dips below the plate
    (2.6, 1, 0.45, "unstable"),
    (3.0, 1, 0.2, "unstable"),
    (6.74, 2, 0.45, "unstable"),
    (10.0, 2, 0.3, "unstable"),
]


@pytest.mark.parametrize("Gamma, M, e, branch", INADMISSIBLE)
def test_early_touch_is_rejected(Gamma, M, e, branch):
    T = 2 * math.pi * M
    s = (1 - e) / (1 + e)
    c = s * T / (2 * Gamma)
    assert c <= 1                                    # (19) has a solution ...
    t0 = -math.acos(c) if branch == "unstable" else math.acos(c)
    W0 = T / (2 * Gamma) - c
    t_min, z_min = interior_min_height(Gamma, t0, W0, T)
    assert z_min < -1e-3 and t0 < t_min < t0 + T    # ... but zeta < 0 inside the period
    with pytest.raises(ValueError, match="touches the plate"):
        FlatLayer(Gamma, M, e=e, branch=branch)
    # the other branch at the same parameters is admissible (constructing it must not raise)
    FlatLayer(Gamma, M, e=e, branch="stable" if branch == "unstable" else "unstable")


def test_stable_branch_inadmissible_only_for_sticking_e0():
    """Scanning M in {1, 2}, e in [0.05, 0.95], Gamma up to 60 found no early touch on the
    stable branch; e = 0 (no lift-off) is rejected with a sticking message."""
    with pytest.raises(ValueError, match="does not lift off"):
        FlatLayer(20.0, 2, e=0.0)


@pytest.mark.parametrize("side, admissible", [(1 - 1e-6, True), (1 + 1e-6, False)])
def test_admissibility_near_tangency(side, admissible):
    """Near the Gamma where the saddle orbit first grazes the plate, the interior minimum of
    zeta is O(1e-6) deep and only a few 1e-3 wide: a coarse grid would miss it."""
    from scipy.optimize import brentq
    M, e = 1, 0.45

    def zmin(G):
        T = 2 * math.pi * M
        c = (1 - e) / (1 + e) * T / (2 * G)
        t0 = -math.acos(c)
        return interior_min_height(G, t0, T / (2 * G) - c, T)[1]

    Gc = brentq(zmin, 2.3, 2.6, xtol=1e-14)
    assert zmin(Gc * side) > 0 if admissible else zmin(Gc * side) < 0
    if admissible:
        FlatLayer(Gc * side, M, e=e, branch="unstable")
    else:
        with pytest.raises(ValueError, match="touches the plate"):
            FlatLayer(Gc * side, M, e=e, branch="unstable")


@settings(max_examples=150, deadline=None)
@given(e=st.floats(0.02, 0.95), M=st.sampled_from([1, 2]), Gamma=st.floats(0.2, 30.0),
       branch=st.sampled_from(["stable", "unstable"]))
def test_admissibility_verdict_matches_dense_sampling(e, M, Gamma, branch):
    T = 2 * math.pi * M
    c = (1 - e) / (1 + e) * T / (2 * Gamma)
    if c > 1:
        event("no orbit")
        with pytest.raises(ValueError, match="Gamma"):
            FlatLayer(Gamma, M, e=e, branch=branch, pattern="bounce")
        return
    t0 = math.acos(c) if branch == "stable" else -math.acos(c)
    W0 = T / (2 * Gamma) - c
    z_min = interior_min_height(Gamma, t0, W0, T, n_samples=4001)[1]
    assume(abs(z_min) > 1e-9)           # skip grazing draws, decided by round-off
    event("admissible" if z_min > 0 else "touches")
    if z_min > 0:
        FlatLayer(Gamma, M, e=e, branch=branch)
    else:
        with pytest.raises(ValueError, match="touches the plate"):
            FlatLayer(Gamma, M, e=e, branch=branch, pattern="bounce")


# ----------------------------------------------------------------------------- bad input

BAD_INPUTS = [
    # (kwargs, parameter named in the message)
    (dict(Gamma=0.0, M=2, e=0.45), "Gamma"),
    (dict(Gamma=-1.0, M=2, e=0.45), "Gamma"),
    (dict(Gamma=math.inf, M=2, e=0.45), "Gamma"),
    (dict(Gamma=math.nan, M=2, e=0.45), "Gamma"),
    (dict(Gamma="2.5", M=2, e=0.45), "Gamma"),
    (dict(Gamma=1.0, M=2, e=0.45), "Gamma"),                  # below the fold: no orbit
    (dict(Gamma=2.5, M=2, e=1.0), "e"),
    (dict(Gamma=2.5, M=2, e=-0.1), "e"),
    (dict(Gamma=2.5, M=2, e=math.nan), "e"),
    (dict(Gamma=2.5, M=2, e=math.inf), "e"),
    (dict(Gamma=2.5, M=0, e=0.45), "M"),
    (dict(Gamma=2.5, M=-1, e=0.45), "M"),
    (dict(Gamma=2.5, M=2.5, e=0.45), "M"),
    (dict(Gamma=2.5, M=True, e=0.45), "M"),
    (dict(Gamma=2.5, M="2", e=0.45), "M"),
    (dict(Gamma=2.5, M=2, t0=0.5 * math.pi + 0.1), "t0"),    # cos t0 < 0: e > 1
    (dict(Gamma=10.0, M=1, t0=0.0), "t0"),                    # s > 1: e < 0
    (dict(Gamma=2.5, M=2, t0=math.nan), "t0"),
    (dict(Gamma=2.5, M=2, t0=math.inf), "t0"),
    (dict(Gamma=2.5, M=2, e=0.45, t0=0.0), "e and t0"),       # inconsistent with (19)
    (dict(Gamma=2.5, M=2, e=0.45, branch="Stable"), "branch"),
    (dict(Gamma=2.5, M=2, e=0.45, branch=None), "branch"),
    (dict(Gamma=2.5, M=2, t0=0.0, branch="up"), "branch"),
    (dict(Gamma=2.5, M=2), "e or t0"),
]


@pytest.mark.parametrize("kwargs, name", BAD_INPUTS, ids=[f"{n}:{k}" for k, n in BAD_INPUTS])
def test_bad_constructor_input(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}\b|\b{name} (must|is)"):
        FlatLayer(**kwargs)


@pytest.mark.parametrize("t0", [0.5 * math.pi, -0.5 * math.pi])
def test_t0_at_quarter_period_gives_e_one(t0):
    with pytest.raises(ValueError, match="t0"):
        FlatLayer(2.5, 2, t0=t0)


@pytest.mark.parametrize("call, name", [
    (lambda fl: fl.harmonics(0), "N"),
    (lambda fl: fl.harmonics(-3), "N"),
    (lambda fl: fl.harmonics(2.5), "N"),
    (lambda fl: fl.height_harmonics(0), "N"),
    (lambda fl: fl.impact_map(math.nan, 1.0), "t"),
    (lambda fl: fl.impact_map(0.3, 0.0), "v"),
    (lambda fl: fl.impact_map(0.3, -1.0), "v"),
    (lambda fl: FlatLayer.stability_window(1.0, 2), "e"),
    (lambda fl: FlatLayer.stability_window(math.nan, 2), "e"),
    (lambda fl: FlatLayer.stability_window(0.0, 2), "e"),
    (lambda fl: FlatLayer.stability_window(0.45, 0), "M"),
    (lambda fl: FlatLayer.stability_window(0.45, 1.5), "M"),
])
def test_bad_method_input(flat_factory, call, name):
    with pytest.raises(ValueError, match=rf"^{name} "):
        call(flat_factory())
