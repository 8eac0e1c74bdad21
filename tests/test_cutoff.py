"""Tests of the cut-off study: grid-scale instability of point impacts, regularised models."""
import math

import mpmath
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.fda import flat_state, simulate
from tps_solver.model.soft_flat import SoftFlatOrbit, soft_contact_parameters
from tps_solver.operators.lattice import lattice_eigenvalues
from validation.impact_rules import kernel_matrix, regularised_impact
from validation.cutoff import fast_plain, fast_soft, perturbation_growth, soft_simulation_check

GAMMA, E, M = 2.5, 0.45, 2
EPS = np.finfo(float).eps


def simulate_radau(*args, **kw):
    """The soft contact by the Radau reference integrator (``simulate(..., method="soft-radau")``)."""
    return simulate(*args, method="soft-radau", **kw)


def flat():
    return tps.FlatLayer(Gamma=GAMMA, M=M, e=E)


# --------------------------------------------------------- the plain lattice is ill-posed
def test_point_impact_growth_increases_under_refinement():
    """hazard 8 of docs/design.md: growth per period rises as dx falls (1.6, 0.53, 0.27) and exceeds 1 on fine grids."""
    rows = fast_plain()
    g = np.array([r["growth"] for r in rows])
    dx = np.array([r["dx"] for r in rows])
    assert np.all(np.diff(dx) < 0)
    assert np.all(np.diff(g) > 0), g
    assert g[0] < 1.0 < g[-1], g
    assert all(r["impacts_per_node"] == 1.0 for r in rows)     # one bounce per node and period
    assert max(r["flat_defect"] for r in rows) < 1e-12         # the unperturbed lattice stays flat


# ---------------------------------------------------------------- uniform mode is exact
RULE_KINDS = ("kernel", "patch")


@pytest.mark.parametrize("kind", RULE_KINDS)
@pytest.mark.parametrize("geometry", ("planar", "quasilog"))
def test_rule_conserves_flat_impact(kind, geometry):
    lat = (tps.Lattice.planar(n_nodes=17, length=8.0) if geometry == "planar"
           else tps.Lattice.axisymmetric(n_nodes=17, r_max=8.0, grid="quasilog"))
    rule = regularised_impact(kind, 0.7)
    w_minus = np.full(17, -3.25)
    w_plus = rule(w_minus, np.arange(17), E, lat, np.ones(17, bool))
    np.testing.assert_allclose(w_plus, -E * w_minus, rtol=8 * EPS, atol=0)
    assert rule.cutoff == {"kind": f"{kind} impact", "length": 0.7}


@pytest.mark.parametrize("kind", RULE_KINDS)
def test_rule_reproduces_bouncing_ball(kind):
    fl = flat()
    lat = tps.Lattice.planar(n_nodes=13, length=8.0)
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    run = simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + 2 * fl.period, impact=regularised_impact(kind, 0.5))
    assert run.success
    np.testing.assert_allclose(run.zeta, fl.height(t0), atol=1e-11)
    np.testing.assert_allclose(run.w, fl.velocity(t0), atol=1e-11)


def test_kernel_rows_normalised_and_symmetric_on_uniform_grid():
    K = kernel_matrix(tps.Lattice.planar(n_nodes=9, length=4.0), 0.8)
    np.testing.assert_allclose(K.sum(axis=1), 1.0, rtol=0, atol=4 * EPS)
    assert np.all(K >= 0)


def test_kernel_rule_is_discontinuous_at_the_flat_layer():
    """Evidence kept in the report: a 1e-7 perturbation changes the post-impact state at O(1)."""
    lat = tps.Lattice.planar(n_nodes=21, length=8.0)
    res = perturbation_growth(lat, GAMMA, E, M, periods=1, discard=0, impact=regularised_impact("kernel", 0.5))
    assert res["factors"][0] > 1e5


@pytest.mark.parametrize("V", (0.3, 1.0, 3.4))
def test_soft_contact_restitution_is_exact_for_uniform_states(V):
    """Damped oscillator: entry speed V leaves after exactly tau_c with velocity e V (any V)."""
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    cutoff = 0.3
    tau_c, om2, beta = soft_contact_parameters(E, cutoff)
    t_in = 0.7
    run = simulate_radau(lat, GAMMA, E, np.full(5, -V), np.zeros(5), t_start=t_in, t_end=t_in + tau_c,
                        cutoff=cutoff, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(run.w, E * V, rtol=2e-8)
    np.testing.assert_allclose(run.zeta, 0.0, atol=2e-9 * V)
    assert run.cutoff["kind"] == "soft contact" and run.cutoff["tau_c"] == pytest.approx(cutoff**2, rel=4 * EPS)
    assert math.exp(-beta * tau_c) == pytest.approx(E, rel=8 * EPS)
    assert om2 == pytest.approx((math.pi / tau_c) ** 2 + beta**2, rel=8 * EPS)


def test_soft_uniform_mode_tends_to_flat_layer_multipliers():
    """lambda = 0 monodromy -> FlatLayer.floquet_multipliers as the cut-off -> 0, fitted order 2 (tau_c = cutoff^2)."""
    ref = np.sort_complex(flat().floquet_multipliers())
    cutoffs = np.array([1e-3, 3e-3, 1e-2, 3e-2])
    err = []
    for c in cutoffs:
        mu = np.sort_complex(np.linalg.eigvals(SoftFlatOrbit(GAMMA, M, E, c).monodromy(0.0)[0]))
        err.append(np.max(np.abs(mu - ref)))
        # det = exp(-2 beta tau_c) = e^2 exactly: the complex pair has modulus e
        np.testing.assert_allclose(np.abs(mu), E, rtol=64 * EPS)
    slope = np.polyfit(np.log(cutoffs), np.log(err), 1)[0]
    assert abs(slope - 2.0) < 0.05, slope


@pytest.mark.parametrize("c", (-2500.0, -7.0, 0.0, 3.0))
def test_companion_exponential_against_mpmath(c):
    from tps_solver.model.flight import expm_companion as _expm_companion
    a = np.array([-1e8, -1e3, -50.0, -2 * math.sqrt(7.0), -3.0, 0.5, 100.0])
    got = _expm_companion(a, c, 0.09)
    with mpmath.workdps(40):
        for k, x in enumerate(a):
            ref = np.array(mpmath.expm(mpmath.matrix([[x, c], [1, 0]]) * mpmath.mpf(0.09)).tolist(), dtype=float)
            assert np.max(np.abs(got[k] - ref)) <= 64 * EPS * np.max(np.abs(ref))


# ------------------------------------------------------------ soft model converges
def test_soft_lattice_growth_converges_at_fixed_cutoff():
    """At cut-off 0.3 the lattice growth factor converges under refinement, observed order 2."""
    res = fast_soft(0.3)
    g = np.array([r["growth"] for r in res["rows"]])
    assert np.all(g < 1.0)                                       # never unstable
    orders = res["orders"]
    assert len(orders) >= 2
    np.testing.assert_allclose(orders[-2:], 2.0, atol=0.25)
    # the limit is the neutral high-wavenumber asymptote rho -> 1 (see the report)
    np.testing.assert_allclose(res["orders_to_one"][-2:], 2.0, atol=0.25)


def test_soft_monodromy_matches_nonlinear_lattice():
    """One period of the nonlinear soft lattice (Radau) against the per-mode monodromy."""
    res = soft_simulation_check(cutoff=0.3, n_nodes=9, mode=1, amplitude=1e-5)
    assert res["rel_error"] < 2e-3
    assert res["uniform_defect"] < 1e-7                         # the closed-form soft flat orbit


def test_lattice_eigenvalues_planar_neumann():
    lat = tps.Lattice.planar(n_nodes=11, length=8.0)
    dx = 0.8
    j = np.arange(11)
    ref = 4.0 / dx**2 * np.sin(j * math.pi / 20.0) ** 2         # DCT-I spectrum of the ghost-reflection Laplacian
    np.testing.assert_allclose(lattice_eigenvalues(lat), ref, rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------------ bad input
@pytest.mark.parametrize("call, match", [
    (lambda: regularised_impact("gauss", 0.5), "kind"),
    (lambda: regularised_impact("kernel", 0.0), "cutoff"),
    (lambda: regularised_impact("patch", -1.0), "cutoff"),
    (lambda: soft_contact_parameters(0.0, 0.3), "e"),
    (lambda: soft_contact_parameters(0.45, float("nan")), "cutoff"),
    (lambda: SoftFlatOrbit(GAMMA, M, E, 4.0), "cutoff"),
    (lambda: simulate_radau("lattice", GAMMA, E, [0.0], [0.0], t_end=1.0, cutoff=0.3), "lattice"),
    (lambda: simulate_radau(tps.Lattice.planar(n_nodes=3), GAMMA, E, [0.0] * 3, [0.0] * 3, t_end=1.0,
                           cutoff=0.0), "cutoff"),
])
def test_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()
