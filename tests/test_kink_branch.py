"""validation/kink_branch.py: the e = 0 kink's Gamma-branch against independent shooting solves."""
import numpy as np
import pytest

from validation.kink_branch import gamma_branch, independent_points


@pytest.mark.slow
def test_gamma_branch_coarse_against_independent_solves():
    # dx = 4 (11 nodes), Gamma in [4.0, 4.4] (about 2 minutes): every branch point is a periodic
    # orbit (its period defect is at shooting's tolerance), the branch leaves the interval at both
    # ends, and shooting from its own default start at two values of Gamma finds the branch's
    # orbit or its mirror image: the same leading multiplier and state.  (At Gamma = 4.05 shooting
    # from its default start converges to the other, unstable pinned kink: |mu1| = 1.038 against
    # the branch's 0.972; not a branch point.)
    res = gamma_branch(dx=4.0, bounds=(4.0, 4.4), bothsides=True)
    br = res["branch"]
    assert br.status == 0
    assert br.parameter_values.min() <= 4.0 and br.parameter_values.max() >= 4.4
    defects = np.array([r["period_defect"] for r in res["rows"]])
    assert np.all(defects < 1e-9)
    widths = np.array([r["width"] for r in res["rows"]])
    assert np.all(np.isfinite(widths)) and np.all(widths > 0)
    for row in independent_points(res, [4.2, 4.35]):
        assert row["independent_converged"] and row["branch_converged"]
        assert row["mu1_difference"] < 1e-5
        assert row["state_difference"] < 1e-7


def test_retrace_after_a_jump_is_cut():
    """A branch that jumps at its largest Gamma and comes back over its own points is cut before the jump;
    a branch that turns at a genuine fold onto new points is kept whole."""
    from validation.kink_branch import _retrace

    up = np.linspace(3.9, 4.5, 13)
    mu = 1.0 + 0.1 * (up - 4.25)
    retraced = np.concatenate((up, [4.6], up[::-1][1:]))
    mu_r = np.concatenate((mu, [1.2], mu[::-1][1:]))
    assert _retrace(retraced, mu_r) == 13
    folded = np.concatenate((up, up[::-1][1:]))
    assert _retrace(folded, np.concatenate((mu, mu[::-1][1:] + 0.05))) is None
    assert _retrace(up, mu) is None
