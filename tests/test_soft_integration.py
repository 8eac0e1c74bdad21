"""The regularised (soft-contact) model wired into simulate/check_stability, and cut-off reporting."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.model.soft_flat import SoftFlatOrbit
from validation.impact_rules import regularised_impact


def make_flat():
    return tps.FlatLayer(2.5, 2, e=0.45)


def test_simulate_soft_follows_the_soft_flat_orbit():
    orb = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    ts = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(ts)
    run = tps.simulate(lat, 2.5, 0.45, np.full(5, float(w)), np.full(5, float(z)), t_start=ts,
                       t_end=ts + orb.period, method="soft", cutoff=0.3)
    assert run.success and run.cutoff["kind"] == "soft contact" and run.cutoff["length"] == 0.3
    assert np.max(np.abs(run.zeta - z)) < 1e-7 and np.max(np.abs(run.w - w)) < 1e-7


def test_soft_uniform_multipliers_match_closed_form_monodromy():
    """check_stability's finite differences of the soft lattice period map (uniform mode) against
    the closed-form soft monodromy; and the closed form tends to (17)-(19) like cutoff^2."""
    fl = make_flat()
    chk = tps.check_stability(fl, periods=3, n_nodes=3, length=2.0, method="soft", cutoff=0.3)
    orb = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
    mu = np.linalg.eigvals(orb.monodromy(0.0, t_section=chk.section_time)[0])
    # finite differences (step 1e-6) of an adaptive Radau run (rtol 1e-10) carry ~1e-4 noise
    assert np.max(np.abs(np.sort_complex(chk.uniform_multipliers) - np.sort_complex(mu))) < 2e-3
    errs = []
    for ell in (0.1, 0.05):
        m = np.linalg.eigvals(SoftFlatOrbit(2.5, 2, 0.45, ell).monodromy(0.0)[0])
        errs.append(np.max(np.abs(np.sort_complex(m) - np.sort_complex(fl.floquet_multipliers()))))
    assert 3.0 < errs[0] / errs[1] < 5.0          # second order in the cut-off


@pytest.mark.parametrize("method,kw,limited", [
    ("exact", {}, True),                       # point impacts: always cut-off-limited
    ("soft", dict(cutoff=0.3), True),          # spacing 2 > cutoff / 4
])
def test_cutoff_limited_flag_and_message(method, kw, limited):
    chk = tps.check_stability(make_flat(), periods=3, n_nodes=3, length=8.0, method=method, **kw)
    assert chk.cutoff_limited is limited
    assert ("cut-off-limited" in chk.message) is limited
    assert chk.cutoff["length"] is not None


def test_declared_cutoff_of_a_rule_is_recorded():
    fl = make_flat()
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    rule = regularised_impact("kernel", 0.5)
    t = fl.t0 + 1.0
    run = tps.simulate(lat, 2.5, 0.45, np.full(5, fl.velocity(t)), np.full(5, fl.height(t)),
                       t_start=t, t_end=t + 1.0, impact=rule)
    assert run.cutoff["length"] == 0.5


@pytest.mark.parametrize("kwargs,match", [
    (dict(method="soft"), "cutoff"),
    (dict(method="soft", cutoff=-1.0), "cutoff"),
    (dict(method="exact", cutoff=0.3), "cutoff"),
    (dict(method="soft", cutoff=0.3, impact="diffused", rho_c=0.1), "impact"),
])
def test_bad_soft_input(kwargs, match):
    fl = make_flat()
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t = fl.t0 + 1.0
    with pytest.raises(ValueError, match=match):
        tps.simulate(lat, 2.5, 0.45, np.full(5, fl.velocity(t)), np.full(5, fl.height(t)),
                     t_start=t, t_end=t + 1.0, **kwargs)
