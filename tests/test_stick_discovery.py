"""Tests of the TPS's own pattern discovery (tps_solver.solvers.tps.stick_discovery)."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core.bunch import Bunch
from tps_solver.solvers.tps.stick_discovery import (anticontinuum_pattern, discover_stick_kink, prolong_kink_pattern,
                                                     refine_stick_kink, sequence_stick_kink)
from tps_solver.solvers.tps.stick_pattern import check_with_fda, make_pattern, pattern_from_orbit
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


@pytest.fixture(scope="module")
def kink_dx4():
    """The six-node kink at spacing 4, solved at coupling 1 directly from the anti-continuum pattern
    (the active set turns the two front nodes' sticks into touch-and-goes; about 1 s)."""
    lat = tps.Lattice.planar(n_nodes=6, length=20.0)
    sol = discover_stick_kink(lat, 4.1, start=anticontinuum_pattern(6, 2, 4.1), coupling_start=1.0)
    assert sol.converged and sol.checks.all_pass
    return sol


def test_kink_at_coupling_one_is_the_path_kink(kink_dx4):
    """At spacing 4 the anti-continuum pattern at coupling 1 reaches the kink of the coupling path."""
    lat = kink_dx4.lattice
    path = discover_stick_kink(lat, 4.1, coupling_start=0.02, step=0.4)
    shift, t_err, tau_err = matched(kink_dx4.pattern, path.pattern)
    assert shift == 0 and t_err < 1e-9 and tau_err < 1e-9
    assert [kink_dx4.contacts.sequence(j) for j in range(6)] == ["TS", "ST", "TT", "TT", "TS", "TS"]


def _corrupt(p, *, front_sticks=None, moved=0.0):
    kind, t, tau = p.kind.copy(), p.t.copy(), p.tau.copy()
    if front_sticks is not None:            # the front nodes' last touch-and-go becomes a stick
        for j in (2, 3):
            c = np.nonzero(p.node == j)[0]
            c = c[np.argmax(t[c])]
            kind[c], tau[c] = "stick", t[c] + front_sticks
    m = np.isin(p.node, [1, 2])
    t[m] += moved
    tau[m] += moved
    return make_pattern(p.node, kind, t, p.J, tau, p.trigger, p.trigger_shift, p.n_nodes, p.period)


@pytest.mark.parametrize("corruption", [dict(front_sticks=1e-3), dict(front_sticks=0.05), dict(moved=0.01),
                                        dict(front_sticks=0.01, moved=0.005)])
def test_corrupted_start_recovers(kink_dx4, corruption):
    """A wrong pattern on a few nodes (sticks where the orbit touches and goes, times moved) is repaired
    by the active set at coupling 1: the same orbit to 1e-9, every check passing."""
    bad = _corrupt(kink_dx4.pattern, **corruption)
    sol = discover_stick_kink(kink_dx4.lattice, 4.1, start=bad, coupling_start=1.0)
    assert sol.converged and sol.checks.all_pass
    shift, t_err, tau_err = matched(sol.pattern, kink_dx4.pattern)
    assert shift == 0 and t_err < 1e-9 and tau_err < 1e-9
    if "front_sticks" in corruption:
        assert any("touch-and-go" in text for _, text in sol.discovery.changes)


@pytest.mark.parametrize("Gamma, coupling_start", [(3.7, 1.0), (3.7, 0.05), (3.8, 1.0)])
def test_start_without_orbit_is_reported(kink_dx4, Gamma, coupling_start):
    """Below Gamma = 3.857 the e = 0 far field has no f/2 orbit (and below 3.7242 no f/2 orbit at all):
    from the Gamma = 4.1 kink's pattern the solver must say so, never return an orbit."""
    sol = discover_stick_kink(kink_dx4.lattice, Gamma, start=kink_dx4.pattern, coupling_start=coupling_start)
    assert not sol.converged and not sol.checks.all_pass and sol.status != 0
    assert ("no orbit found" in sol.message) if coupling_start == 1.0 else ("stopped at nu" in sol.message)
    assert "try" in sol.message


def test_prolongation_is_node_for_node(kink_dx4):
    """Onto twice the nodes at half the coordinates (the finer lattice at coupling 1/4) the pattern is
    carried node for node; the added far-field nodes approach the flat orbit and are all distinct."""
    fine = tps.Lattice.planar(n_nodes=12, length=22.0)
    p = kink_dx4.pattern
    q = prolong_kink_pattern(p, kink_dx4.lattice.nodes / 2, fine, Gamma=4.1)
    for j in range(6):
        a, b = p.node == j, q.node == j + 3
        assert np.allclose(np.sort(np.mod(p.t[a], p.period)), np.sort(np.mod(q.t[b], p.period)), atol=1e-13)
    flat = flat_stick_orbit(4.1, 2)
    t_far = [np.sort(np.mod(q.t[q.node == j], q.period)) for j in (0, 1, 2)]
    dev = [float(np.max(np.abs(tj - np.sort(np.mod(flat.t, q.period))))) for tj in t_far]
    assert dev[0] < dev[1] < dev[2] < float(np.max(np.abs(np.sort(np.mod(p.t[p.node == 0], p.period))
                                                          - np.sort(np.mod(flat.t, p.period)))))
    assert dev[0] > 0.0
    copy = prolong_kink_pattern(p, kink_dx4.lattice.nodes / 2, fine)          # without Gamma: copies
    assert np.array_equal(copy.t[copy.node == 0], copy.t[copy.node == 3])
    with pytest.raises(ValueError, match="nodes must have shape"):
        prolong_kink_pattern(p, np.arange(5.0), fine)
    with pytest.raises(ValueError, match="one kink front"):
        prolong_kink_pattern(_uniform(p), kink_dx4.lattice.nodes, fine)


def _uniform(p):
    """Every node on node 0's contacts: no front."""
    m = p.node == 0
    C = int(m.sum())
    node = np.repeat(np.arange(p.n_nodes), C)
    return make_pattern(node, np.tile(p.kind[m], p.n_nodes), np.tile(p.t[m], p.n_nodes), np.tile(p.J[m], p.n_nodes),
                        np.tile(p.tau[m], p.n_nodes), -np.ones(node.size, int), np.zeros(node.size, int),
                        p.n_nodes, p.period)


def test_grid_sequencing_reaches_the_shooting_kink_at_dx2():
    """Discovery at spacing 4 (6 nodes), carried to 12 nodes at spacing 2: the shooting kink on that lattice."""
    lat = tps.Lattice.planar(n_nodes=12, length=22.0)
    sol = sequence_stick_kink(lat, 4.1)
    assert sol.converged and sol.checks.all_pass
    assert sol.sequence.n_nodes == [6, 12] and sol.sequence.converged == [True, True]
    assert "grid sequencing" in sol.formulation and sol.spacing == 2.0
    ref = tps.lattice_kink(lat, Gamma=4.1, e=0.0)
    assert ref.converged
    shift, t_err, tau_err = matched(sol.pattern, pattern_from_orbit(ref))
    assert shift == 0 and t_err < 1e-8 and tau_err < 1e-8


def test_refine_input_is_validated(kink_dx4):
    with pytest.raises(ValueError, match="finer than the coarse"):
        refine_stick_kink(kink_dx4, tps.Lattice.planar(n_nodes=4, length=24.0))
    with pytest.raises(ValueError, match="converged stick kink"):
        refine_stick_kink(Bunch(converged=False), tps.Lattice.planar(n_nodes=12, length=22.0))
    with pytest.raises(ValueError, match="coupling_start must be in"):
        discover_stick_kink(kink_dx4.lattice, 4.1, coupling_start=1.0)
