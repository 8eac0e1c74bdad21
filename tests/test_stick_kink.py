"""The e = 0 kink front door: solve_kink(e=0) -> solve_stick_kink (shooting, impact-and-stick TPS, FDA check)."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.tps.stick_kink import FDA_TOL, solve_stick_kink
from tps_solver.solvers.tps.stick_pattern import pattern_from_orbit


def _against_shooting(sol, ref):
    """Max distance of the TPS's contact and lift-off times from an independent shooting orbit's."""
    p, q = sol.pattern, pattern_from_orbit(ref)
    assert p.node.tolist() == q.node.tolist() and p.kind.tolist() == q.kind.tolist()
    T = sol.period
    dt = np.abs((p.t - q.t + T / 2) % T - T / 2)
    stick = p.kind == "stick"
    dtau = np.abs((p.tau[stick] - q.tau[stick] + T / 2) % T - T / 2)
    return float(dt.max()), float(dtau.max(initial=0.0))


@pytest.mark.parametrize("n_nodes", [6, pytest.param(21, marks=pytest.mark.slow)])
def test_e0_kink_matches_shooting_and_fda(n_nodes):
    """dx = 8 and 2: contact and lift-off times against lattice_kink to 1e-9, |mu_1| to 1e-6, FDA stays on it."""
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=40.0)
    sol = tps.solve_kink(4.1, e=0.0, lattice=lat)
    ref = tps.lattice_kink(lat, Gamma=4.1, e=0.0)
    assert sol.converged and sol.checks.all_pass and ref.converged
    assert sol.formulation.startswith("impact-and-stick TPS")
    assert sol.spacing == pytest.approx(40.0 / (n_nodes - 1), rel=1e-15)
    dt, dtau = _against_shooting(sol, ref)
    assert dt < 1e-9 and dtau < 1e-9
    assert sol.fda_check.passed and sol.fda_check.periods == 10
    assert max(sol.fda_check.contact_error, sol.fda_check.liftoff_error, sol.fda_check.state_defect) <= FDA_TOL
    assert abs(abs(sol.multipliers[0]) - abs(ref.multipliers[0])) < 1e-6
    if n_nodes == 21:               # the stable pinned kink of validation (width 9.014, |mu_1| = 0.983)
        assert abs(sol.multipliers[0]) == pytest.approx(0.983, abs=1e-3)
        assert tps.front_width(sol.orbit)[0] == pytest.approx(9.014, abs=1e-3)


def test_single_contact_formulation_is_named():
    sol = tps.solve_kink(n_harmonics=6, n_nodes=6)
    assert sol.formulation.startswith("single-contact TPS")


@pytest.mark.parametrize("kwargs, match", [
    (dict(e=0.0, n_nodes=10), "n_nodes applies to the single-contact TPS"),
    (dict(e=0.0, half_length=30.0), "half_length applies"),
    (dict(e=0.0, scheme="picard"), "scheme applies"),
    (dict(e=0.45, lattice=tps.Lattice.planar(n_nodes=6, length=40.0)), "lattice applies to the e = 0 kink"),
])
def test_options_that_do_not_apply_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        tps.solve_kink(4.1, **kwargs)


@pytest.mark.parametrize("kwargs, match", [
    (dict(Gamma=3.0), "no sticking flat orbit"),
    (dict(M=3), "M must be even"),
    (dict(lattice=tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform")), "planar"),
    (dict(fda_periods=0), "fda_periods"),
])
def test_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        solve_stick_kink(**{"lattice": tps.Lattice.planar(n_nodes=6, length=40.0), **kwargs})


def test_failed_shooting_is_said():
    """No shooting steps: the message says so and no multipliers are reported as the orbit's."""
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    sol = solve_stick_kink(4.1, lattice=lat, periods=1, max_iter=0, fda_periods=2)
    assert not sol.orbit.converged and sol.multipliers is None
    assert sol.message.startswith("shooting did not converge")
    if not sol.converged:
        assert not sol.checks.all_pass and not sol.fda_check.passed


@pytest.mark.slow
def test_default_lattice_is_dx1():
    """The default call: dx = 1 on [-20, 20], checked by the FDA, |mu_1| as shooting's."""
    sol = tps.solve_kink(4.1, e=0.0)
    assert sol.spacing == 1.0 and sol.lattice.n_nodes == 41
    assert sol.converged and sol.checks.all_pass and sol.fda_check.passed
    assert 0.99 < abs(sol.multipliers[0]) < 1.0


def test_e0_oscillon_pinned_on_a_coarse_lattice():
    """dr = 8: the lattice pins a core of radius 12 (as lattice_oscillon finds); the FDA stays on it."""
    lat = tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform")
    sol = tps.solve_oscillon(4.1, e=0.0, lattice=lat, r_core=12.0)
    ref = tps.lattice_oscillon(lat, Gamma=4.1, e=0.0, core_radius=12.0)
    assert sol.converged and sol.localized and sol.checks.all_pass and ref.localized
    dt, dtau = _against_shooting(sol, ref)
    assert dt < 1e-9 and dtau < 1e-9
    assert sol.fda_check.passed


def test_e0_oscillon_that_does_not_exist_is_not_reported():
    """dr = 4: the core shrinks to nothing while settling; the orbit found is the flat layer, and it says so."""
    lat = tps.Lattice.axisymmetric(n_nodes=11, r_max=40.0, grid="uniform")
    sol = tps.solve_oscillon(4.1, e=0.0, lattice=lat, r_core=10.0)
    assert not sol.localized and not sol.checks.all_pass and not sol.checks.localized
    assert sol.core_nodes[0] == 3 and sol.core_nodes[-1] == 0
    assert sol.message.startswith("no oscillon found: the orbit is uniform")
    # it is the flat e = 0 orbit: every node lands at the closed form's contact times
    flat = tps.solvers.tps.stick.flat_stick_orbit(4.1, 2)
    T = sol.period
    for j in range(lat.n_nodes):
        tj = np.sort(np.mod(sol.pattern.t[sol.pattern.node == j], T))
        assert np.max(np.abs(tj - np.sort(np.mod(flat.t, T)))) < 1e-9


def test_oscillon_options_that_do_not_apply_are_refused():
    with pytest.raises(ValueError, match="n_nodes applies to the single-contact TPS"):
        tps.solve_oscillon(4.1, e=0.0, n_nodes=12)
    with pytest.raises(ValueError, match="lattice applies to the e = 0 oscillon"):
        tps.solve_oscillon(4.1, e=0.45, lattice=tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform"))
    with pytest.raises(ValueError, match="core_radius must lie inside"):
        tps.solve_oscillon(4.1, e=0.0, lattice=tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform"),
                           r_core=50.0)
