"""Exact soft-contact monodromy (tps_solver.solvers.shooting.soft_monodromy) against independent references.

* the closed-form per-mode soft flat monodromy (SoftFlatOrbit.monodromy, built from
  expm_companion/flight_map, not from scipy's expm) times the lattice modes;
* scipy.linalg.expm of the free (or contact) generator when no switch occurs;
* central differences of the period map computed by the time stepper, on a non-uniform
  state (entry/exit at different times) and on a state with a capture and a release of the
  sticking rule (docs/design.md, hazard 10);
* the matrix-free route (expm_multiply, ARPACK) against the dense one.
"""
import numpy as np
import pytest
import scipy.linalg

import tps_solver as tps
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.operators.lattice import lattice_eigenvalues
from tps_solver.solvers.shooting.soft_monodromy import SoftMonodromy, soft_monodromy

G, M, E, ELL = 2.5, 2, 0.45, 0.3


def _match(a, b):
    """Largest distance from any element of a to the nearest of b and vice versa."""
    d = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    return max(d.min(axis=0).max(), d.min(axis=1).max())


@pytest.fixture(scope="module")
def flat():
    orb = SoftFlatOrbit(G, M, E, ELL)
    s = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(s)
    lat = tps.Lattice.planar(n_nodes=4, length=3.0)
    run = tps.simulate(lat, G, E, np.full(4, w), np.full(4, z), t_start=s, t_end=s + orb.period,
                       method="soft", cutoff=ELL)
    J = SoftMonodromy.from_run(run, np.full(4, w), np.full(4, z), s)
    return orb, s, lat, J, run.events


def _period_map(lat, x, t0, T):
    n = lat.n_nodes
    r = tps.simulate(lat, G, E, x[:n], x[n:], t_start=t0, t_end=t0 + T, method="soft", cutoff=ELL)
    return np.concatenate((r.w, r.zeta)), [(int(ev.node), str(ev.kind)) for ev in r.events]


def test_flat_lattice_multipliers_match_the_closed_form_per_mode_monodromy(flat):
    orb, s, lat, J, ev = flat
    mono = orb.monodromy(lattice_eigenvalues(lat), t_section=s)
    want = np.concatenate([np.linalg.eigvals(Mk) for Mk in mono])
    assert [sw[2] for sw in J.switches] == ["entry"] * 4 + ["exit"] * 4
    assert _match(J.multipliers(), want) < 1e-10          # measured 7e-13
    # the modal blocks themselves: Q^-1 J Q = blockdiag(mono), Q from the eigenvectors of -L
    # (-L = D^-1 F is similar to the symmetric D^-1/2 F D^-1/2, D the cell volumes)
    d = np.sqrt(lat.volumes)
    lam, U = np.linalg.eigh(-(d[:, None] * lat.operator / d[None, :]))
    np.testing.assert_allclose(lam, lattice_eigenvalues(lat), atol=1e-12)
    Q = np.kron(np.eye(2), U / d[:, None])
    B = np.linalg.solve(Q, J.matrix() @ Q)
    for k in range(4):
        np.testing.assert_allclose(B[np.ix_([k, 4 + k], [k, 4 + k])], mono[k], rtol=0, atol=1e-10)
    np.testing.assert_allclose(J.uniform_block(), mono[0], rtol=0, atol=1e-10)


def test_taylor_interval_flow_matches_dense_expm(flat):
    """The banded Taylor series (used above EXPM_MAX unknowns) against dense expm per interval."""
    J = flat[3]
    np.testing.assert_allclose(J._propagate(np.eye(8), "taylor"), J.matrix(), rtol=0, atol=1e-11)


@pytest.mark.slow
def test_matrix_free_route_matches_the_dense_product(flat):
    orb, s, lat, J, ev = flat
    Jf = SoftMonodromy(lat, G, E, ELL, J.t_start, J.t_end, np.full(4, orb.state(s)[1]), ev, dense_max=0)
    v = np.linspace(-1.0, 1.0, 8)
    np.testing.assert_allclose(Jf.jv(v), J.matrix() @ v, rtol=0, atol=1e-11)
    np.testing.assert_allclose(J._propagate(np.eye(8), "expm_multiply"), J.matrix(), rtol=0, atol=1e-11)
    mu = Jf.multipliers(k=3)
    assert Jf.arpack_converged is True
    np.testing.assert_allclose(np.abs(mu), np.abs(J.multipliers()[:3]), rtol=0, atol=1e-9)


def test_no_switch_gives_expm_of_the_generator():
    lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    w0, z0 = np.array([0.1, -0.2, 0.3]), np.full(3, 5.0)           # high above the plate
    J = soft_monodromy(lat, G, E, ELL, w0, z0, 0.0, 1.5)
    assert J.switches == [] and len(J.intervals) == 1
    A = np.zeros((6, 6))
    A[:3, :3] = lat.operator
    A[3:, :3] = np.eye(3)
    np.testing.assert_allclose(J.matrix(), scipy.linalg.expm(1.5 * A), rtol=0, atol=1e-13)
    # all nodes compressed and moving down: soft contact throughout a short segment
    Jc = soft_monodromy(lat, G, E, ELL, np.full(3, -1.0), np.full(3, -0.01), 0.0, 0.02)
    assert Jc.switches == []
    tau_c = ELL ** 2                                   # the contact constants, written out
    beta = -np.log(E) / tau_c
    om2 = (np.pi / tau_c) ** 2 + beta ** 2
    Ac = A.copy()
    Ac[:3, :3] -= 2.0 * beta * np.eye(3)
    Ac[:3, 3:] = -om2 * np.eye(3)
    np.testing.assert_allclose(Jc.matrix(), scipy.linalg.expm(0.02 * Ac), rtol=0, atol=1e-12)


@pytest.mark.slow
def test_central_differences_of_the_period_map_on_a_non_uniform_state():
    """Entries and exits at four different times: directional derivatives by central differences."""
    orb = SoftFlatOrbit(G, M, E, ELL)
    s = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(s)
    lat = tps.Lattice.planar(n_nodes=4, length=3.0)
    x0 = np.concatenate((w + 0.05 * np.array([1.0, -0.5, 0.3, -1.0]), z + 0.02 * np.array([-1.0, 0.5, 1.0, 0.2])))
    J = soft_monodromy(lat, G, E, ELL, x0[:4], x0[4:], s, orb.period)
    assert len({sw[0] for sw in J.switches}) == 8                  # no two switches together
    ev0 = _records(J)
    h = 1e-5                                                        # measured optimum (error 2e-9)
    for v in (np.array([1.0, 0, 0, 0, 0, 0, 0, 0]), np.array([0.3, -1.0, 0.2, 0.5, -0.4, 1.0, 0.1, -0.7])):
        yp, evp = _period_map(lat, x0 + h * v, s, orb.period)
        ym, evm = _period_map(lat, x0 - h * v, s, orb.period)
        assert evp == ev0 and evm == ev0                            # same switch sequence
        np.testing.assert_allclose(J.jv(v), (yp - ym) / (2.0 * h), rtol=0, atol=1e-7)


def _records(J):
    """The event records (node, kind) that the switches of J come from."""
    kind = {"entry": "impact", "exit": "liftoff", "capture": "stick", "release": "liftoff"}
    return [(j, kind[k]) for _, j, k, _ in J.switches]


def test_capture_and_release_saltation_against_central_differences():
    """Node 0 leaves a shallow contact slowly, is captured (stick), released when a_0 > 0."""
    lat = tps.Lattice.planar(n_nodes=3, length=20.0)
    x0 = np.array([0.0, 0.3, -0.2, -1e-6, 0.5, 0.3])
    J = soft_monodromy(lat, G, E, ELL, x0[:3], x0[3:], 0.0, 2.0)
    assert [sw[2] for sw in J.switches] == ["exit", "entry", "capture", "release"]
    # one direction: node 0's height (through the slow exit/entry and the capture, whose
    # neighbour term -L_j0 dzeta_0 changes this product by 3e-2 when left out) and a
    # neighbour's velocity (through the release)
    v = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 0.0])
    h = 1e-8                                            # measured optimum (error 5e-8)
    yp, evp = _period_map(lat, x0 + h * v, 0.0, 2.0)
    ym, evm = _period_map(lat, x0 - h * v, 0.0, 2.0)
    assert evp == _records(J) and evm == _records(J)
    np.testing.assert_allclose(J.jv(v), (yp - ym) / (2.0 * h), rtol=0, atol=5e-7)
    # the capture erases node 0: its rows are those of the held node (released with w = zeta = 0)
    assert abs(J.matrix()[3, 3]) < 1e-3 and abs(J.matrix()[0, 0]) < 1e-3


def test_bad_input_raises_value_error(flat):
    orb, s, lat, J, ev = flat
    z = np.full(4, orb.state(s)[1])
    with pytest.raises(ValueError, match="t_end"):
        SoftMonodromy(lat, G, E, ELL, 1.0, 0.5, z, ev[:0])
    with pytest.raises(ValueError, match="events must lie"):
        SoftMonodromy(lat, G, E, ELL, s, s + 1.0, z, ev)
    with pytest.raises(ValueError, match="e must be"):
        SoftMonodromy(lat, G, 1.0, ELL, s, s + orb.period, z, ev)
    with pytest.raises(ValueError, match="not free"):
        SoftMonodromy(lat, G, E, ELL, s, s + orb.period, np.full(4, -1.0), ev)
    with pytest.raises(ValueError, match="v must have shape"):
        J.jv(np.ones(3))
    with pytest.raises(ValueError, match="lattice"):
        SoftMonodromy("lattice", G, E, ELL, s, s + orb.period, z, ev)


# ------------------------------------------------------------ routing (slow: time-stepped periods)

@pytest.mark.slow
def test_check_stability_soft_reports_the_exact_multipliers():
    fl = tps.FlatLayer(G, M, e=E)
    chk = tps.check_stability(fl, periods=3, n_nodes=3, length=2.0, method="soft", cutoff=ELL, jacobian=True)
    orb = SoftFlatOrbit(G, M, E, ELL)
    mono = orb.monodromy(lattice_eigenvalues(chk.lattice), t_section=chk.section_time)
    assert _match(chk.uniform_multipliers, np.linalg.eigvals(mono[0])) < 1e-10     # FD: 5e-9
    assert chk.multipliers_kind == "full period map" and chk.differentiable
    assert _match(chk.multipliers, np.concatenate([np.linalg.eigvals(m) for m in mono])) < 1e-10   # FD: 4e-7
    assert "exact soft monodromy" in chk.message


@pytest.mark.slow
def test_find_periodic_orbit_soft_uses_the_exact_product():
    orb = SoftFlatOrbit(G, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=3, length=1.0)
    s = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(s)
    guess = (np.full(3, w) + 1e-4 * np.array([1.0, -1.0, 0.5]), np.full(3, z))
    res = tps.find_periodic_orbit(lat, G, M, E, cutoff=ELL, guess=guess, t_start=s, section="fixed", tol=1e-10)
    assert res.converged and res.multipliers_kind == "all (exact)"
    want = np.concatenate([np.linalg.eigvals(m) for m in orb.monodromy(lattice_eigenvalues(lat), t_section=s)])
    assert _match(res.multipliers, want) < 1e-8                     # measured 1.3e-10 (FD: 4.3e-5)
    assert res.nit <= 3 and res.n_period_maps <= 8                  # exact Newton: 2 steps, 6 maps
    lead = tps.find_periodic_orbit(lat, G, M, E, cutoff=ELL, guess=res, section="fixed", tol=1e-10,
                                   dense_max=0, n_multipliers=3)
    assert lead.multipliers_kind == "leading (exact)" and lead.multipliers.size == 3
    np.testing.assert_allclose(lead.multipliers, res.multipliers[:3], rtol=0, atol=1e-9)
