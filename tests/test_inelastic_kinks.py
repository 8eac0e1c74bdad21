"""The e = 0 kinks (validation/inelastic_kinks.py): the contact-pattern analysis on hand-built
event lists, the core-radius measure on a hand-built profile, and (slow) the Gamma = 4.1, dx = 2
kink against the numbers of validation/sections/shooting.md."""
import math

import numpy as np
import pytest

from validation.inelastic_kinks import contact_pattern, convergence, core_radius, kink_row


def _events(records):
    return np.rec.fromrecords(records, names="t,node,kind")


def test_contact_pattern_hand_built():
    T = 4 * math.pi
    # node 0: flat-layer pattern (lift-off, touch-and-go, stick); node 1 lifts off exactly when
    # node 0 sticks (triggered); node 2 lifts off 1e-6 after node 1 touches (not triggered) and
    # its stick lies across the section (event order starts with the stick)
    ev = _events([(0.5, 2, "stick"), (1.0, 0, "liftoff"), (3.0, 1, "impact"), (3.000001, 2, "liftoff"),
                  (5.0, 0, "impact"), (6.0, 0, "stick"), (6.0, 1, "liftoff"), (7.0, 1, "stick"),
                  (9.0, 2, "impact")])
    p = contact_pattern(ev, 3, T, stuck0=[False, True, False])
    assert p["sequences"] == ["L T S", "L* S T", "L T S"]
    assert p["triggered"] == 1 and p["triggered_nodes"] == [1]
    assert p["histogram"] == {"L T S": 2, "L* S T": 1}
    assert p["contacts"] == {2: 3}
    assert (p["touch_and_go"], p["sticks"], p["liftoffs"], p["stuck_at_section"]) == (3, 3, 3, 1)


def test_contact_pattern_trigger_wraps_the_period():
    T = 10.0
    # a lift-off at the start of the period triggered by a neighbour's landing at its end
    ev = _events([(1e-12, 0, "liftoff"), (T - 1e-12, 1, "stick"), (4.0, 0, "stick"), (5.0, 1, "liftoff")])
    p = contact_pattern(ev, 2, T)
    assert p["sequences"] == ["L* S", "L S"]
    p = contact_pattern(ev, 2, T, trigger_tol=1e-13)
    assert p["triggered"] == 0


def test_core_radius_and_convergence_hand_built():
    r = np.arange(6.0)
    z = np.array([2.0, 2.0, 1.5, 0.5, 0.0, 0.0])          # z_in = 2, z_out = 0: theta = 0.5 at r = 2.5
    assert core_radius(r, z, 2.0, 0.0) == pytest.approx(2.5)
    assert core_radius(r, np.zeros(6), 2.0, 0.0) == 0.0
    # widths 1 + dx**2: differences 3, 0.75, 0.1875 -> order 2, Richardson value 1
    rows = [dict(converged=True, dx=dx, width=[1 + dx ** 2, 0.0]) for dx in (2.0, 1.0, 0.5, 0.25)]
    c = convergence(rows)
    assert c["orders"] == pytest.approx([2.0, 2.0]) and c["richardson"] == pytest.approx(1.0)
    rows[1]["width"] = [0.5, 0.0]
    assert math.isnan(convergence(rows)["richardson"]) and not convergence(rows)["monotone"]


@pytest.mark.slow
def test_gamma41_dx2_kink_matches_shooting_section():
    # validation/sections/shooting.md, dx = 2: 10 Newton steps, 2 contacts per node (all),
    # 21/21 nodes sticking, leading |mu| 0.9828, 0.214, 0.039, front width 9.01
    row = kink_row(4.1, 2.0)
    assert row["converged"] and row["residual"] < 1e-10
    assert row["width"] == pytest.approx([9.01, 9.01], abs=0.01)
    assert row["abs_mu"] == pytest.approx([0.9828, 0.214, 0.039], abs=1e-3)
    p = row["pattern"]
    assert p["contacts"] == {2: 21} and row["sticking_nodes"] == 21
    # every node sticks every period; the kinds per node are a regression pin of this module's
    # measurement (validation/sections/inelastic_kinks.md; not in shooting.md): 20 nodes have the
    # flat orbit's lift-off, touch-and-go, stick and one node at the front sticks twice
    assert all("S" in s for s in p["sequences"])
    kinds = sorted(s.replace("*", "") for s in p["sequences"])
    assert kinds == ["L S L S"] + ["L T S"] * 20
    assert row["defect10"] < 1e-10


@pytest.mark.slow
def test_e0_oscillon_core_collapses_by_curvature():
    # the planar e = 0 kink is a periodic orbit (neutral front); a circular core must shrink, and a
    # curvature-driven collapse has R dR/dk constant: the first- and second-half fits of R**2
    # must agree (validation/sections/inelastic_kinks.md: R dR/dk = -5.59 per period at dr = 1)
    from validation.inelastic_kinks import fit_radii, oscillon_rates

    row, = oscillon_rates(4.1, R0s=(20.0,), r_max=60.0, dr=1.0, periods=30)
    R = np.asarray(row["radii"])
    assert row["status"] == 0 and R[-1] < 3.0 and np.all(np.diff(R[1:]) <= 0.0)
    assert -8.0 < row["R_dRdk"] < -4.0
    early = fit_radii(R[:15], 1.0, 60.0)[2]
    late = 0.5 * np.polyfit(np.arange(15, 26), R[15:26] ** 2, 1)[0]
    assert late == pytest.approx(early, rel=0.15)
