"""Restitution laws (tps_solver.model.restitution) and the flat layer with a speed-dependent law.

References: the viscoelastic collision integrated directly (not the table), the first two
coefficients of its expansion (C1 in closed form, C2 = 3/5 C1^2), a one-ball DOP853 integration
of the flight with the law applied at each landing, central differences of the impact map, and
today's constant-e FlatLayer for the constant law.
"""
import math

import numpy as np
import pytest
from scipy import integrate

from tps_solver.model.flat import FlatLayer
from tps_solver.model.restitution import (
    CallableRestitution, ConstantRestitution, PowerLawRestitution, ViscoelasticRestitution, as_restitution,
    viscoelastic_c1, viscoelastic_restitution,
)
from validation.flat_layer_analytics import fd_jacobian

EPS = np.finfo(float).eps
VISCO = ViscoelasticRestitution.from_reference(e=0.45, v=4.5)
POWER = PowerLawRestitution(e0=0.3, v0=6.0)
LAWS = [VISCO, POWER, CallableRestitution(lambda v: 0.9 / (1.0 + 0.1 * v), lambda v: -0.09 / (1.0 + 0.1 * v) ** 2,
                                          name="hyperbolic")]


# ----------------------------------------------------------------------------- the laws
def test_viscoelastic_first_coefficient_is_ramirez_c1():
    # C1 = 4/5 (5/4)^(3/5) B(3/5, 3/2) = 1.15344 (Ramirez et al. 1999); the integrated collision
    # gives (1 - e)/kappa -> C1 with the next term C2 kappa, C2 = 3/5 C1^2
    c1 = viscoelastic_c1()
    assert c1 == pytest.approx(1.15344, abs=1e-5)
    k = np.array([1e-3, 2e-3, 4e-3])
    e = np.array([viscoelastic_restitution(x) for x in k])
    c2_est = (e - 1.0 + c1 * k) / k ** 2            # C2 + O(kappa^(1/2))
    # Richardson on the sqrt(kappa) term (the separation criterion's kappa^(5/2))
    r = math.sqrt(2.0)
    c2 = (r * c2_est[0] - c2_est[1]) / (r - 1.0)
    assert c2 == pytest.approx(0.6 * c1 ** 2, rel=2e-3)


@pytest.mark.parametrize("kappa", [0.0, 0.013, 0.37, 1.0, 4.2, 17.0, 24.9])
def test_viscoelastic_table_matches_direct_integration(kappa):
    law = ViscoelasticRestitution(b=1.0)
    v = kappa ** 5
    assert law(v) == pytest.approx(viscoelastic_restitution(kappa), abs=1e-11)


def test_viscoelastic_beyond_the_table_integrates():
    law = ViscoelasticRestitution(b=1.0)
    kappa = 30.0
    assert law(kappa ** 5) == pytest.approx(viscoelastic_restitution(kappa), abs=1e-14)


@pytest.mark.parametrize("law", LAWS + [ConstantRestitution(0.45)], ids=repr)
@pytest.mark.parametrize("v", [0.3, 2.0, 4.49, 7.5])
def test_derivative_against_central_differences(law, v):
    h = 1e-5 * v
    fd = (law(v + h) - law(v - h)) / (2.0 * h)
    assert law.derivative(v) == pytest.approx(fd, abs=1e-8)
    assert law.rebound_derivative(v) == pytest.approx(law(v) + v * law.derivative(v), abs=4 * EPS)


def test_viscoelastic_from_reference_and_monotone():
    assert VISCO(4.5) == pytest.approx(0.45, abs=1e-13)
    v = np.linspace(0.0, 50.0, 201)
    e = VISCO(v)
    assert e[0] == 1.0 and np.all(np.diff(e) < 0)
    assert VISCO.at(b=2 * VISCO.b).b == 2 * VISCO.b


def test_power_law_is_continuous_at_its_floor():
    assert POWER(6.0 * (1 - 1e-12)) == pytest.approx(0.3, abs=1e-11)
    assert POWER(6.0) == 0.3 and POWER(0.0) == 1.0
    assert POWER.derivative(7.0) == 0.0


@pytest.mark.parametrize("bad, match", [
    (lambda v: 1.2, "must give a finite e in"),
    (lambda v: -0.1, "must give a finite e in"),
    (lambda v: math.nan, "must give a finite e in"),
])
def test_invalid_law_values_raise(bad, match):
    law = CallableRestitution(bad, name="bad")
    with pytest.raises(ValueError, match=match):
        law(1.0)


@pytest.mark.parametrize("call, match", [
    (lambda: PowerLawRestitution(e0=1.0, v0=1.0), "e0 must be"),
    (lambda: PowerLawRestitution(e0=0.4, v0=0.0), "v0 must be"),
    (lambda: ViscoelasticRestitution(b=-1.0), "b must be"),
    (lambda: ViscoelasticRestitution.from_reference(e=1.0, v=1.0), "e must be"),
    (lambda: as_restitution(1.5), "e must be"),
    (lambda: as_restitution("x"), "RestitutionLaw"),
    (lambda: CallableRestitution(3.0), "func must be callable"),
    (lambda: VISCO(-1.0), "impact speed"),
    (lambda: VISCO.at(e0=0.1), "is not a parameter"),
])
def test_bad_arguments_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# ----------------------------------------------------------------------------- the flat layer
@pytest.mark.parametrize("Gamma, M, e", [(2.5, 2, 0.45), (4.5, 2, 0.2), (1.7, 1, 0.6), (5.5, 3, 0.3)])
@pytest.mark.parametrize("branch", ["stable", "unstable"])
def test_constant_law_equals_float_bit_for_bit(Gamma, M, e, branch):
    a = FlatLayer(Gamma, M, e=e, branch=branch)
    b = FlatLayer(Gamma, M, e=ConstantRestitution(e), branch=branch)
    assert (a.t0, a.W0, a.e) == (b.t0, b.W0, b.e)
    assert np.array_equal(a.impact_map_jacobian(), b.impact_map_jacobian())
    assert np.array_equal(a.floquet_multipliers(), b.floquet_multipliers())
    t = np.linspace(0.0, 20.0, 7)
    assert np.array_equal(a.height(t), b.height(t)) and np.array_equal(a.velocity(t), b.velocity(t))
    assert FlatLayer.stability_window(e, M) == FlatLayer.stability_window(ConstantRestitution(e), M)


def _ode_ball(Gamma, law, t, v, periods, T):
    """Integrate one ball for ``periods`` landings (DOP853), the law applied at each: (t_k, v_k)."""
    out = []
    for _ in range(periods):
        def rhs(s, y):
            return [math.sin(s) - 1.0 / Gamma, y[0]]

        def hit(s, y):
            return y[1]

        hit.terminal, hit.direction = True, -1.0
        sol = integrate.solve_ivp(rhs, (t, t + 2.0 * T), [v, 0.0], method="DOP853", events=hit, rtol=1e-13,
                                  atol=1e-15, first_step=1e-3)
        t = float(sol.t_events[0][0])
        u = -float(sol.y_events[0][0][0])
        v = law(u) * u
        out.append((t, v))
    return out


@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_law_orbit_against_independent_ball_integration(law):
    Gamma, M = 2.5, 2
    fl = FlatLayer(Gamma, M, e=law)
    T = fl.period
    # the orbit: impact speed solves v (1 + e(v)) = T / Gamma, W0 = e(v) v
    v = -fl.impact_velocity
    assert v * (1.0 + law(v)) == pytest.approx(T / Gamma, abs=1e-13)
    assert fl.W0 == pytest.approx(law(v) * v, abs=1e-13) and fl.e == law(v)
    for k, (t, w) in enumerate(_ode_ball(Gamma, law, fl.t0, fl.W0, 3, T), start=1):
        assert t - (fl.t0 + k * T) == pytest.approx(0.0, abs=1e-12)     # measured <= 5.2e-13
        assert w == pytest.approx(fl.W0, abs=1e-12)


@pytest.mark.parametrize("law", LAWS, ids=repr)
@pytest.mark.parametrize("branch", ["stable", "unstable"])
def test_law_multipliers_against_finite_differences(law, branch):
    fl = FlatLayer(2.5, 2, e=law, branch=branch)
    J = fl.impact_map_jacobian()
    Jfd = fd_jacobian(fl, fl.t0, fl.W0)
    assert np.max(np.abs(J - Jfd)) < 1e-8
    mu, mu_fd = np.sort_complex(np.linalg.eigvals(J)), np.sort_complex(np.linalg.eigvals(Jfd))
    assert np.max(np.abs(mu - mu_fd)) < 1e-8
    # det J = e(v) phi'(v) on the orbit
    v = -fl.impact_velocity
    assert np.linalg.det(J) == pytest.approx(law(v) * law.rebound_derivative(v), rel=1e-12)


@pytest.mark.parametrize("law", [VISCO, POWER], ids=repr)
def test_law_stability_window_ends(law):
    low, high = FlatLayer.stability_window(law, 2)
    # lower end: the fold cos t0 = 1; upper end: a multiplier -1 (period doubling)
    fold = FlatLayer(low * (1 + 1e-12), 2, e=law)
    assert math.cos(fold.t0) == pytest.approx(1.0, abs=1e-5)
    mu = FlatLayer(high, 2, e=law).floquet_multipliers()
    assert np.min(mu.real) == pytest.approx(-1.0, abs=1e-9)
    assert FlatLayer(0.5 * (low + high), 2, e=law).is_stable
    assert not FlatLayer(high * 1.01, 2, e=law).is_stable


def test_law_layer_errors_and_patterns():
    with pytest.raises(ValueError, match=r"the sticking orbit has period 2\*pi\*5"):
        FlatLayer(4.1, 2, e=VISCO, pattern="stick")
    with pytest.raises(ValueError, match="touch-and-go orbits need e = 0"):
        FlatLayer(4.1, 2, e=VISCO, pattern="touch")
    with pytest.raises(ValueError, match="inconsistent"):
        FlatLayer(2.5, 2, e=VISCO, t0=0.1)
    table = FlatLayer.patterns(2.5, 2, VISCO)
    assert table["bounce"] == (True, ["stable", "unstable"]) and table["stick"][0] is False
    assert FlatLayer.patterns(4.6, 2, ViscoelasticRestitution(5.0))["stick"] == (True, ["stable"])
    orbits = FlatLayer.bounce_orbits(2.5, 2, VISCO)
    assert [o.branch for o in orbits] == ["stable", "unstable"]
    again = FlatLayer(2.5, 2, e=VISCO, t0=orbits[0].t0)
    assert again.t0 == orbits[0].t0 and again.e == pytest.approx(orbits[0].e, abs=1e-14)


def test_law_layer_saves_and_loads(tmp_path):
    import tps_solver as tps
    from tps_solver.core import archive
    fl = FlatLayer(2.5, 2, e=VISCO)
    path = tmp_path / "fl.npz"
    archive.save(fl, path)
    back = tps.load(path)
    assert back.restitution == VISCO and back.t0 == fl.t0 and back.e == fl.e


# ----------------------------------------------------------------------------- the FDA, shooting, the TPS
@pytest.mark.parametrize("method", ["point", "exact", "ode"])
def test_fda_flat_lattice_with_law_keeps_the_law_orbit(method):
    import tps_solver as tps
    fl = FlatLayer(2.5, 2, e=VISCO)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t0 = fl.t0 + 1.0
    t1 = t0 + 10 * fl.period
    run = tps.simulate(lat, 2.5, VISCO, np.full(5, fl.velocity(t0)), np.full(5, fl.height(t0)), t_start=t0,
                       t_end=t1, method=method)
    assert run.success
    imp = run.events[run.events["kind"] == "impact"]
    k = np.round((imp["t"] - fl.t0) / fl.period)
    tol = {"point": 1e-13, "exact": 1e-13, "ode": 2e-12}[method]
    assert imp.size == 50 and np.max(np.abs(imp["t"] - fl.t0 - k * fl.period)) < tol
    assert np.max(np.abs(run.zeta - fl.height(t1))) < 100 * tol
    assert np.max(np.abs(imp["w_before"] - fl.impact_velocity)) < 100 * tol


def test_fda_point_and_exact_agree_on_a_perturbed_lattice_with_law():
    import tps_solver as tps
    fl = FlatLayer(2.5, 2, e=POWER.at(e0=0.45, v0=4.0))
    lat = tps.Lattice.planar(n_nodes=9, length=8.0)
    t0 = fl.t0 + 1.0
    bump = 0.05 * np.cos(np.pi * lat.nodes / 8.0)
    runs = [tps.simulate(lat, 2.5, fl.restitution, np.full(9, fl.velocity(t0)) + bump, np.full(9, fl.height(t0)),
                         t_start=t0, t_end=t0 + 4 * fl.period, method=m) for m in ("point", "exact")]
    a, b = (r.events for r in runs)
    assert a.size == b.size and np.array_equal(a["node"], b["node"]) and np.array_equal(a["kind"], b["kind"])
    assert np.max(np.abs(a["t"] - b["t"])) < 1e-12
    assert np.max(np.abs(runs[0].w - runs[1].w)) < 1e-11 and np.max(np.abs(runs[0].zeta - runs[1].zeta)) < 1e-11


def test_uniform_period_map_of_the_fda_has_the_flat_law_multipliers():
    # the flat lattice perturbed along its uniform mode stays synchronous: the FDA's period map
    # restricted to it is the ball's, whose multipliers FlatLayer gives through phi'(v)
    import tps_solver as tps
    fl = FlatLayer(2.5, 2, e=VISCO)
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    ts = fl.t0 + 1.0

    def P(w, z):
        run = tps.simulate(lat, 2.5, VISCO, np.full(3, w), np.full(3, z), t_start=ts, t_end=ts + fl.period,
                           method="exact")
        return np.array([run.w[0], run.zeta[0]])

    x0 = np.array([fl.velocity(ts), fl.height(ts)])
    h = 1e-6
    J = np.column_stack([(P(*(x0 + h * d)) - P(*(x0 - h * d))) / (2 * h) for d in np.eye(2)])
    mu = np.sort_complex(np.linalg.eigvals(J))
    assert np.max(np.abs(mu - np.sort_complex(fl.floquet_multipliers()))) < 1e-7


def test_single_contact_cycle_with_law_is_the_constant_e_cycle_with_other_multipliers():
    # every node of a single-contact orbit takes the impulse T/Gamma per period, so it lands at
    # the flat orbit's impact speed: the orbit is that of e = e(v_flat), the multipliers are not
    import tps_solver as tps
    from tps_solver.core import defaults
    lat = tps.Lattice.planar(**defaults.COARSE_LATTICE)
    fl = FlatLayer(2.5, 2, e=VISCO)
    with_law = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=VISCO)
    const = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=fl.e)
    assert with_law.converged and const.converged and with_law.e == fl.e
    assert np.max(np.abs(with_law.tc - const.tc)) < 1e-12
    o_law = tps.find_periodic_orbit(lat, Gamma=2.5, M=2, e=VISCO, guess=with_law)
    o_const = tps.find_periodic_orbit(lat, Gamma=2.5, M=2, e=fl.e, guess=const)
    assert o_law.converged and o_const.converged
    assert np.max(np.abs(o_law.w0 - o_const.w0)) < 1e-10 and np.max(np.abs(o_law.zeta0 - o_const.zeta0)) < 1e-10
    run = tps.simulate(lat, 2.5, VISCO, o_law.w0, o_law.zeta0, t_start=o_law.t_start,
                       t_end=o_law.t_start + o_law.period, method="exact")
    imp = run.events[run.events["kind"] == "impact"]
    assert np.max(np.abs(imp["w_before"] - fl.impact_velocity)) < 1e-10
    # the law is more dissipative for perturbations (phi' < e): smaller multipliers
    assert abs(o_law.multipliers[0]) < abs(o_const.multipliers[0]) - 0.01


def test_soft_contact_refuses_a_speed_dependent_law():
    import tps_solver as tps
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    with pytest.raises(ValueError, match="constant restitution with method='soft'"):
        tps.simulate(lat, 2.5, VISCO, np.zeros(3), np.ones(3), t_end=1.0, method="soft", cutoff=0.3)


def test_restitution_flat_study_rows():
    # the REPORT's claims: every law's window ends in a period doubling, is narrower than the
    # constant-e window at the same e, and its comparison columns are constant e's own window
    from validation.restitution_flat import law_windows
    laws = [("viscoelastic", "b = 0.6", ViscoelasticRestitution(0.6)), ("power law", "v0 = 6", POWER)]
    rows = law_windows(laws)
    for r in rows:
        assert r["end"] == "period doubling" and r["width_ratio"] < 1.0
        assert (r["const_low"], r["const_high"]) == FlatLayer.stability_window(r["e_mid"], 2)
    assert rows[0]["Gamma_low"] < 2.5 < rows[0]["Gamma_high"]


# ----------------------------------------------------------------------------- the ball and its basins
@pytest.mark.parametrize("w0, z0", [(3.0, 0.5), (1.2, 2.0), (0.2, 0.01)])
def test_ball_with_law_closed_form_against_simulate(w0, z0):
    # the one-node ball's closed form (model/ball.py) and the lattice FDA on a uniform lattice
    # (events.point_impact) apply the law independently; 5 forcing cycles, chatter included
    from tps_solver.analyses.basins import ball_cycle
    law = ViscoelasticRestitution(0.6)
    a, ev_a = ball_cycle(2.5, law, w0, z0, n_cycles=5)
    b, ev_b = ball_cycle(2.5, law, w0, z0, n_cycles=5, integrator="simulate")
    assert [k for _, k in ev_a] == [k for _, k in ev_b]
    assert np.max(np.abs(np.array([t for t, _ in ev_a]) - np.array([t for t, _ in ev_b]))) < 1e-11
    assert np.max(np.abs(a - b)) < 1e-10


def test_ball_keeps_the_law_orbit_and_basins_save():
    import tps_solver as tps
    from tps_solver.analyses.basins import ball_cycle
    fl = FlatLayer(2.5, 2, e=ViscoelasticRestitution(0.6))
    ts = fl.t0 + 1.0
    x, ev = ball_cycle(2.5, fl.restitution, fl.velocity(ts), fl.height(ts), n_cycles=4, t_section=ts)
    assert np.max(np.abs(x[4] - x[0])) < 1e-12 and [k for _, k in ev] == ["impact", "impact"]
    with pytest.raises(ValueError, match="constant restitution with model='soft'"):
        tps.flat_basins(2.5, fl.restitution, model="soft", cutoff=0.3, n_samples=2)


# ----------------------------------------------------------------------------- chatter and sticking with a law
def test_chatter_tail_against_direct_summation():
    # constant gravity: the launch speeds follow u -> phi(u); the tail's closed end (iterated to
    # 1e-15, then the asymptote u^(1-p)/(c(1-p)) + u/2) against brute-force summation to u < 1e-18
    law = ViscoelasticRestitution(5.0)
    v, gam = 1e-4, 0.8
    total, u = 0.0, v
    while u > 1e-18:
        total += u
        u = law.rebound(u)
    D, n = law.chatter_tail(v, gam)
    assert n == math.inf
    # the brute-force sum stops at 1e-18 (its remainder ~ (1e-18)^0.8 / (c 0.8) ~ 1e-15, 1e-11 of the sum)
    assert D == pytest.approx(2.0 * total / gam, rel=1e-10)
    D_const, _ = ConstantRestitution(0.5).chatter_tail(v, gam)
    assert D_const == pytest.approx(2.0 * v / (gam * 0.5), rel=1e-14)


def test_law_sticking_orbit_against_the_ball():
    # FlatLayer(pattern="stick") with a law (bounces and a chatter summed by the law) against the
    # one-node ball integrated event by event (model/ball.py; rest below stick_velocity = 1e-9)
    from tps_solver.analyses.basins import ball_cycle
    law = ViscoelasticRestitution(5.0)
    fl = FlatLayer(4.6, 2, e=law, pattern="stick")
    assert fl.contact_sequence == "BC" and fl.chatter_error < 1e-13
    assert np.array_equal(fl.floquet_multipliers(), np.zeros(2, complex))
    x, ev = ball_cycle(4.6, law, 0.0, 0.0, n_cycles=2, t_section=fl.t0, stuck=True, stick_velocity=1e-9)
    impacts_orbit = [t for t, k in fl.events if k == "impact"]
    impacts_ball = [t for t, k in ev if k == "impact"]
    n = len(impacts_orbit)
    assert n > 20 and len(impacts_ball) >= n - 5
    m = min(n, len(impacts_ball)) - 5            # all but the last few (the ball's cut-off at 1e-9)
    assert np.max(np.abs(np.array(impacts_orbit[:m]) - np.array(impacts_ball[:m]))) < 1e-10
    stick_orbit = [t for t, k in fl.events if k == "stick"][0]
    stick_ball = [t for t, k in ev if k == "stick"][0]
    assert abs(stick_orbit - stick_ball) < 1e-6        # the tail below 1e-9 lasts about 1e-7
    # after one period T = 4 pi from the lift-off the ball is at rest again (it lifts off at t0 + T)
    assert np.array_equal(x[-1], [0.0, 0.0]) and [k for _, k in ev].count("liftoff") == 1


# ----------------------------------------------------------------------------- the TPS and continuation
def test_solve_kink_with_law_is_the_constant_e_kink_and_stick_tps_refuses():
    import tps_solver as tps
    law = ViscoelasticRestitution(0.6)
    fl = FlatLayer(2.4, 2, e=law)
    a = tps.solve_kink(Gamma=2.4, e=law)
    b = tps.solve_kink(Gamma=2.4, e=fl.e)
    assert a.converged and b.converged and a.e == b.e == fl.e
    assert np.max(np.abs(a.tc - b.tc)) < 1e-12
    with pytest.raises(ValueError, match="constant restitution for the impact-and-stick TPS"):
        tps.solve_stick_flat(4.6, e=law)


def test_continuation_of_the_law_flat_layer():
    # in Gamma: the period doubling where stability_window's modulus scan puts it (an independent
    # test: det(I + J) along the branch); in the law's parameter b: the fold cos t0 = 1
    import tps_solver as tps
    law = ViscoelasticRestitution(0.6)
    fl = FlatLayer(2.4, 2, e=law)
    br = tps.continue_branch(fl, "Gamma", (2.2, 2.8), bothsides=True)
    kinds = {sp[0]: sp[1] for sp in br.special_points}
    lo, hi = FlatLayer.stability_window(law, 2)
    assert kinds["period_doubling"] == pytest.approx(hi, abs=1e-8)
    assert kinds["fold"] == pytest.approx(lo, abs=1e-8)
    br = tps.continue_branch(fl, "b", (0.3, 1.0))
    b_fold = [sp[1] for sp in br.special_points if sp[0] == "fold"][0]
    at_fold = FlatLayer(2.4, 2, e=ViscoelasticRestitution(b_fold), pattern="bounce")
    assert math.cos(at_fold.t0) == pytest.approx(1.0, abs=1e-7)
