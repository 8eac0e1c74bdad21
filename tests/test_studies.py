"""The validation studies' functions, in fast configurations, asserted on their numbers."""

import pytest

from validation import lattice_tps, tps_branches


def test_fda_closes_the_exact_cycle():
    rows = lattice_tps.fda_defect(kinds=("planar",), n=6, size=105.0)
    for r in rows:
        assert r["converged"] and r["impacts"] == 6
        tol = 1e-11 if r["method"] == "exact" else 1e-8
        assert r["defect_zeta"] < tol and r["defect_w"] < tol and r["max_dtc"] < tol


def test_spectral_lattice_tps_first_order():
    out = lattice_tps.tps_convergence(kinds=("axisymmetric",), Ns=(16, 32, 64, 128), n=6, size=105.0)
    rows, slope = out["axisymmetric"]
    assert all(r["converged"] for r in rows)
    assert -1.4 < slope < -0.7


def test_branch_end_on_a_fine_lattice_and_existence_on_a_coarse_one():
    rows = lattice_tps.branch_ends(cases=[("fine", "planar", 21, 4.0, "uniform"),
                                          ("coarse", "planar", 8, 160.0, "uniform")])
    fine = [r for r in rows if r["case"] == "fine" and r["preset"] == "e = 0.45"][0]
    coarse = [r for r in rows if r["case"] == "coarse" and r["preset"] == "e = 0.45"][0]
    assert fine["status"] == 4 and 11.0 < fine["effective_spacing"] < 16.0
    assert coarse["status"] == 0
    assert all(r["status"] == 2 for r in rows if r["preset"] == "t0 = 0 (paper)")


@pytest.mark.parametrize("geometry", ["planar", "axisymmetric"])
def test_continuum_branch_ends_at_a_fold(geometry):
    rows, hstar = tps_branches.fold_singular_values(geometry, N=8, n_nodes=16,
                                                    fractions=(4.0, 1.3, 1.0))
    assert 8.0 < hstar < 13.0
    s = [r["sigma_min"] for r in rows]
    assert all(r["converged"] for r in rows)
    assert s[0] > s[1] > s[2] and s[2] < 0.35 * s[0]


def test_continuum_n_convergence_rates():
    """Documented rates (validation/sections/tps.md): with the dual-cell quadrature in both
    geometries a node's own high harmonics see only its own q, and the contact condition
    converges spectrally in N (fitted slopes about -9 over N = 16..64)."""
    _, slope_osc = tps_branches.n_convergence("axisymmetric", Ns=(8, 16, 32), n_nodes=8)
    _, slope_kink = tps_branches.n_convergence("planar", Ns=(8, 16, 32), n_nodes=8)
    assert slope_osc < -4.0
    assert slope_kink < -4.0


def test_kink_preset_statements():
    from validation import presets

    rows = {r["preset"]: r for r in presets.study("planar", Ns=(16, 32), periods=6)}
    interior, paper = rows["interior (e = 0.45)"], rows["paper (t0 = 0)"]
    assert not interior["tps_default_converged"] and interior["tps_default_status"] == 4
    assert not interior["fine_exists"] and 12.0 < interior["fine_effective_spacing"] < 15.5
    assert interior["coarse_exists"] and interior["fda_stable"] and interior["fda_defect"] < 1e-11
    assert interior["tps_vs_exact_order"] > 0.6
    assert paper["tps_default_status"] == 2 and paper["fine_status"] == 2 and not paper["coarse_exists"]
