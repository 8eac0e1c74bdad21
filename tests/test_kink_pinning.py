"""validation/kink_pinning.py: the symmetry centre of a kink, on manufactured orbits and a shooting kink."""
import numpy as np
import pytest

from tps_solver.core.bunch import Bunch
from validation.kink_pinning import continuum_width, pinned_kink, symmetry_centre


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
    # Gamma = 3.9, dx = 4 (11 nodes): shooting ends on the node-centred kink; the mirror symmetry is
    # not imposed anywhere, so its holding to rounding checks the orbit; measured |mu1| = 1.00555
    # (this coarse kink is unstable: the pinning strength is negative)
    row = pinned_kink(3.9, 4.0)
    assert row["converged"] and row["centre"] == "node" and row["x_centre"] == 0.0
    assert row["symmetry_error"] < 1e-9
    assert row["mu1"] == pytest.approx(1.00555, abs=1e-5)
    assert row["pinning"] == 1.0 - row["mu1"]


def test_continuum_width_table():
    rows = [dict(dx=2.0, converged=True, width=10.0), dict(dx=1.0, converged=True, width=9.5),
            dict(dx=0.5, converged=False, width=None)]
    assert continuum_width(rows) == (9.5, 0.5)
    assert continuum_width(rows[:1]) == (None, None)
