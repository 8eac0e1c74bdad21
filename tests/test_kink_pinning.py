"""validation/kink_pinning.py: the symmetry centre of a kink, on manufactured orbits and a shooting kink."""
import numpy as np
import pytest

from tps_solver.core.bunch import Bunch
from validation.kink_pinning import (both_pinned, continuum_fit, continuum_width, convergence_rows, fit_convergence,
                                     integral_width, mean_increments, pinned_kink, profile_widths, refined_instant,
                                     spline_width,
                                     symmetry_centre)


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


@pytest.mark.parametrize("delta, dx", [(3.0, 0.5), (4.1, 0.03125), (2.0, 1.0)])
def test_integral_width_tanh(delta, dx):
    # theta = (1 + tanh(x / delta)) / 2: integral of theta (1 - theta) = delta / 2, 10-90 % width delta ln 9;
    # the trapezoid rule on a sech^2 is exponentially accurate: its aliasing error (the first Fourier
    # coefficient of sech^2 at wavenumber 2 pi / dx) is ~ 4 a e^(-a), a = pi^2 delta / dx; the ends at
    # |x| = 80 cost ~ 320 e^(-160 / delta) < 1e-14
    x = dx * (np.arange(int(round(160 / dx)) + 1) - 80 / dx)
    w = integral_width(x, 1.5 + 0.7 * np.tanh(x / delta))
    a = np.pi ** 2 * delta / dx
    rel = max(1e-12, 8 * a * np.exp(-a))
    assert w == pytest.approx(delta * np.log(9.0), rel=rel)
    # reversed orientation (a front that decreases) and a shift of the centre off the nodes
    assert integral_width(x, -np.tanh((x - 0.37) / delta)) == pytest.approx(delta * np.log(9.0), rel=rel)
    # the spline's 10-90 % width of the same front: delta ln 9 to interpolation accuracy
    assert spline_width(x, np.tanh(x / delta)) == pytest.approx(delta * np.log(9.0), rel=1e-3)


def test_integral_width_rejects():
    x = np.linspace(0.0, 1.0, 5)
    with pytest.raises(ValueError, match="x and zeta"):
        integral_width(x, np.ones(4))
    with pytest.raises(ValueError, match="increasing"):
        integral_width(x[::-1], x)
    with pytest.raises(ValueError, match="no front"):
        integral_width(x, np.ones(5))


@pytest.mark.parametrize("w0, c, p", [(7.4, -0.3, 0.5), (9.0, 0.12, 1.0), (6.9, 0.05, 1.7)])
def test_fit_convergence_recovers_law(w0, c, p):
    d = 0.25 / 2.0 ** np.arange(4)
    w = w0 + c * d ** p
    f = fit_convergence(d, w)
    assert f["w0"] == pytest.approx(w0, abs=1e-8) and f["p"] == pytest.approx(p, abs=1e-6)
    assert f["c"] == pytest.approx(c, rel=1e-5) and f["dof"] == 1
    fixed = fit_convergence(d, w, p)
    assert fixed["w0"] == pytest.approx(w0, abs=1e-12) and fixed["rms"] < 1e-12
    # the wrong exponent leaves residuals and a biased w0
    wrong = fit_convergence(d, w, 1.5 if p < 1.2 else 0.5)
    assert wrong["rms"] > 1e-4 * abs(c) and abs(wrong["w0"] - w0) > 1e-4 * abs(c)


def test_fit_convergence_error_bar_covers_noise():
    # seeded noise of size 1e-4 on w0 - 0.2 sqrt(dx) at 5 spacings: w0 within 3 standard errors
    rng = np.random.default_rng(38)
    d = 0.5 / 2.0 ** np.arange(5)
    hits = 0
    for _ in range(40):
        w = 7.5 - 0.2 * np.sqrt(d) + 1e-4 * rng.standard_normal(d.size)
        f = fit_convergence(d, w, 0.5)
        assert f["dof"] == 3 and f["w0_err"] > 0
        hits += abs(f["w0"] - 7.5) <= 3 * f["w0_err"]
    assert hits >= 36
    with pytest.raises(ValueError, match="points"):
        fit_convergence(d[:2], d[:2])
    with pytest.raises(ValueError, match="dx"):
        fit_convergence(-d, d, 0.5)


def test_continuum_fit_and_convergence_rows():
    # a sqrt(dx) law: the fitted-p and p = 1/2 fits agree, p = 1 is far off and excluded from the error bar
    d = 0.25 / 2.0 ** np.arange(4)
    w = 7.5 - 0.2 * np.sqrt(d)
    w0, err, fits = continuum_fit(d, w)
    assert w0 == pytest.approx(7.5, abs=1e-8) and err < 1e-7
    assert fits["p = 1"]["rms"] > 1e3 * fits["p fitted"]["rms"]
    # rows with saved profiles (tanh fronts of known width): W, increments and their ratio
    rows = []
    for dx in (0.5, 0.25, 0.125):
        n = int(round(80 / dx)) + 1
        x = dx * (np.arange(n) - (n - 1) / 2)
        delta = 3.0 - 0.4 * np.sqrt(dx)
        rows.append(dict(Gamma=4.1, dx=dx, n_nodes=n, converged=True, mu1=1.0, width=0.0, seconds=1.0,
                         instant="refined", profile=list(np.tanh(x / delta))))
    assert profile_widths(dict(dx=1.0)) == (None, None)
    assert profile_widths(dict(rows[0], instant=None)) == (None, None)     # a grid instant's profile
    cr = convergence_rows(rows[::-1])
    assert [r["dx"] for r in cr] == [0.5, 0.25, 0.125]
    exact = [(3.0 - 0.4 * np.sqrt(dx)) * np.log(9.0) for dx in (0.5, 0.25, 0.125)]
    assert [r["w_int"] for r in cr] == pytest.approx(exact, rel=1e-6)
    assert cr[2]["ratio"] == pytest.approx(1 / np.sqrt(2), rel=1e-5)


def test_refined_instant():
    # left end 1 - (t - 0.3)^2 (the lower far field, top at t = 0.3), right end 5: the maximum of the
    # lower end found from a grid instant 0.0015 off (within the half step 1/512), to the search tolerance
    def height(t):
        t = np.asarray(t, float)[:, None]
        return np.hstack([1.0 - (t - 0.3) ** 2, np.full_like(t, 3.0), np.full_like(t, 5.0)])
    orb = Bunch(height=height, period=1.0)
    assert refined_instant(orb, 0.3015, 1 / 512) == pytest.approx(0.3, abs=1e-8)


def test_continuum_fit_error_bar_covers_a_second_term():
    # w = 7.5 - 0.2 sqrt(dx) + 0.5 dx^2: no single power law; the error bar includes the change on
    # dropping the coarsest spacing and covers the true w0
    d = 0.25 / 2.0 ** np.arange(4)
    w = 7.5 - 0.2 * np.sqrt(d) + 0.5 * d ** 2
    w0, err, fits = continuum_fit(d, w)
    drop = abs(fits["p fitted, coarsest dropped"]["w0"] - w0)
    assert drop > 1e-4 and err >= drop
    assert abs(w0 - 7.5) <= err
