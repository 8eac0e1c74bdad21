"""Kinks and oscillons on lattices by settling and shooting (tps_solver.analyses.localized)."""
import math
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.analyses.localized import front_width, interface_position, lattice_kink, lattice_oscillon


@pytest.fixture(scope="module")
def e0_kink():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    return lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)


def test_e0_kink_is_periodic_and_antisymmetric(e0_kink):
    """The kink maps to itself under x -> -x, t -> t + T/2 (a symmetry Newton does not impose)."""
    orb = e0_kink
    assert orb.converged and orb.localized and orb.residual < 1e-11
    assert orb.contacts_per_node.tolist() == [2] * 6
    ts = orb.t_start + orb.period * np.arange(16) / 16
    Z = orb.height(ts)
    Zs = orb.height(ts + 0.5 * orb.period)
    assert np.max(np.abs(Z - Zs[:, ::-1])) < 1e-9
    # one period of time stepping from the section state returns to it
    run = tps.simulate(orb.lattice, orb.Gamma, orb.e, orb.w0, orb.zeta0, t_start=orb.t_start,
                       t_end=orb.t_start + orb.period, stuck0=orb.stuck0)
    assert np.max(np.abs(run.zeta - orb.zeta0)) < 1e-10 and np.max(np.abs(run.w - orb.w0)) < 1e-10


def test_front_width_matches_interpolated_profile(e0_kink):
    wl, wr = front_width(e0_kink, n_samples=64)
    assert abs(wl - wr) < 1e-9
    assert 8.0 < wl < 16.0                       # 10-90 % of a front spread over ~2 cells of 8


@pytest.mark.parametrize("x, p, level, want", [
    ([0.0, 1.0, 2.0], [0.0, 0.5, 1.0], 0.5, 1.0),
    ([0.0, 1.0, 2.0], [2.0, 1.0, 0.0], 0.75, 1.5),
    ([0.0, 2.0, 4.0, 6.0], [0.0, 0.0, 4.0, 4.0], 0.1, 2.2),
    ([0.0, 1.0], [1.0, 3.0], 0.9, 0.9),
])
def test_interface_position_table(x, p, level, want):
    assert interface_position(x, p, level) == pytest.approx(want, abs=4 * np.finfo(float).eps)


@pytest.mark.parametrize("kw, name", [
    (dict(level=0.0), "level"), (dict(level=1.0), "level"),
    (dict(profile=[1.0, 1.0, 1.0]), "profile"), (dict(x=[0.0, 1.0]), "x"),
])
def test_interface_position_bad_input(kw, name):
    args = dict(x=[0.0, 1.0, 2.0], profile=[0.0, 1.0, 2.0], level=0.5)
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        interface_position(**args)


@pytest.mark.parametrize("call, name", [
    (lambda: lattice_kink(tps.Lattice.axisymmetric(n_nodes=5, r_max=8.0)), "lattice"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), M=3), "M"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), e=-0.1), "e"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), cutoff=0.0), "cutoff"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), cutoff=0.3, e=0.45,
                          pattern="stick"), "pattern"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), periods=-1), "periods"),
    (lambda: lattice_kink(tps.Lattice.planar(n_nodes=5, length=8.0), Gamma=2.5, e=0.45,
                          pattern="touch"), "pattern|touch"),
    (lambda: lattice_oscillon(tps.Lattice.planar(n_nodes=5, length=8.0)), "lattice"),
    (lambda: lattice_oscillon(tps.Lattice.axisymmetric(n_nodes=5, r_max=8.0), core_radius=9.0),
     "core_radius"),
])
def test_bad_input_names_the_parameter(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.slow
@pytest.mark.parametrize("t_start, width, mu", [
    (None, 9.0136, 0.98284),          # the default start = that of validation.shooting.e0_kinks
    (4.319689898685965, 9.0291, 1.00502),           # another start: the other pinned position
])
def test_e0_kink_dx2_two_pinned_fronts(t_start, width, mu):
    """Gamma = 4.1, dx = 2: the stable kink of validation/sections/shooting.md (front width 9.01,
    |mu| = 0.983) from the default start and, from another, the weakly unstable one at the other
    lattice position."""
    lat = tps.Lattice.planar(n_nodes=21, length=40.0)
    orb = lattice_kink(lat, Gamma=4.1, e=0.0, periods=10, t_start=t_start, max_iter=80, n_multipliers=4,
                       dense_max=100)
    assert orb.converged and orb.localized
    assert orb.contacts_per_node.tolist() == [2] * 21
    assert abs(front_width(orb)[0] - width) < 2e-4
    assert abs(abs(orb.multipliers[0]) - mu) < 2e-4


def test_cli_lattice_kink(capsys):
    from tps_solver.cli import main

    assert main(["lattice-kink", "--dx", "8", "--periods", "4", "--multipliers", "2"]) == 0
    out = capsys.readouterr().out
    assert "contacts per node and period (count: nodes) = {2: 6}" in out
    assert "localized = True" in out and "stable = True" in out


def test_cli_lattice_kink_bad_spacing(capsys):
    from tps_solver.cli import main

    assert main(["lattice-kink", "--dx", "-1"]) != 0
    assert "--dx" in capsys.readouterr().err


@pytest.mark.slow
def test_e0_oscillon_core_collapses_on_a_finer_lattice():
    """dr = 4: a core of radius 12 does not survive ten settling periods; the result says so."""
    lat = tps.Lattice.axisymmetric(n_nodes=11, r_max=40.0, grid="uniform")
    orb = lattice_oscillon(lat, Gamma=4.1, e=0.0, core_radius=12.0, periods=10, multipliers=False)
    assert not orb.converged and not orb.success and orb.status == 2 and not orb.localized
    assert orb.message.startswith("the phase-shifted region did not survive")


class _TanhKink:
    """A manufactured front zeta = zL(t) + (zR(t) - zL(t)) (1 + tanh(x/w))/2, 10-90 width 2 atanh(0.8) w."""

    def __init__(self, w, n=20001):
        # the nodes of Lattice.planar(n_nodes=n, length=30 w), without its dense n x n operators
        # (at n = 20001 they took 12.8 GB, and the memory check refused them on a busy machine)
        self.nodes = np.linspace(-15.0 * w, 15.0 * w, n)                 # tanh(15) = 1 - 2e-13
        self.w, self.period, self.t_start = w, 4 * np.pi, 0.3

    def height(self, t):
        t = np.atleast_1d(t)[:, None]
        zl, zr = 1.0 + np.sin(t / 2), 1.0 - np.sin(t / 2)
        return zl + (zr - zl) * 0.5 * (1.0 + np.tanh(self.nodes[None, :] / self.w))


@pytest.mark.parametrize("w", [0.5, 1.0, 2.0])
def test_front_width_of_a_manufactured_tanh_front(w):
    want = 2.0 * math.atanh(0.8) * w
    wl, wr = front_width(_TanhKink(w), n_samples=64)
    assert abs(wl - want) <= 1e-6 * want and abs(wr - want) <= 1e-6 * want


def test_front_width_refuses_orbits_without_a_front():
    with pytest.raises(ValueError, match="orbit must be a kink"):
        front_width(tps.FlatLayer(2.5, e=0.45))
    flat = _TanhKink(1.0, n=11)
    flat.height = lambda t: np.ones((np.size(t), 11)) * 5.49
    with pytest.raises(ValueError, match="no front"):
        front_width(flat)


def test_lattice_kink_max_iter_is_checked():
    lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    with pytest.raises(ValueError, match="max_iter"):
        lattice_kink(lat, Gamma=4.1, e=0.0, periods=0, max_iter=-1)


@pytest.mark.slow
def test_lattice_kink_defaults_converge_at_dx1():
    """Gamma = 4.1, e = 0, dx = 1: the defaults converge (33 Newton steps, more than find_periodic_orbit's 30)."""
    lat = tps.Lattice.planar(n_nodes=41, length=40.0)
    orb = lattice_kink(lat, Gamma=4.1, e=0.0)
    assert orb.converged and orb.localized and orb.residual < 1e-10
    assert 30 < orb.nit <= 80
    assert 0.99 < abs(orb.multipliers[0]) < 1.0            # the nearly neutral front position
