"""Soft-contact kinks at cut-off 0.3 over lattice spacings (validation/soft_kinks.py).

Default tests: the kink start, the definitions, and the time-stepped 12-node kink at spacing 20
(single contact per node, its defect decays at the rate of the closed-form soft flat orbit's
multiplier).  Slow tests: shooting on that lattice (residual, multipliers against the measured
decay of a perturbation) and the invasion at spacing 5.
"""
import numpy as np
import pytest

import tps_solver as tps
from validation import soft_kinks as sk


def _flat_abs_mu():
    """|mu| of the uniform mode of the soft flat orbit, closed form (SoftFlatOrbit.monodromy)."""
    fo = tps.SoftFlatOrbit(sk.GAMMA, sk.M, sk.E, sk.CUTOFF)
    return float(np.max(np.abs(np.linalg.eigvals(fo.monodromy(0.0)[0]))))


def test_kink_start_is_two_flat_phases():
    lat = sk.kink_lattice(20.0)
    w, z, t0, fo = sk.kink_start(lat)
    wa, za = fo.state(t0)
    wb, zb = fo.state(t0 + 0.5 * fo.period)
    left = lat.nodes < 0
    assert lat.boundary == "neumann" and lat.n_nodes == 12 and np.count_nonzero(left) == 6
    np.testing.assert_array_equal(w[left], wa)
    np.testing.assert_array_equal(z[~left], zb)
    assert min(za, zb) > 0.0           # both phases in flight at t0


def test_lattice_choice_and_bad_input():
    assert sk.kink_lattice(5.0).n_nodes == 12
    assert sk.kink_lattice(0.2).n_nodes == 241
    assert abs(sk.kink_lattice(0.2).spacing - 0.2) < 1e-12
    with pytest.raises(ValueError, match="dx"):
        sk.kink_lattice(-1.0)


def test_invasion_speed_is_the_slope_before_the_lattice_fills():
    # 3 nodes per period until 80 % of 20 nodes, then saturated: the saturated periods are left out
    assert sk.invasion_speed([0, 3, 6, 9, 12, 15, 18, 20, 20, 20], 20) == pytest.approx(3.0)
    assert sk.invasion_speed([20, 20], 20) is None


def test_coarse_kink_settles_at_the_flat_multiplier():
    """Spacing 20, 12 nodes: one contact per node and period throughout, and the periodicity defect
    decays like |mu|^k with |mu| that of the soft flat orbit (0.45 = e to the digits shown), the
    decoupled limit of the kink's multipliers (measured by shooting: 0.449, slow test below)."""
    fr = sk.fate(20.0, periods=12, settle_tol=0.0)
    assert fr["periods_run"] == 12
    assert all(r["contacts_min"] == r["contacts_max"] == 1 and r["disordered"] == 0 for r in fr["records"])
    d = np.array([r["defect"] for r in fr["records"]])
    k = np.arange(3, 13)
    ratio = float(np.exp(np.polyfit(k, np.log(d[k - 1]), 1)[0]))
    mu = _flat_abs_mu()
    assert mu == pytest.approx(0.45, abs=1e-9)
    assert abs(ratio - mu) < 0.05, (ratio, mu)
    assert d[-1] < 1e-4 * d[0]


@pytest.mark.slow
def test_coarse_orbit_residual_and_multiplier_against_time_stepping():
    fr = sk.fate(20.0, periods=12, settle_tol=0.0)
    r = sk.shoot(20.0, fr["w"], fr["zeta"], fr["t"], tol=1e-10)
    assert r["converged"] and r["residual"] < 1e-10
    assert r["contacts"] == "1: 12" and r["sticking_nodes"] == 0
    mu1 = r["abs_mu"][0]
    assert abs(mu1 - _flat_abs_mu()) < 5e-3
    dc = sk.decay_check(r["orbit"], periods=10, size=1e-5)
    # a perturbation of the orbit decays at no more than |mu_1| per period (faster modes die first)
    assert dc["defects"][-1] < 1e-5 * mu1 ** 10 * 30
    assert 0.7 * mu1 < dc["ratio"] < 1.1 * mu1


@pytest.mark.slow
def test_spacing_5_invades():
    fr = sk.fate(5.0, periods=14)
    assert fr["verdict"] == "invades"
    assert 0.5 < fr["speed_nodes"] < 2.0
    assert fr["records"][-1]["contacts_min"] >= 2


@pytest.mark.slow
def test_unstable_two_contact_kink_below_the_fold():
    """Spacing 11.5 (below the single-contact fold at about 11.93): from the state after 9 time-stepped
    periods Newton converges to a periodic kink with a two-contact front node whose leading multiplier
    (exact monodromy) is the growth rate of a small perturbation measured by time stepping."""
    rows = sk.orbit_search(11.5, periods=9, every=9)
    r = rows[0]
    assert r["converged"] and r["residual"] < 1e-10
    assert "2: " in r["contacts"]
    assert r["abs_mu"][0] > 5.0
    assert r["growth"] == pytest.approx(r["abs_mu"][0], rel=0.02)
