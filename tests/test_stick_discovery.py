"""Tests of the TPS's own pattern discovery (tps_solver.solvers.tps.stick_discovery)."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.tps.stick_discovery import anticontinuum_pattern, discover_stick_kink
from tps_solver.solvers.tps.stick_pattern import check_with_fda, pattern_from_orbit
from tps_solver.solvers.tps.stick_problem import flat_stick_orbit
from validation.stick_discovery import discovery_vs_shooting, matched


def test_anticontinuum_pattern_is_the_flat_orbit_and_its_shift():
    p = anticontinuum_pattern(5, 1, 4.1)
    flat = flat_stick_orbit(4.1, 2)
    T = p.period
    for j in range(5):
        m = p.node == j
        shift = 0.0 if j <= 1 else T / 2
        phase = np.sort(np.mod(p.t[m] - shift, T))
        assert np.max(np.abs(phase - np.sort(np.mod(flat.t, T)))) < 1e-12
        assert np.all(p.trigger[m] == -1)
    with pytest.raises(ValueError, match="front must be in"):
        anticontinuum_pattern(5, 4, 4.1)
    with pytest.raises(ValueError, match="M must be even"):
        anticontinuum_pattern(5, 1, 4.1, M=3)


def test_discovered_kink_is_the_shooting_kink():
    """From the uncoupled start, with no time stepping: the same orbit as shooting on the same lattice
    (an independent Newton on the FDA's period map), contact and lift-off times to 1e-9, the pattern
    (touch-and-go at the two front nodes, triggered lift-offs none) identical."""
    lat = tps.Lattice.planar(n_nodes=6, length=20.0)
    sol = tps.solve_kink(4.1, e=0.0, lattice=lat, start="anticontinuum")      # the front door
    ref = tps.lattice_kink(lat, Gamma=4.1, e=0.0)
    assert sol.formulation.startswith("impact-and-stick TPS, pattern discovered")
    # its multipliers (the period map at the TPS orbit) are shooting's
    assert abs(abs(sol.multipliers[0]) - abs(ref.multipliers[0])) < 1e-6
    assert sol.fda_check.passed and sol.fda_check.periods == 10
    assert sol.converged and sol.checks.all_pass and ref.converged
    assert sol.residual < 1e-10 and sol.discovery.reached == 1.0
    assert len(sol.discovery.changes) > 0                      # the pattern did change along the path
    shift, t_err, tau_err = matched(sol.pattern, pattern_from_orbit(ref))
    assert shift == 0
    assert t_err < 1e-9 and tau_err < 1e-9
    assert sol.contacts.sequence(2) == "TT" and sol.contacts.sequence(0) == "TS"
    # and the FDA started on it stays on it
    chk = check_with_fda(sol, periods=3)
    assert chk.run.status == 0
    assert chk.contact_error < 1e-8 and chk.liftoff_error < 1e-8


def test_discovery_reports_an_unfinished_path():
    """A path cut short returns converged=False with the coupling reached, never an orbit."""
    lat = tps.Lattice.planar(n_nodes=6, length=20.0)
    sol = discover_stick_kink(lat, 4.1, coupling_start=0.02, step=0.4, max_steps=2)
    assert not sol.converged and not sol.checks.all_pass
    assert 0.02 <= sol.discovery.reached < 1.0
    assert "stopped at nu" in sol.message


def test_discovery_input_is_validated():
    lat = tps.Lattice.planar(n_nodes=6, length=20.0)
    with pytest.raises(ValueError, match="start must be"):
        tps.solve_kink(4.1, e=0.0, lattice=lat, start="fda")
    with pytest.raises(ValueError, match="start applies to the e = 0 kink only"):
        tps.solve_kink(4.1, e=0.45, start="anticontinuum")
    with pytest.raises(ValueError, match="coupling_start must be in"):
        discover_stick_kink(lat, 4.1, coupling_start=1.5)
    with pytest.raises(ValueError, match="planar tps.Lattice"):
        discover_stick_kink(tps.Lattice.axisymmetric(n_nodes=10, r_max=10.0), 4.1)
    with pytest.raises(ValueError, match="does not close|Gamma"):
        discover_stick_kink(lat, 7.0)


@pytest.mark.slow
def test_discovery_ten_nodes_against_shooting():
    r = discovery_vs_shooting(10, 18.0)
    assert r["converged"] and r["all_pass"] and r["shift_nodes"] == 0
    assert r["contact_vs_shooting"] < 1e-9 and r["liftoff_vs_shooting"] < 1e-9
    assert r["fda_event_error"] < 1e-8
