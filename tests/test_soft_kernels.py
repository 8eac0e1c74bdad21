"""The compiled step loop of SoftIntegrator (tps_solver.solvers.fda.soft_kernels) against the numpy path,
a dense solve, the closed-form soft flat orbit and the Radau reference."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import jit
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.solvers.fda import kink_state, simulate
from tps_solver.solvers.fda.soft import SoftIntegrator

pytestmark = pytest.mark.skipif(not jit.enabled(), reason="numba (the fast extra) is not installed or disabled")

GAMMA, E, M, ELL = 2.5, 0.45, 2, 0.3
EPS = np.finfo(float).eps


def _drive(integ, t, w, z, t_end, t_eval=()):
    stuck = np.zeros(w.size, bool)
    events, samples = [], []
    while t < t_end:
        s = integ.advance(t, w, z, stuck, t_end, t_eval)
        t, w, z, stuck = s.t, s.w, s.zeta, s.stuck
        events += s.events
        samples += s.samples
    return w, z, events, samples


def _kink(n, length):
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=n, length=length, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    return fl, lat, t0, w, z


def test_tridiagonal_solve_matches_a_dense_solve_with_row_interchanges():
    from tps_solver.solvers.fda.soft_kernels import tridiagonal_solve

    rng = np.random.default_rng(5)
    m, n = 3, 11
    cplx = lambda *shape: rng.standard_normal(shape) + 1j * rng.standard_normal(shape)   # noqa: E731
    dl, du, b = cplx(m, n - 1), cplx(m, n - 1), cplx(m, n)
    d = 0.1 * cplx(m, n)                          # small diagonal: most rows are interchanged
    x = b.copy()
    assert tridiagonal_solve(dl.copy(), d.copy(), du.copy(), x)
    for k in range(m):
        A = np.diag(d[k]) + np.diag(dl[k], -1) + np.diag(du[k], 1)
        ref = np.linalg.solve(A, b[k])
        assert np.max(np.abs(x[k] - ref)) <= 100 * EPS * np.linalg.cond(A) * np.max(np.abs(ref))
    # a zero pivot is reported, not divided by
    d0 = d.copy()
    d0[1, 0] = dl[1, 0] = 0.0
    assert not tridiagonal_solve(dl.copy(), d0, du.copy(), b.copy())


def test_numba_and_numpy_paths_agree_event_for_event_on_a_kink_with_sticking():
    """Nine-node kink over two periods (impacts, lift-offs, held nodes and releases): same events,
    event times and output samples to rounding (the kink amplifies rounding by about 1e2 here)."""
    fl, lat, t0, w, z = _kink(9, 8.0)
    t_end = t0 + 2.0 * fl.period
    t_eval = t0 + fl.period * np.arange(1, 5) / 2
    runs = []
    for compiled in (False, True):
        integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled=compiled)
        assert integ.compiled is compiled
        runs.append((_drive(integ, t0, w, z, t_end, t_eval), integ.n_steps))
    (wa, za, ea, sa), na = runs[0]
    (wb, zb, eb, sb), nb = runs[1]
    kinds = {ev[2] for ev in ea}
    assert kinds == {"impact", "liftoff", "stick"}
    assert [ev[1:3] for ev in ea] == [ev[1:3] for ev in eb]
    assert max(abs(x[0] - y[0]) for x, y in zip(ea, eb)) <= 1e-12
    assert max(abs(x[3] - y[3]) for x, y in zip(ea, eb)) <= 1e-11
    assert abs(na - nb) <= 0.01 * na          # same steps; a switch search may end one Newton step apart
    assert len(sa) == len(sb) == 4
    for (ta, wsa, zsa), (tb, wsb, zsb) in zip(sa, sb):
        assert ta == tb
        assert np.max(np.abs(wsa - wsb)) <= 1e-11 and np.max(np.abs(zsa - zsb)) <= 1e-11
    assert np.max(np.abs(wa - wb)) <= 1e-11 and np.max(np.abs(za - zb)) <= 1e-11


@pytest.mark.parametrize("compiled", [False, True])
def test_perturbed_flat_lattice_contact_times_match_the_closed_form(compiled):
    """Five nodes on the soft flat orbit, heights perturbed by 1e-9: every node enters at t_exit + F
    (mod T) and leaves tau_c later to first order in the perturbation (1e-9 times the slopes, measured
    below 1e-8), over three periods; both paths."""
    orb = SoftFlatOrbit(GAMMA, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    ts = orb.t_exit + 0.5 * orb.flight
    w0, z0 = orb.state(ts)
    z = np.full(5, z0) + 1e-9 * np.linspace(0.0, 1.0, 5) ** 2
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled=compiled)
    _, _, events, _ = _drive(integ, ts, np.full(5, w0), z, ts + 3 * orb.period)
    imp = np.array([ev[0] for ev in events if ev[2] == "impact"])
    out = np.array([ev[0] for ev in events if ev[2] == "liftoff"])
    assert imp.size == out.size == 15
    k = np.round((imp - orb.t_exit - orb.flight) / orb.period)
    t_in = orb.t_exit + orb.flight + k * orb.period
    assert np.max(np.abs(imp - t_in)) < 1e-7
    assert np.max(np.abs(out - (t_in + orb.tau_c))) < 1e-7


def test_compiled_path_matches_radau_on_a_small_kink():
    """Independent reference: scipy Radau (rtol 1e-11) over half a period of a five-node kink."""
    fl, lat, t0, w, z = _kink(5, 4.0)
    t_end = t0 + 0.5 * fl.period
    ref = simulate(lat, GAMMA, E, w, z, t0, t_end, method="soft-radau", cutoff=ELL, rtol=1e-11, atol=1e-12)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, stick_speed=0.0, compiled=True)
    wf, zf, events, _ = _drive(integ, t0, w, z, t_end)
    assert ref.n_events == sum(ev[2] == "impact" for ev in events) >= 1
    assert np.max(np.abs(wf - ref.w)) < 1e-8 and np.max(np.abs(zf - ref.zeta)) < 1e-8
    assert abs(events[0][0] - ref.events.t[0]) < 1e-8


def test_compiled_option_is_checked():
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    with pytest.raises(ValueError, match="compiled must be True, False or None"):
        SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled="yes")
    assert SoftIntegrator(lat, GAMMA, E, cutoff=ELL).compiled is True
    assert SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled=False).compiled is False
