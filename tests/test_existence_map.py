"""Tests of the existence-stability map (validation/existence_map.py): classification rules and a fast subset."""
import math

import numpy as np
import pytest

import tps_solver as tps
from validation import existence_map as em


# ------------------------------------------------------------ verdict rules (exact behaviour)
def test_verdict_settles_when_periodic_and_bounded():
    assert em.verdict([1e-2, 1e-5, 1e-8], [0.4, 0.4, 0.0], [20.0, 20.0, 20.0], 40.0) == ("settles", None)


def test_verdict_invades_with_least_squares_width_rate_before_saturation():
    # widths 2, 12, 22 grow by 10 per period, then 38 >= 0.8 * 40 saturates: the rate uses 2, 12, 22, 38
    label, rate = em.verdict([3.0] * 5, [2.0, 12.0, 22.0, 38.0, 40.0], [20.0] * 5, 40.0)
    assert label == "invades"
    assert rate == pytest.approx(np.polyfit([0, 1, 2, 3], [2.0, 12.0, 22.0, 38.0], 1)[0], rel=1e-12)


def test_verdict_invades_on_growth_alone():
    assert em.verdict([1.0] * 3, [1.0, 3.0, 6.0], [20.0] * 3, 40.0, front_max=4.0)[0] == "invades"


def test_verdict_drift_and_collapse():
    label, rate = em.verdict([0.1] * 4, [0.0] * 4, [20.0, 21.0, 22.0, 23.0], 40.0)
    assert label == "drifts" and rate == pytest.approx(1.0, rel=1e-12)
    label, rate = em.verdict([0.1, 0.1, 0.0], [0.0] * 3, [20.0, 22.0, 0.0], 40.0, alive=[True, True, False])
    assert label == "collapses" and rate == pytest.approx(2.0)


def test_verdict_stationary_when_frozen_but_not_periodic():
    assert em.verdict([1e-3] * 4, [6.8] * 4, [20.0] * 4, 40.0) == ("stationary", None)


def test_verdict_undecided_when_the_width_still_changes():
    assert em.verdict([1e-3] * 4, [0.0, 1.0, 0.4, 1.2], [20.0] * 4, 40.0) == ("undecided", None)


def test_select_front_points_threshold_thinning_and_control():
    rows = [dict(Gamma=1.5 + 0.25 * k, e=0.0, flat_fraction=1.0) for k in range(10)]
    pts = em.select_front_points(rows, max_points=4, control=(2.5, 0.45))
    assert len(pts) == 5 and pts[-1] == (2.5, 0.45)
    assert pts[0] == (1.5, 0.0) and pts[-2] == (3.75, 0.0)       # ends kept
    assert em.select_front_points([dict(Gamma=2.0, e=0.1, flat_fraction=0.49)], control=None) == []


def test_docstring_examples_of_the_module():
    import doctest
    result = doctest.testmod(em, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0 and result.attempted >= 8


# ------------------------------------------------------------------- flat layer pieces
def test_flat_orbit_pattern_choice_matches_flatlayer_patterns():
    assert em.flat_orbit(2.5, 0.45).pattern == "bounce"
    assert em.flat_orbit(4.0, 0.0).pattern == "stick"
    assert em.flat_orbit(1.5, 0.45) is None                       # below the fold s*pi*M = 2.38
    lo, _ = tps.FlatLayer.stability_window(0.45, 2)
    assert lo == pytest.approx((1 - 0.45) / (1 + 0.45) * math.pi * 2, rel=1e-12)


def test_flat_count_is_one_bounce_or_impact_plus_stick():
    assert em.flat_count(tps.FlatLayer(2.5, 2, e=0.45)) == 1
    assert em.flat_count(tps.FlatLayer(4.0, 2, e=0.0, pattern="stick")) == 2


def test_basins_reproduce_the_issue_statements():
    """e = 0, Gamma = 4: every start reaches f/2; Gamma = 2.5, e = 0.45: only 0-2 of 16 (docs/design.md, hazard 9)."""
    b0 = em.basin_point(4.0, 0.0, n_samples=16, periods=60)
    assert b0["flat_fraction"] == 1.0 and b0["flat_mu"] == 0.0 and b0["pattern"] == "stick"
    b1 = em.basin_point(2.5, 0.45, n_samples=16, periods=60)
    assert b1["flat_fraction"] <= 2 / 16
    assert b1["flat_mu"] == pytest.approx(0.45, abs=1e-6)        # the single bounce: |mu| = e
    assert b1["flat_stderr"] == pytest.approx(math.sqrt(b1["flat_fraction"] * (1 - b1["flat_fraction"]) / 16))


# ------------------------------------------------------------------ fronts (fast subset)
@pytest.fixture(scope="module")
def kink_e0():
    return em.front_run("kink", 4.0, 0.0, dx=0.8, extent=24.0, periods=8, keep_state=False,
                        config=dict(n_samples=8, basin_periods=40))


@pytest.mark.slow
def test_inelastic_kink_relaxes_to_a_stationary_single_pattern_front(kink_e0):
    d = np.array(kink_e0["defects"])
    assert kink_e0["ref_count"] == 2 and kink_e0["periods_run"] == 8
    assert np.all(np.diff(d) < 0) and d[-1] < 1e-4 < d[0]        # converging to a periodic state
    assert max(kink_e0["widths"][1:]) == 0.0                       # every node: impact + stick, like the flat layer
    assert len(set(kink_e0["fronts"])) == 1 and all(kink_e0["alive"])   # the front neither moves nor collapses


@pytest.mark.slow
def test_paper_case_kink_front_launches_a_multi_contact_state():
    r = em.front_run("kink", 2.5, 0.45, dx=0.8, extent=24.0, periods=2, keep_state=False,
                     config=dict(n_samples=16, basin_periods=60))
    assert r["ref_count"] == 1
    assert r["widths"][-1] > r["widths"][0] > 0.0                  # the disordered region grows
    assert r["invader"] > 1.0                                      # more than one contact per node and period
    assert r["verdict"] == "invades" and r["speed"] > 0.0


def test_no_f2_attractor_is_reported_not_simulated():
    r = em.front_run("kink", 1.5, 0.45, dx=0.8, extent=8.0, periods=1, config=dict(n_samples=8, basin_periods=40))
    assert r["verdict"] == "no f/2 attractor" and "defects" not in r


def test_f1_cycle_labelled_f2_by_flat_basins_is_not_counted():
    """At (3.25, 0.05) the f/1 bounce (one-cycle multiplier near -1) repeats after two cycles first;
    flat_basins used to call it period 2 (found by this study) and now classifies it f/1, so neither the
    library nor the map counts it as an f/2 state."""
    b = em.basin_point(3.25, 0.05, n_samples=8, periods=60)
    assert b["library_flat_fraction"] == 0.0
    assert b["flat_fraction"] == 0.0 and b["f1_as_f2"] == 0.0
    assert em.flat_phases(3.25, 0.05, n_samples=8, periods=60) is None
