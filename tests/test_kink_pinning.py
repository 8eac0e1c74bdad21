"""validation/kink_pinning.py: the symmetry centre of a kink, on manufactured orbits and a shooting kink."""
import numpy as np
import pytest

from tps_solver.core.bunch import Bunch
from validation.kink_pinning import both_pinned, continuum_width, mean_increments, pinned_kink, symmetry_centre


def manufactured(c, dx=1.0, n=41):
    """zeta = a(t) + b(t) tanh(x - c), a(t + T/2) = a(t), b(t + T/2) = -b(t): mirror point c."""
    x = -20.0 + dx * np.arange(n)
    T = 4 * np.pi

    def height(t):
        t = np.asarray(t, float)[:, None]
        return 2.0 + np.cos(t) + np.sin(t / 2) * np.tanh(x[None, :] - c)
    return Bunch(lattice=Bunch(nodes=x), period=T, t_start=0.0, height=height)


@pytest.mark.parametrize("c, kind", [(0.0, "node"), (3.0, "node"), (0.5, "bond"), (-2.5, "bond")])
def test_symmetry_centre_manufactured(c, kind):
    got, xc, err = symmetry_centre(manufactured(c))
    assert got == kind
    assert xc == pytest.approx(c, abs=1e-12)
    assert err < 64 * np.finfo(float).eps          # heights of order 3


def test_symmetry_centre_off_lattice_is_not_rounding():
    # a mirror point a quarter spacing off any node or bond: the best match is far from rounding
    _, _, err = symmetry_centre(manufactured(0.25))
    assert err > 1e-3


def test_pinned_kink_coarse():
    # Gamma = 3.9, dx = 4 (11 nodes), the node-centred kink as a fixed point of the mirrored
    # half-period map; the former study's period-map shooting from the default start reached the
    # same orbit (|mu1| = 1.00555, cached in validation/data/kink_pinning/G3.9_dx4.json): an
    # independent method.  This coarse kink is unstable (the pinning strength is negative).
    row = pinned_kink(3.9, 4.0, "node")
    assert row["converged"] and row["found_centre"] == "node" and row["x_centre"] == 0.0
    assert row["symmetry_error"] < 1e-9
    assert row["mu1"] == pytest.approx(1.00555, abs=1e-5)
    assert row["pinning"] == 1.0 - row["mu1"]
    with pytest.raises(ValueError, match="centre"):
        pinned_kink(3.9, 4.0, "edge")


def test_both_pinned_and_continuum_width():
    node = dict(Gamma=4.1, dx=1.0, mu1=0.999, width=7.35, converged=True, seconds=1.0)
    bond = dict(Gamma=4.1, dx=1.0, mu1=1.003, width=7.31, converged=True, seconds=1.0)
    p1 = both_pinned(node, bond)
    assert p1["stable"] == "node" and p1["pinning"] == pytest.approx(1e-3)
    assert p1["mean"] == pytest.approx(7.33) and p1["gap"] == pytest.approx(0.04)
    p2 = both_pinned(dict(node, dx=0.5, width=7.342), dict(bond, dx=0.5, width=7.332))
    w, err = continuum_width([p1, p2])
    assert w == pytest.approx(7.337) and err == pytest.approx(0.005 + 0.007)
    assert continuum_width([p1]) == (None, None)
    assert mean_increments([p2, p1]) == pytest.approx([0.007])
