"""Floquet multipliers of symmetric orbits from the mirrored half-period map G = S o P_{T/2}.

At a fixed point of G, DP_T = DG^2, so the multipliers of the period map are the squares of
DG's eigenvalues (tps_solver.solvers.shooting.symmetric.mirrored_multipliers; the default of
find_periodic_orbit and lattice_kink where it applies).  References, none of them computed by G:

* the closed-form per-mode soft flat monodromy (SoftFlatOrbit.monodromy) on a mirror-symmetric
  lattice: the f/1 soft flat orbit is a fixed point of G for T = 4 pi, and G's eigenvalue on
  the lattice mode k is (-1)^k times the per-mode multiplier of one forcing cycle (the cosine
  mode's parity under the mirror), the period map's the square;
* the dense central-difference Jacobian of the full period map P_T (``multiplier_map="period"``)
  on e = 0 kinks, with the same relative step 1e-5 (both accurate to about 1e-8: the map's
  round-off is about 2e-13); the default one-sided route of the period map (step 1e-7) is
  only good to about 1e-6 there.
"""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.operators.lattice import lattice_eigenvalues
from tps_solver.solvers.shooting.floquet import ritz_multipliers


def _match(a, b):
    """Largest distance from any element of a to the nearest of b and vice versa."""
    d = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    return max(d.min(axis=0).max(), d.min(axis=1).max())


def test_soft_flat_lattice_mirrored_multipliers_are_the_per_mode_closed_form_with_the_mirror_parity():
    G, E, ELL, n = 1.5, 0.45, 0.3, 5
    orb = SoftFlatOrbit(G, 1, E, ELL)                     # f/1: also periodic with T = 4 pi (M = 2)
    lat = tps.Lattice.planar(n_nodes=n, length=4.0)
    s = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(s)
    res = tps.find_periodic_orbit(lat, G, 2, E, cutoff=ELL, guess=(np.full(n, w), np.full(n, z)), t_start=s,
                                  section="fixed", tol=1e-10)
    assert res.converged and res.multipliers_map == "mirrored" and res.multipliers_kind == "all (exact)"
    lam = [np.linalg.eigvals(Mk) for Mk in orb.monodromy(lattice_eigenvalues(lat), t_section=s)]
    # lattice mode k of the Neumann lattice has parity (-1)^k under x -> -x
    assert _match(res.half_period_multipliers, np.concatenate([(-1) ** k * l for k, l in enumerate(lam)])) < 1e-10
    assert _match(res.multipliers, np.concatenate(lam) ** 2) < 1e-10
    assert np.iscomplexobj(res.multipliers) and np.any(np.abs(res.multipliers.imag) > 0.1)   # a complex pair
    ref = tps.find_periodic_orbit(lat, G, 2, E, cutoff=ELL, guess=res, section="fixed", tol=1e-10,
                                  multiplier_map="period")
    assert ref.multipliers_map == "period" and ref.half_period_multipliers.size == 0
    assert _match(ref.multipliers[:6], res.multipliers[:6]) < 1e-10


@pytest.fixture(scope="module")
def kink11():
    """The e = 0 kink on 11 nodes (dx = 4): centred on a node it is unstable here (mu_1 = 1.094),
    with the reference: the dense central-difference period map (step 1e-5)."""
    lat = tps.Lattice.planar(n_nodes=11, length=40.0)
    orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)
    ref = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=orb, multiplier_map="period",
                                  jacobian_step=1e-5)
    assert ref.converged and ref.multipliers_map == "period" and ref.multipliers_kind == "all (dense)"
    assert np.sum(np.abs(ref.multipliers) > 1e-3) >= 4
    return lat, orb, ref


@pytest.mark.slow
def test_kink_dense_mirrored_equals_dense_period_map(kink11):
    lat, orb, ref = kink11
    new = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=orb)
    assert new.multipliers_map == "mirrored" and new.multipliers_kind == "all (dense)" and new.differentiable
    # measured: 1.8e-8 at most (both differences carry about 1e-8 of the map's round-off)
    np.testing.assert_allclose(new.multipliers[:4], ref.multipliers[:4], rtol=0, atol=3e-8)
    np.testing.assert_allclose(new.multipliers, new.half_period_multipliers ** 2, rtol=0, atol=0)
    # the translation, reversed by the mirror: lambda_1 < -1 (unstable), mu_1 = lambda_1^2 > 1
    assert new.half_period_multipliers[0].real < -1.0 and abs(new.half_period_multipliers[0].imag) == 0.0
    # 2 m central columns of G (half periods) against 2 m of P, and the cheaper test
    assert new.multiplier_periods < 0.6 * ref.multiplier_periods


@pytest.mark.slow
def test_kink_arnoldi_on_G_matches_the_dense_period_map(kink11):
    lat, orb, ref = kink11
    new = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=orb, dense_max=0, n_multipliers=4)
    assert new.multipliers_map == "mirrored" and new.multipliers_kind == "leading (Arnoldi)"
    assert new.multipliers.size == 4 and 6 <= new.arnoldi_dim < 20 and new.differentiable
    np.testing.assert_allclose(new.multipliers, ref.multipliers[:4], rtol=0, atol=3e-8)   # measured 1.7e-8
    assert "mirrored map has" not in new.message                # mu_1 = 1.094: not neutral
    assert new.multiplier_time > 0 and new.multiplier_periods < 16


def test_lattice_kink_reports_the_mirrored_multipliers():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    new = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, dense_max=0, n_multipliers=3)
    assert new.converged and new.multipliers_map == "mirrored" and new.multipliers_kind == "leading (Arnoldi)"
    ref = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=new, multiplier_map="period",
                                  jacobian_step=1e-5)
    assert ref.multipliers_map == "period" and abs(ref.multipliers[0]) > 1e-2 > abs(ref.multipliers[1])
    # both central differences of step 1e-5 on maps with ~2e-13 round-off: ~2e-13 / 1e-5 = 2e-8 each
    assert abs(new.multipliers[0] - ref.multipliers[0]) < 3e-8


def test_a_non_symmetric_orbit_falls_back_to_the_period_map():
    # the f/2 flat layer: its two halves of the period differ, so it is no fixed point of G
    lat = tps.Lattice.planar(n_nodes=4, length=60.0)
    orb = tps.find_periodic_orbit(lat, Gamma=2.5, M=2, e=0.45, dense_max=0, n_multipliers=2)
    assert orb.converged and orb.multipliers_map != "mirrored"
    assert "not a fixed point of the mirrored half-period map" in orb.message
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    assert np.max(np.abs(orb.zeta0 - fl.height(orb.t_start))) < 1e-9


def test_multiplier_map_refusals():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    with pytest.raises(ValueError, match="multiplier_map"):
        tps.find_periodic_orbit(lat, Gamma=2.5, M=2, e=0.45, multiplier_map="half")
    with pytest.raises(ValueError, match="multiplier_map='mirrored'"):
        tps.find_periodic_orbit(lat, Gamma=2.5, M=1, e=0.45, multiplier_map="mirrored")
    shifted = tps.Lattice.planar(n_nodes=6, length=40.0, center=1.0)
    with pytest.raises(ValueError, match="multiplier_map='mirrored'"):
        tps.find_periodic_orbit(shifted, Gamma=2.5, M=2, e=0.45, multiplier_map="mirrored")


def test_arnoldi_stops_when_the_squares_have_converged():
    # a non-normal matrix with known eigenvalues +-0.9^j: the squares of the leading 4 to 1e-12
    rng = np.random.default_rng(5)
    n = 60
    lam = np.array([(-1) ** j * 0.9 ** (3 * j) for j in range(n)])
    X = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    A = X @ np.diag(lam) @ np.linalg.inv(X)
    mu, res, used = ritz_multipliers(lambda v: A @ v, n, 4, 40, rng.standard_normal(n), tol=1e-12, power=2)
    assert used < 40
    np.testing.assert_allclose(mu ** 2, lam[:4] ** 2, rtol=0, atol=1e-10)
    full = ritz_multipliers(lambda v: A @ v, n, 4, 40, rng.standard_normal(n))
    assert full[2] == 40
