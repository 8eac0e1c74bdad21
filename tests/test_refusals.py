"""Calls that would run without end or allocate without bound estimate first and refuse by name."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import costs

FLAT = tps.FlatLayer(2.5, e=0.45)


def _flat_state(n):
    t = FLAT.t0 + 1.0
    return np.full(n, FLAT.velocity(t)), np.full(n, FLAT.height(t)), t


@pytest.mark.parametrize("method, kw", [("exact", {}), ("point", {}), ("soft", {"cutoff": 0.3})])
def test_simulate_refuses_a_billion_periods_with_its_estimate(method, kw):
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    w, z, t = _flat_state(5)
    with pytest.raises(ValueError, match=r"t_end = .* out of reach for simulate: estimated run time at least"):
        tps.simulate(lat, 2.5, 0.45, w, z, t_start=t, t_end=t + 1e9 * FLAT.period, method=method, **kw)


def test_simulate_refuses_a_cutoff_below_the_time_resolution():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    w, z, t = _flat_state(5)
    with pytest.raises(ValueError, match=r"cutoff = 1e-12 gives a contact of duration tau_c = cutoff\*\*2"):
        tps.simulate(lat, 2.5, 0.45, w, z, t_start=t, t_end=t + FLAT.period, method="soft", cutoff=1e-12)


def test_the_simulate_bound_is_a_lower_bound():
    """The estimate never exceeds the measured time of a fast case (a flat layer, point impacts)."""
    import time

    lat = tps.Lattice.planar(n_nodes=9, length=40.0)
    w, z, t = _flat_state(9)
    tic = time.perf_counter()
    tps.simulate(lat, 2.5, 0.45, w, z, t_start=t, t_end=t + 20 * FLAT.period, method="point")
    measured = time.perf_counter() - tic
    assert costs.simulate_cost(9, 20 * FLAT.period / (2 * np.pi))[1] < measured


@pytest.mark.parametrize("call, name", [
    (lambda: tps.check_stability(FLAT, periods=10**9), "periods"),
    (lambda: tps.flat_basins(2.5, 0.45, n_samples=10**9), "n_samples"),
    (lambda: tps.solve_stick_lattice(tps.Lattice.planar(n_nodes=9, length=40.0), n_harmonics=10**9),
     "n_harmonics"),
    (lambda: tps.solve_stick_flat(n_harmonics=10**9), "n_harmonics"),
])
def test_unbounded_sizes_are_refused_by_name(call, name):
    with pytest.raises(ValueError, match=rf"{name} = 1000000000 is out of reach for .*: estimated"):
        call()


# ------------------------------------------------------------------ no silent answers
@pytest.mark.parametrize("call, match", [
    (lambda: tps.continue_branch(FLAT, "Gamma", (2.3, 2.5, 2.7)), r"bounds must be a pair .* got 3 values"),
    (lambda: tps.continue_branch(FLAT, "Gamma", (2.4, 2.6), multipliers="yes"), "multipliers must be True or False"),
    (lambda: tps.continue_branch(FLAT, "Gamma", (2.4, 2.6), bothsides="yes"), "bothsides must be True or False"),
    (lambda: tps.find_periodic_orbit(tps.Lattice.planar(n_nodes=5, length=4.0), multipliers=1, max_iter=0),
     "multipliers must be True or False"),
    (lambda: tps.solve_stick_lattice(tps.Lattice.planar(n_nodes=9, length=40.0), 4.1, w0=np.zeros(9)),
     "w0 and zeta0 must be given together"),
    (lambda: tps.lattice_kink(tps.Lattice.planar(n_nodes=5, length=4.0), t_start=np.nan),
     "t_start must be a finite real number"),
])
def test_contradictory_or_loose_options_are_refused_by_name(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.slow
def test_lattice_kink_finds_the_kink_whose_far_field_sticks_at_e_positive():
    """Gamma = 4.5, e = 0.1 has no single-bounce flat layer; the far field is the sticking orbit
    (FlatLayer's "auto"), and the kink exists there (lattice_kink used to fail)."""
    lat = tps.Lattice.planar(n_nodes=21, length=40.0)
    orb = tps.lattice_kink(lat, Gamma=4.5, e=0.1, periods=10, max_iter=40, multipliers=False)
    assert orb.converged and orb.localized and orb.residual <= 1e-10
    assert orb.flat.pattern == "stick"


def test_shooting_probes_one_period_and_refuses_a_newton_step_out_of_reach():
    """The first period map is timed; a Newton step of krylov_dim + 2 maps beyond the limit is refused."""
    lat = tps.Lattice.planar(n_nodes=8, length=140.0)
    # above the a-priori bound (18 maps x 1.3e-4 s), below the measured pace (a map takes milliseconds)
    old = costs.set_limits(time=3e-3)
    try:
        with pytest.raises(ValueError, match=r"lattice.n_nodes = 8 is out of reach for find_periodic_orbit: "
                                             r"estimated run time .* \(one period map took"):
            tps.find_periodic_orbit(lat, section="fixed", t_start=1.0, multipliers=False)
    finally:
        costs.set_limits(**old)
    orb = tps.find_periodic_orbit(lat, section="fixed", t_start=1.0, multipliers=False)   # within the limit
    assert orb.converged


def test_the_impact_and_stick_tps_refuses_a_dense_newton_step_out_of_reach():
    old = costs.set_limits(time=0.5)
    try:
        with pytest.raises(ValueError, match=r"lattice.n_nodes = 200 is out of reach for the impact-and-stick "
                                             r"TPS: estimated run time .* 1800 unknowns"):
            tps.solve_stick_flat(Gamma=4.1, n_nodes=200, length=400.0)
    finally:
        costs.set_limits(**old)


def test_the_fault_battery_is_all_good():
    """validation/fault_battery.py: every item refused by name or answered honestly (7 of 16 at 33c4ade)."""
    from validation.fault_battery import battery

    rows = battery()
    assert [r[0] for r in rows if r[1] != "good"] == []


def test_the_impact_and_stick_tps_reports_progress_and_stops_on_ctrl_c():
    lat = tps.Lattice.planar(n_nodes=9, length=40.0)
    seen = []
    sol = tps.solve_stick_lattice(lat, 4.1, 2, 0.0, periods=20, n_basis=6, tol=1e-10,
                                  callback=lambda s: seen.append((s.stage, s.iteration)))
    assert sol.converged
    newton_steps = [k for stage, k in seen if stage == "newton"]
    assert newton_steps == list(range(1, sol.nit + 1))

    def stop(state):
        if state.stage == "newton":
            raise KeyboardInterrupt

    cut = tps.solve_stick_lattice(lat, 4.1, 2, 0.0, periods=20, n_basis=6, tol=1e-14, shoot=False, callback=stop)
    assert cut.status == 5 and not cut.converged and "interrupted" in cut.message


def test_lattice_kink_times_its_first_settling_period_and_reports_both_stages():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    old = costs.set_limits(time=0.5)         # above simulate's a-priori bound, below the measured pace
    try:
        with pytest.raises(ValueError, match=r"periods = 400 is out of reach for lattice_kink: .* \(the first "):
            tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=400)
    finally:
        costs.set_limits(**old)
    stages = []
    orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False,
                           callback=lambda s: stages.append(s.stage))
    assert orb.converged and {"simulate", "shooting"} <= set(stages)
    assert stages.index("shooting") > max(i for i, s in enumerate(stages) if s == "simulate")
