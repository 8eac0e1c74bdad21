"""Kinks as fixed points of the mirrored half-period map (tps_solver.solvers.shooting.symmetric)."""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.solvers.shooting.floquet import multipliers
from tps_solver.solvers.shooting.symmetric import MirroredHalfPeriodMap, mirror_symmetric


@pytest.fixture(scope="module")
def bond_kinks():
    """Gamma = 4.1, e = 0 on 10 nodes (dx = 4, mirror point between two nodes): both solvers."""
    lat = tps.Lattice.planar(n_nodes=10, length=36.0)
    a = tps.lattice_kink(lat, Gamma=4.1, e=0.0, symmetric=True, dense_max=200)
    b = tps.lattice_kink(lat, Gamma=4.1, e=0.0, symmetric=False, dense_max=200)
    return lat, a, b


def test_refusals():
    lat = tps.Lattice.planar(n_nodes=11, length=40.0)
    with pytest.raises(ValueError, match="M even"):
        MirroredHalfPeriodMap(lat, 4.1, 0.0, 2 * np.pi, 0.0)
    with pytest.raises(ValueError, match="symmetric under x -> -x"):
        MirroredHalfPeriodMap(tps.Lattice.planar(n_nodes=11, length=40.0, center=2.0), 4.1, 0.0, 4 * np.pi, 0.0)
    assert not mirror_symmetric(tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform"))
    with pytest.raises(ValueError, match="symmetric=True needs"):
        tps.lattice_kink(tps.Lattice.planar(n_nodes=11, length=40.0, center=2.0), symmetric=True)
    with pytest.raises(ValueError, match="symmetric must be"):
        tps.lattice_kink(lat, symmetric="yes")


def test_same_orbit_as_period_map_shooting(bond_kinks):
    lat, a, b = bond_kinks
    assert a.converged and b.converged and a.localized
    # measured: 4 Newton steps on G, then none on the period map; the period map's own Newton took 4
    assert a.symmetric_nit <= 5 and a.nit == 0
    ts = a.t_start + a.period * np.arange(32) / 32
    assert np.max(np.abs(np.asarray(a.height(ts)) - np.asarray(b.height(ts)))) <= 1e-9
    assert np.max(np.abs(np.abs(a.multipliers[:3]) - np.abs(b.multipliers[:3]))) <= 1e-6
    assert abs(a.multipliers[0]) == pytest.approx(0.886764, abs=2e-6)


def test_orbit_is_mirror_symmetric(bond_kinks):
    lat, a, _ = bond_kinks
    ts = a.t_start + a.period * np.arange(16) / 16
    Z, Zh = np.asarray(a.height(ts)), np.asarray(a.height(ts + a.period / 2))
    assert np.max(np.abs(Zh - Z[:, ::-1])) <= 1e-10


def test_G_multipliers_square_to_the_period_maps(bond_kinks):
    """G^2 = P_T: the eigenvalues of dG/dx squared are the Floquet multipliers, and the front's
    translation, nearly neutral for P_T, has a negative multiplier for G (the mirror reverses it)."""
    lat, a, _ = bond_kinks
    G = MirroredHalfPeriodMap(lat, 4.1, 0.0, a.period, a.t_start, stuck=a.stuck0)
    x = G.pack(a.w0, a.zeta0)
    F, Px, extra = G.residual(x)
    assert G.error(F, (Px, extra)) <= 1e-10                # the kink is a fixed point of G
    mg = multipliers(G.monodromy_matrix(x, 1e-6))
    assert mg[0].real < 0 and abs(mg[0].imag) < 1e-12
    assert np.max(np.abs(np.abs(mg[:3] ** 2) - np.abs(a.multipliers[:3]))) <= 1e-5


def test_node_lattice_saddle_is_said():
    """On 11 nodes (dx = 4) the node-centred kink is a saddle (|mu1| = 1.09367, measured) and the
    message says where the stable one is; period-map shooting from the same start drifts to a
    kink centred between two nodes (|mu1| = 0.8868), the stable one of the 10-node lattice above."""
    lat = tps.Lattice.planar(n_nodes=11, length=40.0)
    a = tps.lattice_kink(lat, Gamma=4.1, e=0.0)                 # symmetric by default here
    assert a.converged and a.symmetric_nit is not None
    assert abs(a.multipliers[0]) == pytest.approx(1.093666, abs=2e-6)
    assert "unstable" in a.message and "one node more or fewer" in a.message


def test_soft_kink_symmetric():
    """The soft contact (exact mirrored monodromy): converges where the period map's Newton
    stagnates from the same settled state (measured: max|F| 2.5e-8 after 11 steps)."""
    lat = tps.Lattice.planar(n_nodes=11, length=20.0)
    a = tps.lattice_kink(lat, Gamma=2.5, e=0.45, cutoff=0.5, periods=4)
    assert a.converged and a.symmetric_nit is not None and a.residual <= 1e-9
    ts = a.t_start + a.period * np.arange(16) / 16
    Z, Zh = np.asarray(a.height(ts)), np.asarray(a.height(ts + a.period / 2))
    assert np.max(np.abs(Zh - Z[:, ::-1])) <= 1e-8
