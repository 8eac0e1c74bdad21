"""tps_solver.analyses.basins: the single-node integrator against simulate and FlatLayer, the classifier, the statistics."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.analyses.basins import ball_cycle, flat_basins

TWO_PI = 2.0 * math.pi


def _orbit_box(w, z, half=1e-9):
    return dict(w_range=(w - half, w + half), zeta_range=(z - half, z + half))


def _strobe(fl, t_section, p):
    t = t_section + TWO_PI * np.arange(p)
    return np.column_stack((fl.velocity(t), fl.height(t)))


def _cyclic_distance(a, b):
    return min(np.abs(np.roll(a, s, axis=0) - b).max() for s in range(len(a)))


# ---------------------------------------------------------------- the single-ball integrator
@pytest.mark.parametrize("Gamma, e, w0, z0", [
    (2.5, 0.45, -1.3, 2.0),        # bounces, then a chatter sequence that sticks
    (2.5, 0.45, 0.7, 0.1),
    (4.1, 0.0, 1.0, 3.0),          # completely inelastic: every impact ends at rest
    (4.4, 0.1, -0.4, 0.5),
])
def test_closed_form_ball_matches_simulate_point_impacts(Gamma, e, w0, z0):
    a, ev_a = ball_cycle(Gamma, e, w0, z0, n_cycles=6)
    b, ev_b = ball_cycle(Gamma, e, w0, z0, n_cycles=6, integrator="simulate")
    assert [k for _, k in ev_a] == [k for _, k in ev_b]
    assert len(ev_a) >= 3
    # event times to 1e-9: the last impacts of a chatter sequence are slow (time error ~ eps / speed)
    np.testing.assert_allclose([t for t, _ in ev_a], [t for t, _ in ev_b], rtol=0, atol=1e-9)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)


def test_closed_form_ball_matches_simulate_soft_contact():
    a, ev_a = ball_cycle(2.5, 0.45, -1.0, 1.0, n_cycles=1, model="soft", cutoff=0.3)
    b, ev_b = ball_cycle(2.5, 0.45, -1.0, 1.0, n_cycles=1, model="soft", cutoff=0.3, integrator="simulate")
    assert len(ev_a) == len(ev_b) == 1
    assert abs(ev_a[0][0] - ev_b[0][0]) < 1e-9
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-8)         # Radau at rtol 1e-10


# ------------------------------------------------------------------------- classification
def test_f2_orbit_started_on_it_is_f2_with_the_floquet_multipliers():
    fl = tps.FlatLayer(2.5, 2, 0.45)
    ts = fl.t0 + 1.0
    res = flat_basins(2.5, 0.45, M=2, n_samples=3, seed=0, periods=20, t_section=ts,
                      **_orbit_box(fl.velocity(ts), fl.height(ts)))
    assert res.converged and res.status == 0 and len(res.attractors) == 1
    a = res.attractors[0]
    assert a.label == "f/2" and a.period == 2 and a.impacts == 1 and a.sticks == 0 and a.is_flat
    assert a.count == 3 and a.fraction == 1.0 and res.flat_fraction == 1.0
    np.testing.assert_allclose(a.multipliers, fl.floquet_multipliers(), rtol=0, atol=1e-6)
    assert a.smooth and a.stable and a.residual < 1e-12
    assert _cyclic_distance(_strobe(fl, ts, 2), a.points) < 1e-12
    assert a.phase_counts.tolist() == [3, 0]                 # all started on the same phase


def test_soft_f2_multipliers_match_the_soft_flat_orbit_monodromy():
    from tps_solver.model.soft_flat import SoftFlatOrbit  # independent reference (per-mode monodromy)
    orb = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
    ts = orb.t_exit + 1.0
    w, z = orb.state(ts)
    res = flat_basins(2.5, 0.45, n_samples=2, seed=0, model="soft", cutoff=0.3, periods=20, t_section=ts,
                      **_orbit_box(w, z))
    a = res.attractors[0]
    assert a.label == "f/2" and a.count == 2
    ref = np.linalg.eigvals(orb.monodromy(0.0)[0])
    ref = ref[np.argsort(-np.abs(ref), kind="stable")]
    np.testing.assert_allclose(np.sort_complex(a.multipliers), np.sort_complex(ref), rtol=0, atol=1e-6)


def test_e0_gamma41_every_sample_reaches_the_sticking_f2_orbit():
    res = flat_basins(4.1, 0.0, M=2, n_samples=16, seed=3, periods=40)
    assert res.converged and len(res.attractors) == 1
    a = res.attractors[0]
    assert a.period == 2 and a.sticks == 1 and a.is_flat and a.count == 16
    assert a.multipliers.tolist() == [0, 0]                  # sticking resets the map
    fl = tps.FlatLayer(4.1, 2, e=0.0)                        # independent: the "stick" orbit, "TS"
    assert fl.pattern == "stick"
    assert _cyclic_distance(_strobe(fl, 0.0, 2), a.points) < 1e-12
    assert a.phase_counts.sum() == 16 and min(a.phase_counts) > 0   # both phases occur


@pytest.mark.parametrize("Gamma, M_orbit, period", [(4.4, 2, 2), (4.1, 4, 4)])
def test_chatter_stick_cycles_match_flatlayer_stick_orbits(Gamma, M_orbit, period):
    res = flat_basins(Gamma, 0.1, M=2, n_samples=8, seed=0, periods=60)
    a = res.attractors[0]
    assert a.count == 8 and a.period == period and a.sticks == 1 and a.impacts > 1
    fl = tps.FlatLayer(Gamma, M_orbit, e=0.1, pattern="stick")   # chatter summed in closed form there
    assert _cyclic_distance(_strobe(fl, 0.0, period), a.points) < 1e-9
    assert np.all(a.multipliers == 0)


def test_reference_case_is_multistable_with_reproducible_fractions():
    a = flat_basins(2.5, 0.45, n_samples=24, seed=5)
    b = flat_basins(2.5, 0.45, n_samples=24, seed=5)
    assert a.labels.tolist() == b.labels.tolist() and a.fractions == b.fractions
    labels = {x.label for x in a.attractors}
    assert "f/2" in labels and "f/5 (21 impacts, 1 stick)" in labels
    f2 = next(x for x in a.attractors if x.label == "f/2")
    assert f2.fraction < 0.5                                 # the f/2 basin is small (docs/design.md, hazard 9)
    n = a.n_samples
    for x in a.attractors:
        assert x.stderr == pytest.approx(math.sqrt(x.fraction * (1 - x.fraction) / n), rel=1e-15)
        assert x.interval[0] <= x.fraction <= x.interval[1]
    assert sum(x.count for x in a.attractors) + a.irregular.count == n
    # the first n samples of a larger run are the samples of the smaller one
    c = flat_basins(2.5, 0.45, n_samples=8, seed=5)
    np.testing.assert_array_equal(c.initial_states, a.initial_states[:8])
    lab = {i: x.label for i, x in enumerate(a.attractors)}
    lab_c = {i: x.label for i, x in enumerate(c.attractors)}
    assert [lab_c[k] for k in c.labels] == [lab[k] for k in a.labels[:8]]


def test_store_resume_gives_the_same_result(tmp_path):
    first = flat_basins(4.1, 0.1, n_samples=6, seed=2, periods=40, store=tmp_path / "b")
    assert len(list((tmp_path / "b").glob("*.npz"))) == 6
    again = flat_basins(4.1, 0.1, n_samples=6, seed=2, periods=40, store=tmp_path / "b")
    assert again.labels.tolist() == first.labels.tolist()
    np.testing.assert_array_equal(again.attractors[0].points, first.attractors[0].points)


def test_not_settled_is_irregular_with_a_message():
    res = flat_basins(2.5, 0.45, n_samples=4, seed=0, periods=2, p_max=2, tol=1e-14)
    assert not res.converged and res.status == 1
    assert res.irregular.count == 4 and res.fractions["irregular"] == 1.0
    assert "raise periods or p_max" in res.message
    assert sum(c for c, _ in res.irregular.near_periods.values()) == 4


def test_event_bound_marks_failed_samples():
    res = flat_basins(2.5, 0.45, n_samples=4, seed=0, periods=10, p_max=4, max_events_per_cycle=2)
    assert res.status == 6 and not res.converged and np.any(res.labels == -2)
    assert "failed" in res.fractions and "max_events_per_cycle" in res.message


def test_soft_sticking_rule_restores_the_sticking_f2_orbit():
    res = flat_basins(4.4, 0.1, n_samples=6, seed=0, model="soft", cutoff=0.3, periods=40, soft_sticking=True)
    a = res.attractors[0]
    assert res.converged and a.count == 6 and a.period == 2 and a.sticks == 1


# ------------------------------------------------------------------------------ bad input
@pytest.mark.parametrize("kwargs, match", [
    (dict(Gamma=0.0), "Gamma must be a finite number > 0"),
    (dict(e=1.0), r"e must be a finite number in \[0.0, 1.0\)"),
    (dict(model="hard"), "model must be one of 'point', 'soft'"),
    (dict(model="soft"), "cutoff must be a finite number > 0 when model='soft'"),
    (dict(model="soft", cutoff=-0.3), "cutoff must be a finite number > 0"),
    (dict(model="soft", cutoff=3.0), r"cutoff must give a contact time cutoff\*\*2 < 2\*pi"),
    (dict(cutoff=0.3), "cutoff is only used with model='soft'"),
    (dict(e=0.0, model="soft", cutoff=0.3), r"e must be in \(0, 1\) for model='soft'"),
    (dict(n_samples=0), "n_samples must be an integer >= 1"),
    (dict(seed=-1), "seed must be an integer >= 0"),
    (dict(periods=0), "periods must be an integer >= 1"),
    (dict(periods=4), "periods must give at least 2 \\* p_max"),
    (dict(tol=0.0), "tol must be a finite number > 0"),
    (dict(w_range=(1.0, 1.0)), "w_range must be .* low < high"),
    (dict(zeta_range=(-1.0, 1.0)), r"zeta_range must lie in \[0.0, inf\)"),
    (dict(zeta_range=(0.0, np.nan)), "zeta_range must contain only finite values"),
    (dict(integrator="rk4"), "integrator must be one of"),
    (dict(soft_sticking=True), "soft_sticking=True needs model='soft'"),
    (dict(M=0), "M must be an integer >= 1"),
])
def test_bad_input_raises_naming_the_parameter(kwargs, match):
    args = dict(Gamma=2.5, e=0.45, n_samples=2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        flat_basins(**args)


def test_ball_cycle_bad_input():
    with pytest.raises(ValueError, match="zeta0 must be >= 0 for point impacts"):
        ball_cycle(2.5, 0.45, 0.0, -1.0)
    with pytest.raises(ValueError, match="n_cycles must be an integer >= 1"):
        ball_cycle(2.5, 0.45, 0.0, 1.0, n_cycles=0)
    with pytest.raises(ValueError, match="stuck=True needs"):
        ball_cycle(2.5, 0.45, 1.0, 1.0, stuck=True)


@pytest.mark.slow
def test_soft_chatter_matches_simulate_over_several_cycles():
    a, ev_a = ball_cycle(4.4, 0.1, -0.4, 0.5, n_cycles=3, model="soft", cutoff=0.3)
    b, ev_b = ball_cycle(4.4, 0.1, -0.4, 0.5, n_cycles=3, model="soft", cutoff=0.3, integrator="simulate")
    assert len(ev_a) == len(ev_b) >= 4
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-7)


@pytest.mark.slow
def test_fractions_converge_with_the_number_of_samples():
    small = flat_basins(2.5, 0.45, n_samples=64, seed=11)
    large = flat_basins(2.5, 0.45, n_samples=512, seed=11)
    fs, fl = small.fractions.get("f/2", 0.0), large.fractions.get("f/2", 0.0)
    err = math.hypot(small.stderr.get("f/2", 0.0), large.stderr.get("f/2", 0.0))
    assert abs(fs - fl) < 3 * max(err, 1 / 64)
    assert large.stderr["f/2"] < small.stderr["f/2"]


@pytest.mark.parametrize("Gamma, e", [(3.25, 0.05), (3.0, 0.1), (2.5, 0.2)])
def test_f1_orbit_with_multiplier_near_minus_one_is_not_counted_as_f2(Gamma, e):
    # found by validation/existence_map.py: the f/1 bounce (multiplier near -1) repeats after two
    # cycles before it repeats after one; it must be classified f/1
    res = flat_basins(Gamma, e, n_samples=4, seed=0)
    assert res.flat_fraction == 0.0
    assert res.attractors[0].period == 1 and res.attractors[0].label.startswith("f/1")
