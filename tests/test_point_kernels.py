"""The compiled contact search of PointIntegrator (tps_solver.solvers.fda.point_kernels) against the numpy path."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import jit
from tps_solver.solvers.fda import flat_state, kink_state
from tps_solver.solvers.fda.point import PointIntegrator

pytestmark = pytest.mark.skipif(not jit.enabled(), reason="numba (the fast extra) is not installed or disabled")


def _both(lattice, Gamma, e, w, z, t0, t1, **kw):
    a = tps.simulate(lattice, Gamma, e, w, z, t_start=t0, t_end=t1, method="point", compiled=False, **kw)
    b = tps.simulate(lattice, Gamma, e, w, z, t_start=t0, t_end=t1, method="point", compiled=True, **kw)
    return a, b


def _assert_same(a, b, time_tol, state_tol):
    assert a.status == b.status == 0
    assert a.events.size == b.events.size > 0
    assert np.array_equal(a.events.node, b.events.node) and np.array_equal(a.events.kind, b.events.kind)
    assert np.max(np.abs(a.events.t - b.events.t)) <= time_tol
    assert np.max(np.abs(a.w - b.w)) <= state_tol and np.max(np.abs(a.zeta - b.zeta)) <= state_tol


def _flat_case(n, length):
    fl = tps.FlatLayer(2.5, 2, 0.45)
    lat = tps.Lattice.planar(n_nodes=n, length=length)
    t0 = fl.t0 + 1e-6
    w, z = flat_state(lat, fl, t0)
    return lat, fl, w, z, t0


@pytest.mark.parametrize("n,length", [(21, 10.0), (101, 10.0), (21, 40.0)])
def test_flat_lattice_same_events(n, length):
    lat, fl, w, z, t0 = _flat_case(n, length)
    a, b = _both(lat, 2.5, 0.45, w, z, t0, t0 + 10 * fl.period + 0.5)
    _assert_same(a, b, 1e-13, 1e-13)
    # and both on the flat orbit's contacts t0 + kT
    k = np.round((b.events.t - fl.t0) / fl.period)
    assert np.max(np.abs(b.events.t - (fl.t0 + k * fl.period))) <= 1e-13


def test_kink_same_events():
    fl = tps.FlatLayer(2.5, 2, 0.45)
    lat = tps.Lattice.planar(n_nodes=41, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    a, b = _both(lat, 2.5, 0.45, w, z, t0, t0 + 2 * fl.period)
    _assert_same(a, b, 1e-12, 1e-12)


def test_sticking_e0_kink_same_events():
    """e = 0: every node lands, sticks and lifts off (free sets change at every event)."""
    fl = tps.FlatLayer(4.1, 2, 0.0, pattern="stick")
    lat = tps.Lattice.planar(n_nodes=21, length=20.0)
    t0 = 0.25 * fl.period
    w, z = kink_state(lat, fl, t0)
    a, b = _both(lat, 4.1, 0.0, w, z, t0, t0 + 3 * fl.period)
    assert np.count_nonzero(b.events.kind == "stick") > 0 and np.count_nonzero(b.events.kind == "liftoff") > 0
    _assert_same(a, b, 1e-12, 1e-12)


def test_chatter_same_events():
    """The perturbed flat layer at dx = 0.5 breaks up into chatter; the first periods agree to 1e-12."""
    lat, fl, w, z, t0 = _flat_case(21, 10.0)
    z = z + 1e-6 * np.linspace(0.0, 1.0, z.size) ** 2
    a, b = _both(lat, 2.5, 0.45, w, z, t0, t0 + 4 * fl.period)
    _assert_same(a, b, 1e-12, 1e-12)


def test_option_validation():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    with pytest.raises(ValueError, match="compiled must be True, False or None"):
        PointIntegrator(lat, 2.5, 0.45, compiled="yes")
    assert PointIntegrator(lat, 2.5, 0.45).compiled is True
    assert PointIntegrator(lat, 2.5, 0.45, compiled=False).compiled is False


def test_search_bound_raises_compiled():
    lat, fl, w, z, t0 = _flat_case(5, 4.0)
    prop = PointIntegrator(lat, 2.5, 0.45, compiled=True, max_steps=2)
    with pytest.raises(RuntimeError, match="contact search made 2 steps"):
        prop.advance(t0, w, z, np.zeros(5, bool), t0 + 100.0)
