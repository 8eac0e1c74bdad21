"""Run modes of the exact integrator (tps_solver.solvers.fda.runs) against the whole-free-set modes.

References: the closed-form spectra of the discrete Dirichlet/Neumann Laplacian, ``eigvalsh`` of the
lattice's own operator blocks, and the dense decomposition of the whole free set
(``ExactPropagator(modes="free_set")``, the old path) as a second method, event for event.
"""
import numpy as np
import pytest
from scipy.linalg import eigvalsh

import tps_solver as tps
from tps_solver.core import jit
from tps_solver.solvers.fda.exact import Modes, Segment
from tps_solver.solvers.fda.runs import ClosedRun, RunCache, RunModes, Tridiagonal, free_runs
from tps_solver.solvers.fda.states import flat_state, kink_state

EPS = np.finfo(float).eps


def _symmetric_block(lat, a, b):
    v = np.sqrt(lat.volumes[a:b])
    S = lat.flux[a:b, a:b] / v[:, None] / v[None, :]
    return 0.5 * (S + S.T)


@pytest.mark.parametrize("m", [1, 2, 3, 8, 33])
def test_dirichlet_run_has_the_discrete_sine_spectrum(m):
    # interior run of m nodes, both neighbours stuck: -(4/h^2) sin^2(k pi / (2(m + 1))), k = 1..m
    h = 0.25
    lat = tps.Lattice.planar(n_nodes=m + 4, length=h * (m + 3))
    run = RunCache(lat, Modes).run(2, 2 + m)
    assert run.ends == "DD"
    k = np.arange(1, m + 1)
    exact = -(4.0 / h ** 2) * np.sin(k * np.pi / (2 * (m + 1))) ** 2
    scale = 4.0 / h ** 2
    np.testing.assert_allclose(np.sort(run.lam), np.sort(exact), rtol=0, atol=16 * EPS * scale)
    # second method: eigvalsh of the lattice's own block (stuck neighbours removed)
    np.testing.assert_allclose(np.sort(run.lam), np.sort(eigvalsh(_symmetric_block(lat, 2, 2 + m))),
                               rtol=0, atol=64 * m * EPS * scale)


@pytest.mark.parametrize("m", [2, 5, 17])
def test_neumann_runs_have_the_discrete_cosine_spectra(m):
    h = 0.5
    n = m + 3
    lat = tps.Lattice.planar(n_nodes=n, length=h * (n - 1))
    cache = RunCache(lat, Modes)
    scale = 4.0 / h ** 2
    k = np.arange(m)
    # Neumann end (half cell) and a stuck neighbour: theta_k = (k + 1/2) pi / m
    mixed = -scale * np.sin((k + 0.5) * np.pi / (2 * m)) ** 2
    for a, b, ends in ((0, m, "ND"), (n - m, n, "DN")):
        run = cache.run(a, b)
        assert run.ends == ends
        np.testing.assert_allclose(np.sort(run.lam), np.sort(mixed), rtol=0, atol=16 * EPS * scale)
        np.testing.assert_allclose(np.sort(run.lam), eigvalsh(_symmetric_block(lat, a, b)), rtol=0,
                                   atol=64 * m * EPS * scale)
    # the whole Neumann lattice: theta_k = k pi / (n - 1) (lattice_eigenvalues' closed form)
    run = cache.run(0, n)
    assert run.ends == "NN"
    np.testing.assert_allclose(np.sort(-run.lam), scale * np.sin(np.arange(n) * np.pi / (2 * (n - 1))) ** 2,
                               rtol=0, atol=64 * n * EPS * scale)


@pytest.mark.parametrize("ends_case", [(0, 6), (3, 9), (5, 12), (0, 12)])
def test_closed_modes_diagonalise_the_lattice_operator(ends_case):
    a, b = ends_case
    lat = tps.Lattice.planar(n_nodes=12, length=5.5)
    run = RunCache(lat, Modes).run(a, b)
    assert isinstance(run, ClosedRun)
    V = run.matrix()
    L = lat.operator[a:b, a:b]
    scale = 4.0 / lat.spacing ** 2
    assert np.max(np.abs(L @ V - V * run.lam)) <= 64 * EPS * scale
    u = np.random.default_rng(3).standard_normal(b - a)
    assert np.max(np.abs(run.synthesis(run.analysis(u)) - u)) <= 64 * EPS * np.max(np.abs(u))
    np.testing.assert_allclose(V @ run.s, 1.0, rtol=0, atol=64 * EPS * (b - a))


def test_free_runs_and_tridiagonal():
    starts, stops = free_runs(np.array([False, True, True, False, True]))
    assert starts.tolist() == [1, 4] and stops.tolist() == [3, 5]
    lat = tps.Lattice.axisymmetric(n_nodes=9, r_max=5.0)
    u = np.random.default_rng(0).standard_normal(9)
    tri = Tridiagonal(lat.operator)
    np.testing.assert_allclose(tri.apply(u), lat.operator @ u, rtol=0, atol=8 * EPS * np.abs(lat.operator).max())
    with pytest.raises(ValueError, match="tridiagonal"):
        Tridiagonal(np.ones((3, 3)))


@pytest.mark.parametrize("lattice", [tps.Lattice.planar(n_nodes=15, length=7.0),
                                     tps.Lattice.planar(n_nodes=15, length=7.0, boundary="pinned"),
                                     tps.Lattice.axisymmetric(n_nodes=15, r_max=6.0)],
                         ids=["neumann", "pinned", "axisymmetric"])
def test_run_segments_equal_whole_free_set_segments(lattice):
    # second method: the dense decomposition of the whole free set (Modes), same flight
    rng = np.random.default_rng(7)
    n = lattice.n_nodes
    cache = RunCache(lattice, Modes)
    for trial in range(6):
        free = rng.random(n) < 0.7
        free[n // 2] = True
        F = np.flatnonzero(free)
        w, z = rng.standard_normal(F.size), rng.random(F.size)
        ref = Segment(Modes(lattice, free), 1.3, w, z, 3.0)
        new = Segment(RunModes(lattice, free, cache.run, cache.tri), 1.3, w, z, 3.0)
        for tau in (0.0, 0.01, 0.7, 2.5):
            (w0, z0), (w1, z1) = ref.state(tau), new.state(tau)
            np.testing.assert_allclose(w1, w0, rtol=0, atol=1e-12)
            np.testing.assert_allclose(z1, z0, rtol=0, atol=1e-12)
            j = int(rng.integers(F.size))
            assert abs(new.node_height(j, tau) - z0[j]) <= 1e-12
            # the bounds of the run path are upper bounds of the dense ones
            for m in (1, 2, 3):
                assert np.all(new.derivative_bound(tau, m) >= ref.derivative_bound(tau, m) * (1 - 1e-12))


def _same_events(a, b, tol, height=0.0):
    """Same nodes and kinds, times within ``tol``; with ``height``, a landing at speed |w| may also
    differ by the round-off of the height over the speed, 16 eps height / |w| (chatter tails)."""
    ea, eb = a.events, b.events
    assert a.status == 0 and b.status == 0
    assert ea.size == eb.size and np.array_equal(ea.node, eb.node) and np.array_equal(ea.kind, eb.kind)
    speed = np.maximum(np.abs(ea.w_before), 1e-300)
    allowed = tol + np.where(ea.kind == "liftoff", 0.0, 16 * EPS * height / speed)
    assert np.all(np.abs(ea.t - eb.t) <= allowed)
    np.testing.assert_array_equal(a.stuck, b.stuck)


def _both(lat, Gamma, e, w, z, t0, t1, **kw):
    return [tps.simulate(lat, Gamma, e, w, z, t_start=t0, t_end=t1, method="exact", modes=mode, **kw)
            for mode in ("free_set", "runs")]


def test_flat_lattice_same_events_10_periods():
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    lat = tps.Lattice.planar(n_nodes=21, length=10.0)
    t0 = fl.t0 + 1e-6
    w, z = flat_state(lat, fl, t0)
    a, b = _both(lat, 2.5, 0.45, w, z, t0, t0 + 10 * fl.period + 0.5)
    _same_events(a, b, 1e-11)


def test_sticking_kink_same_events():
    # e = 0: every node lands, sticks and lifts off; the free set changes at every event
    fl = tps.FlatLayer(4.1, 2, 0.0, pattern="stick")
    lat = tps.Lattice.planar(n_nodes=21, length=20.0)
    t0 = 0.25 * fl.period
    w, z = kink_state(lat, fl, t0)
    a, b = _both(lat, 4.1, 0.0, w, z, t0, t0 + 3 * fl.period)
    assert np.count_nonzero(b.events.kind == "liftoff") >= 2 * 21
    _same_events(a, b, 1e-11)


def test_pinned_kink_same_events():
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    lat = tps.Lattice.planar(n_nodes=11, length=10.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    a, b = _both(lat, 2.5, 0.45, w, z, t0, t0 + fl.period)
    _same_events(a, b, 1e-11, height=float(z.max()))        # ends in chatter near node 3


def test_chatter_same_events():
    # Gamma < 1, a dropped uneven layer: every node chatters (geometric bounces) and sticks, one run at a
    # time, then the whole lattice lifts off and lands again
    lat = tps.Lattice.planar(n_nodes=9, length=8.0)
    z = 0.3 * (1.0 + 0.2 * np.cos(np.pi * lat.nodes / 4.0))
    a, b = _both(lat, 0.8, 0.5, np.zeros(9), z, 0.0, 20.0, stick_velocity=1e-6)
    assert np.count_nonzero(a.events.kind == "impact") > 9 * 10 and np.count_nonzero(a.events.kind == "stick") >= 9
    fast = np.abs(a.events.w_before) >= 1e-4
    assert np.max(np.abs(a.events.t - b.events.t)[fast]) <= 1e-11
    _same_events(a, b, 1e-11, height=float(z.max()))


@pytest.mark.slow
def test_sticking_kink_same_events_10_periods():
    fl = tps.FlatLayer(4.1, 2, 0.0, pattern="stick")
    lat = tps.Lattice.planar(n_nodes=41, length=40.0)
    t0 = 0.25 * fl.period
    w, z = kink_state(lat, fl, t0)
    a, b = _both(lat, 4.1, 0.0, w, z, t0, t0 + 10 * fl.period)
    assert a.n_events >= 10 * (4 * 41 - 2)
    _same_events(a, b, 1e-11)


def test_modes_option_is_checked():
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    with pytest.raises(ValueError, match="modes"):
        tps.simulate(lat, 2.5, 0.45, np.zeros(5), np.ones(5), t_end=1.0, modes="eigh")


needs_numba = pytest.mark.skipif(not jit.enabled(), reason="numba not installed or TPS_SOLVER_NUMBA=0")


@needs_numba
def test_compiled_coefficients_equal_numpy():
    lat = tps.Lattice.planar(n_nodes=40, length=20.0)
    cache = RunCache(lat, Modes)
    free = np.ones(40, dtype=bool)
    free[[7, 8, 30]] = False
    rng = np.random.default_rng(5)
    F = np.flatnonzero(free)
    w, z = rng.standard_normal(F.size), rng.random(F.size)
    md = RunModes(lat, free, cache.run, cache.tri)
    ref = Segment(md, 2.0, w, z, 4.1)
    from tps_solver.solvers.fda.run_kernels import run_coefficients
    md2 = RunModes(lat, free, cache.run, cache.tri)
    md2.kernel = run_coefficients
    new = Segment(md2, 2.0, w, z, 4.1)
    for tau in (0.0, 1e-9, 1e-3, 0.3, 4.0):          # both branches of phi2 (|lam tau| < 0.1 and above)
        for (c0, c1) in zip(ref.coefficients(tau), new.coefficients(tau)):
            np.testing.assert_allclose(c1, c0, rtol=16 * EPS, atol=16 * EPS * np.abs(c0).max())


@needs_numba
@pytest.mark.parametrize("case", ["kink", "chatter"])
def test_compiled_and_numpy_paths_same_events(case):
    if case == "kink":
        fl = tps.FlatLayer(4.1, 2, 0.0, pattern="stick")
        lat = tps.Lattice.planar(n_nodes=21, length=20.0)
        t0 = 0.25 * fl.period
        w, z = kink_state(lat, fl, t0)
        args, height = (4.1, 0.0, w, z, t0, t0 + 3 * fl.period), 0.0
        kw = {}
    else:
        lat = tps.Lattice.planar(n_nodes=9, length=8.0)
        z = 0.3 * (1.0 + 0.2 * np.cos(np.pi * lat.nodes / 4.0))
        args, height = (0.8, 0.5, np.zeros(9), z, 0.0, 20.0), float(z.max())
        kw = {"stick_velocity": 1e-6}
    G, e, w, z, ta, tb = args
    a, b = [tps.simulate(lat, G, e, w, z, t_start=ta, t_end=tb, method="exact", compiled=c, **kw)
            for c in (False, True)]
    _same_events(a, b, 1e-12, height=height)


@needs_numba
def test_compiled_step_candidates_equal_numpy():
    from tps_solver.solvers.fda.exact import ExactPropagator
    from tps_solver.solvers.fda.run_kernels import step_candidates
    lat = tps.Lattice.planar(n_nodes=30, length=15.0)
    cache = RunCache(lat, Modes)
    rng = np.random.default_rng(11)
    for trial in range(5):
        free = rng.random(30) < 0.75
        md = RunModes(lat, free, cache.run, cache.tri)
        F, S = md.index, md.stuck
        nf = F.size
        zF, wF = rng.random(nf) * (rng.random(nf) < 0.8), rng.standard_normal(nf)
        A, B, rel = 1.0 + rng.random(nf), 1.0 + rng.random(nf), rng.random(nf) - 0.5
        ref = ExactPropagator._candidates(zF, wF, A, B, rel, 1e-14, -0.3, 0.7, md.L_FF, md.L_SF, md.absL_SF,
                                          S.size > 0)
        out = [np.empty(nf + S.size) for _ in range(4)]
        tri = md.L_FF.tri
        step_candidates(zF, wF, A, B, rel, 1e-14, -0.3, 0.7, F, S, tri.lower, tri.diag, tri.upper, *out)
        for a, b in zip(ref, out):
            np.testing.assert_allclose(b, a, rtol=4 * EPS, atol=0)


def test_axisymmetric_sticking_same_events():
    # no closed form: dense run modes cached by node range (DenseRun), against the whole free set
    from tps_solver.solvers.fda.states import oscillon_state
    fl = tps.FlatLayer(4.1, 2, 0.0, pattern="stick")
    lat = tps.Lattice.axisymmetric(n_nodes=12, r_max=8.0)
    t0 = 0.25 * fl.period
    w, z = oscillon_state(lat, fl, t0, r_core=2.0, width=1.0)
    a, b = _both(lat, 4.1, 0.0, w, z, t0, t0 + 2 * fl.period)
    assert np.count_nonzero(b.events.kind == "liftoff") >= 12
    _same_events(a, b, 1e-11)


@needs_numba
def test_compiled_bounds_equal_numpy():
    from tps_solver.solvers.fda.run_kernels import closed_bound, closed_bounds12
    lat = tps.Lattice.planar(n_nodes=40, length=20.0)
    cache = RunCache(lat, Modes)
    rng = np.random.default_rng(3)
    free = rng.random(40) < 0.8
    md = RunModes(lat, free, cache.run, cache.tri)
    assert md.closed and len(md.runs) > 2
    F = md.index
    seg = Segment(md, 1.0, rng.standard_normal(F.size), rng.random(F.size), 4.1)   # numpy: no kernel
    for tau in (0.0, 1e-6, 0.7):
        ref = seg.bounds12(tau)
        md.kernel, md.bounds_kernel = object(), closed_bounds12          # the compiled branch
        try:
            new = seg.bounds12(tau)
        finally:
            md.kernel = md.bounds_kernel = None
        for a, b in zip(ref, new):
            np.testing.assert_allclose(b, a, rtol=64 * EPS, atol=0)
        for p in (1, 2, 3):
            ref = seg.derivative_bound(tau, p)
            md.bound_kernel = closed_bound
            try:
                new = seg.derivative_bound(tau, p)
            finally:
                md.bound_kernel = None
            np.testing.assert_allclose(new, ref, rtol=64 * EPS, atol=0)


@needs_numba
def test_compiled_event_sets_equal_numpy():
    # rest-on-the-plate contacts, lift-offs within time_tol, beyond eps_a, and none: against event_sets
    from tps_solver.solvers.fda.events import event_sets
    from tps_solver.solvers.fda.run_kernels import tri_event_sets
    lat = tps.Lattice.planar(n_nodes=30, length=15.0)
    cache = RunCache(lat, Modes)
    rng = np.random.default_rng(17)
    n_contact = n_lift = 0
    for trial in range(40):
        free = rng.random(30) < 0.7
        md = RunModes(lat, free, cache.run, cache.tri)
        F, S = md.index, md.stuck
        nf = F.size
        wF = rng.standard_normal(nf) * (rng.random(nf) < 0.7)
        zF = rng.random(nf) * (rng.random(nf) < 0.5)
        t = rng.uniform(0, 2 * np.pi)
        eps_z = np.full(nf, 1e-14)
        ref = event_sets(t, wF, zF, F, S, md.L_FF, md.L_SF, 4.1, 1e-12, eps_z,
                         64 * EPS * (1.0 + abs(np.sin(t) - 1 / 4.1) + md.absL_SF @ np.abs(wF)), absL_FF=md.absL_FF)
        tri = md.L_FF.tri
        c, l = np.empty(nf, dtype=np.int64), np.empty(S.size, dtype=np.int64)
        nc, nl = tri_event_sets(np.sin(t) - 1 / 4.1, np.cos(t), wF, zF, F, S, tri.lower, tri.diag, tri.upper,
                                1e-12, eps_z, c, l)
        assert c[:nc].tolist() == ref[0].tolist() and l[:nl].tolist() == ref[1].tolist()
        n_contact += nc
        n_lift += nl
    assert n_contact > 20 and n_lift > 20


@needs_numba
def test_compiled_search_start_and_run_sums_equal_numpy():
    from tps_solver.solvers.fda.run_kernels import closed_abs_sum, search_start
    lat = tps.Lattice.planar(n_nodes=30, length=15.0)
    cache = RunCache(lat, Modes)
    rng = np.random.default_rng(23)
    n_plate = 0
    for trial in range(10):
        free = rng.random(30) < 0.7
        md = RunModes(lat, free, cache.run, cache.tri)
        F = md.index
        nf = F.size
        wF = rng.standard_normal(nf) * (rng.random(nf) < 0.6)
        zF = rng.random(nf) * (rng.random(nf) < 0.5)
        g, dg = -0.3, 0.8
        tri = md.L_FF.tri
        acc, jerk, ea, at = np.empty(nf), np.zeros(nf), np.zeros(nf), np.empty(nf, dtype=bool)
        eps_w, eps_z, k = search_start(wF, zF, F, tri.lower, tri.diag, tri.upper, g, dg, acc, jerk, ea, at)
        ref_acc = md.L_FF @ wF + g
        ref_at = (zF == 0.0) & (np.abs(wF) <= 64 * EPS * (1 + np.abs(wF).max(initial=0.0)))
        assert np.array_equal(acc, ref_acc) and np.array_equal(at, ref_at) and k == np.count_nonzero(ref_at)
        assert eps_z == 64 * EPS * (1.0 + np.abs(zF).max(initial=0.0) + np.abs(wF).max(initial=0.0))
        np.testing.assert_array_equal(jerk[at], (md.L_FF @ ref_acc + dg)[at])
        np.testing.assert_array_equal(ea[at], (64 * EPS * (1.0 + abs(g) + md.absL_FF @ np.abs(wF)))[at])
        n_plate += k
        x = rng.random(nf)
        out = np.empty(nf)
        closed_abs_sum(x, md.offsets, out)
        np.testing.assert_allclose(out, md.absV @ x, rtol=8 * EPS, atol=0)
    assert n_plate > 10


@needs_numba
def test_compiled_bracket_equals_numpy():
    # random flights of closed-form runs: the compiled bracket, group and root against the numpy _bracket
    from tps_solver.solvers.fda.exact import ExactPropagator
    from tps_solver.solvers.fda.run_kernels import closed_bracket
    lat = tps.Lattice.planar(n_nodes=24, length=12.0)
    prop = ExactPropagator(lat, 4.1, 0.0, compiled=False)
    cache = RunCache(lat, Modes)
    rng = np.random.default_rng(29)
    found, grouped = 0, 0
    for trial in range(60):
        free = rng.random(24) < 0.75
        md = RunModes(lat, free, cache.run, cache.tri)
        F, S = md.index, md.stuck
        nf = F.size
        t_c = rng.uniform(0, 2 * np.pi)
        if trial % 2:           # a near-uniform landing: groups of several candidates, order repaired
            w0, z0 = -0.5 * (1.0 + 0.01 * rng.random(nf)), 1e-3 * (1.0 + 0.01 * rng.random(nf))
        else:
            w0, z0 = -rng.random(nf) - 0.1, 1e-3 * rng.random(nf)
        seg = Segment(md, t_c, w0, z0, 4.1)
        wF, zF = seg.state(0.0)
        A, B = seg.bounds12(0.0)
        g = np.sin(t_c) - 1 / 4.1
        f, fp, Ab, h = ExactPropagator._candidates(zF, wF, A, B, np.full(nf, -1.0), 1e-14, g, np.cos(t_c),
                                                   md.L_FF, md.L_SF, md.absL_SF, S.size > 0)
        ref = prop._bracket(seg, md, f, fp, Ab, h, 0.0, nf)
        md.bracket_kernel = closed_bracket
        try:
            new = prop._bracket(seg, md, f, fp, Ab, h, 0.0, nf)
        finally:
            md.bracket_kernel = None
        assert (ref is None) == (new is None)
        if ref is not None:
            found += 1
            grouped += ref[1].size > 1
            assert new[1].tolist() == ref[1].tolist()
            assert abs(new[0] - ref[0]) <= 1e-14 + 16 * EPS * abs(ref[0])
    assert found > 20 and grouped > 5


@needs_numba
def test_compiled_pulled_off_equals_numpy():
    from tps_solver.solvers.fda.events import pulled_off
    from tps_solver.solvers.fda.run_kernels import tri_pulled_off
    lat = tps.Lattice.planar(n_nodes=30, length=15.0)
    rng = np.random.default_rng(31)
    total = 0
    for trial in range(30):
        stuck = rng.random(30) < 0.5
        w = np.where(stuck, 0.0, rng.standard_normal(30) * 0.3)
        t = rng.uniform(0, 2 * np.pi)
        ref = pulled_off(t, w, stuck, lat, 4.1)
        new = pulled_off(t, w, stuck, lat, 4.1, kernel=tri_pulled_off)
        assert new.tolist() == ref.tolist()
        total += ref.size
    assert total > 10
