"""Tests of check_stability: the FDA hand-off of limit cycles (flat layers and duck-typed TPS solutions)."""
import numpy as np
import pytest

import tps_solver as tps

GAMMA, E, M = 2.5, 0.45, 2


class FlatAsPeriodicSolution:
    """A TPS-like periodic solution that is exactly a flat layer on x in [-L, L] (duck-typed)."""

    geometry = "planar"

    def __init__(self, fl, n_nodes=9, half_length=4.0):
        self.flat = fl
        self.Gamma, self.e, self.M, self.period = fl.Gamma, fl.e, fl.M, fl.period
        self.nodes = np.linspace(-half_length, half_length, n_nodes)
        self.tc = np.full(n_nodes, fl.t0 % fl.period)

    def velocity(self, t):
        return np.repeat(np.asarray(self.flat.velocity(t))[:, None], self.nodes.size, axis=1)

    def height(self, t):
        return np.repeat(np.asarray(self.flat.height(t))[:, None], self.nodes.size, axis=1)


@pytest.mark.parametrize("branch, method", [("stable", "exact"), ("unstable", "exact"), ("stable", "ode")])
def test_uniform_multipliers_equal_flat_layer_floquet(branch, method):
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E, branch=branch)
    chk = tps.check_stability(fl, periods=3, n_nodes=6, method=method)
    assert chk.multipliers_kind == "uniform mode"
    np.testing.assert_allclose(chk.uniform_multipliers, fl.floquet_multipliers(), rtol=0, atol=1e-7)


def test_flat_layer_on_coarse_lattice_is_stable_and_says_its_cutoff():
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E)
    chk = tps.check_stability(fl, periods=12, n_nodes=6, length=8.0)
    assert chk.defects.shape == (12, 2) and np.max(chk.defects) <= 1e-12
    assert np.all(chk.events_per_period == 6)          # one simultaneous set per period
    assert chk.sticking_nodes.size == 0
    assert chk.growth_factor < 1.0 and chk.stable
    assert chk.cutoff["kind"] == "lattice spacing"
    assert chk.cutoff["length"] == pytest.approx(1.6, rel=4 * np.finfo(float).eps)
    assert "lattice spacing = 1.6" in chk.message


def test_unstable_branch_is_reported_unstable():
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E, branch="unstable")
    chk = tps.check_stability(fl, periods=8, n_nodes=6)
    assert not chk.stable and chk.growth_factor > 1.0


def test_period_map_of_flat_lattice_is_not_differentiable():
    # hazard 7 of docs/design.md: +h and -h on one node change the impact order, one-sided Jacobians differ
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E)
    chk = tps.check_stability(fl, periods=2, n_nodes=4, length=3.0, jacobian=True)
    assert chk.differentiable is False
    assert chk.multipliers_kind == "uniform mode"
    assert "not differentiable" in chk.message


@pytest.mark.parametrize("n_nodes", [None, 13])
def test_periodic_solution_duck_typed(n_nodes):
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E)
    sol = FlatAsPeriodicSolution(fl)
    chk = tps.check_stability(sol, periods=3, n_nodes=n_nodes)
    n = 9 if n_nodes is None else 13
    assert chk.lattice.n_nodes == n and chk.lattice.boundary == "pinned"
    np.testing.assert_allclose(chk.lattice.nodes[[0, -1]], [-4.0, 4.0])
    assert np.max(chk.defects) <= 1e-10
    assert np.all(chk.events_per_period == n)
    assert chk.multipliers_kind == "none"


@pytest.mark.parametrize("kw, name", [
    (dict(periods=1), "periods"),
    (dict(method="rk"), "method"),
    (dict(perturbation=-1e-7), "perturbation"),
    (dict(n_nodes=2), "n_nodes"),
    (dict(boundary="open"), "boundary"),
])
def test_bad_input(kw, name):
    fl = tps.FlatLayer(Gamma=GAMMA, M=M, e=E)
    with pytest.raises(ValueError, match=name):
        tps.check_stability(fl, **kw)


def test_rejects_unknown_object():
    with pytest.raises(ValueError, match="solution"):
        tps.check_stability(object())
