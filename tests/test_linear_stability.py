"""Acceptance tests of the flat-layer linear stability, eqs. (28)-(35).

References independent of the secular root finder: the Chebyshev discretisation of
(28)-(29) (never uses (35)), an mpmath shooting determinant built from the matrix
exponential of the ODE (``validation/linear_stability.py``), mpmath evaluation of the
paper's (35) as printed, the kappa -> inf single-surface limit, the small-kappa
asymptotics, and manufactured functions for the argument-principle counter.
"""
import math

import mpmath
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tps_solver.model.linear_stability import growth_rates, secular_roots
from tps_solver.cli import main as cli_main
from tps_solver.model.linear_stability import (KAPPA_C, MODES, POLISH_REL, _phi_complex, _winding_number, chebyshev_eigenvalues, reduced_secular_function)
from validation.linear_stability import (
    agreement_table, convergence_study, free_surface_limit, shooting_determinant, shooting_root,
)

EPS = np.finfo(float).eps
AGREE_KAPPAS = [0.1, 0.5, 1.0, 2.0, 5.0]


def _paper_35_residual(gamma, kappa, mode, dps=40):
    """|LHS - RHS| / (|LHS| + |RHS|) of (35) exactly as printed, exponent +1 varicose, -1 sinuous."""
    with mpmath.workdps(dps):
        g = mpmath.mpc(gamma.real, gamma.imag)
        k = mpmath.mpf(kappa)
        ratio = mpmath.tanh(g * k) / mpmath.tanh(k)
        lhs = ratio if mode == "varicose" else 1 / ratio
        rhs = 4 * g / (g * g + 1) ** 2
        return float(abs(lhs - rhs) / (abs(lhs) + abs(rhs)))


def _brackets_root_of_35(gamma, kappa, mode, rel=16 * EPS, dps=40):
    """True if (35) as printed changes sign between gamma (1 -+ rel) (mpmath, ``dps`` digits).

    (35) is multiplied by cosh(gamma kappa) (gamma^2 + 1)^2 to remove the poles of tanh:
    sinuous tanh(k) (g^2+1)^2 cosh(gk) - 4 g sinh(gk), varicose sinh(gk) (g^2+1)^2 - 4 g tanh(k) cosh(gk).
    On gamma = i beta the sinuous form is real and the varicose one imaginary.
    """
    with mpmath.workdps(dps):
        k = mpmath.mpf(kappa)

        def f(g):
            if mode == "sinuous":
                return mpmath.tanh(k) * (g * g + 1) ** 2 * mpmath.cosh(g * k) - 4 * g * mpmath.sinh(g * k)
            return mpmath.sinh(g * k) * (g * g + 1) ** 2 - 4 * g * mpmath.tanh(k) * mpmath.cosh(g * k)

        unit = mpmath.mpc(1) if gamma.imag == 0 else mpmath.mpc(0, 1)
        part = (lambda z: z.real) if (gamma.imag == 0 or mode == "sinuous") else (lambda z: z.imag)
        mag = mpmath.mpf(abs(gamma))
        lo, hi = part(f(unit * mag * (1 - rel))), part(f(unit * mag * (1 + rel)))
        return lo * hi < 0


# ----------------------------------------------------------------------------- (35) itself


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kappa", [1e-3, 0.1, 1.0, 5.0, 50.0, 1e3])
def test_roots_solve_paper_equation_35_with_stated_exponent(kappa, mode):
    res = secular_roots(kappa, mode, 8)
    for g in res.gamma:  # each returned root is within 16 ulps of an exact root of (35)
        assert _brackets_root_of_35(complex(g), kappa, mode)
    # ... and they do NOT solve the other family's equation (labels are not swapped)
    other = "sinuous" if mode == "varicose" else "varicose"
    assert max(_paper_35_residual(complex(g), kappa, other) for g in res.gamma) > 1e-3


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kappa", [1e-3, 0.3, 1.0, 5.0, 50.0])
def test_result_structure_sorted_negative_complete(kappa, mode):
    res = secular_roots(kappa, mode, 12)
    assert res.gamma.shape == (12,) and res.gamma.dtype == complex and res.lam.dtype == float
    assert np.all(np.diff(res.lam) < 0) and np.all(res.lam < 0)
    # lam is computed without the cancellation in gamma^2 - 1, so compare on the scale of gamma^2 + 1
    assert np.all(np.abs(res.lam - ((res.gamma ** 2).real - 1.0)) <= 8 * EPS * (np.abs(res.gamma) ** 2 + 1))
    # gamma is either real in [0, 1) or purely imaginary with Im > 0
    real = res.gamma.imag == 0
    assert np.all((res.gamma.real[real] >= 0) & (res.gamma.real[real] < 1))
    assert np.all((res.gamma.real[~real] == 0) & (res.gamma.imag[~real] > 0))
    assert res.complete and res.n_enclosed == 12
    assert res.trivial[0] == 1 and not res.trivial_is_eigenvalue[0]
    if mode == "varicose":
        assert res.trivial[1] == 0 and not res.trivial_is_eigenvalue[1]


def test_trivial_roots_solve_35_but_are_reported_separately():
    for mode in MODES:
        res = secular_roots(1.0, mode, 5)
        assert _paper_35_residual(1.0 + 0j, 1.0, mode) < 1e-30
        assert np.min(np.abs(res.gamma - 1.0)) > 0.1
    # gamma = 0 solves the varicose (35): both sides vanish
    assert mpmath.tanh(0 * 1.0) / mpmath.tanh(1.0) == 0 and 4 * 0 / (0 ** 2 + 1) ** 2 == 0
    assert np.min(np.abs(secular_roots(1.0, "varicose", 5).gamma)) > 0.1


def test_gamma_zero_is_an_eigenvalue_only_at_kappa_c():
    assert KAPPA_C == pytest.approx(4.0 * math.tanh(KAPPA_C), rel=4 * EPS)
    res = secular_roots(KAPPA_C, "varicose", 3)
    assert res.trivial_is_eigenvalue.tolist() == [False, True]
    assert res.gamma[0] == 0 and res.lam[0] == -1.0
    lam_c = chebyshev_eigenvalues(KAPPA_C, "varicose")[0]
    assert abs(lam_c + 1.0) < 1e-12
    # just below kappa_c the root is imaginary, just above it is real: continuous through gamma = 0
    below = secular_roots(KAPPA_C * (1 - 1e-6), "varicose", 1).gamma[0]
    above = secular_roots(KAPPA_C * (1 + 1e-6), "varicose", 1).gamma[0]
    assert below.real == 0 and 0 < below.imag < 1e-3 and above.imag == 0 and 0 < above.real < 1e-3


# ----------------------------------------------------------------------------- Chebyshev vs (35)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kappa", AGREE_KAPPAS)
def test_chebyshev_agrees_with_secular_roots(kappa, mode):
    ref = secular_roots(kappa, mode, 10).lam
    lam = chebyshev_eigenvalues(kappa, mode, n_cheb=40)
    assert np.max(np.abs(lam[:10] - ref) / np.abs(ref)) <= 1e-9
    assert np.max(np.abs(lam[:10].imag)) == 0.0
    # no eigenvalue at the trivial roots lam = 0 (gamma = 1) or lam = -1 (gamma = 0)
    assert np.min(np.abs(lam)) == pytest.approx(abs(ref[0]), rel=1e-9)
    if mode == "varicose":
        assert np.min(np.abs(lam + 1.0)) > 1e-3


@pytest.mark.parametrize("kappa", [1e-3, 50.0])
def test_chebyshev_agrees_at_extreme_kappa(kappa):
    for mode in MODES:
        ref = secular_roots(kappa, mode, 10).lam
        lam = chebyshev_eigenvalues(kappa, mode, n_cheb=40)[:10]
        assert np.max(np.abs(lam - ref) / np.abs(ref)) <= 1e-9


def test_chebyshev_spectral_convergence():
    n_chebs = (12, 14, 16, 18, 20, 22, 24, 26)
    conv = convergence_study(kappa=1.0, n_chebs=n_chebs)
    for mode in MODES:
        err = conv[mode]
        slope = np.polyfit(np.array(n_chebs, dtype=float), np.log10(err), 1)[0]
        # geometric (spectral) decay: at least half a decade per added polynomial, far from algebraic
        assert slope < -0.5, (mode, err)
        assert err[0] > 1e-3 and err[-1] < 1e-10
        assert np.all(np.diff(np.log10(err)) < 0)


def test_all_chebyshev_eigenvalues_are_damped():
    for kappa in (0.1, 1.0, 5.0):
        for mode in MODES:
            lam = chebyshev_eigenvalues(kappa, mode, n_cheb=40)
            assert lam.real.max() < 0


def test_collocation_variant_agrees_where_well_conditioned():
    for mode in MODES:
        ref = secular_roots(1.0, mode, 10).lam
        lam = chebyshev_eigenvalues(1.0, mode, n_cheb=30, method="collocation")[:10]
        assert np.max(np.abs(lam - ref) / np.abs(ref)) < 1e-9


# ----------------------------------------------------------------------------- third check


@pytest.mark.parametrize("kappa, mode", [(1e-3, "sinuous"), (1.0, "sinuous"), (1.0, "varicose"),
                                         (5.0, "varicose")])
def test_shooting_determinant_confirms_least_damped_root(kappa, mode):
    lam_sec = secular_roots(kappa, mode, 1).lam[0]
    lam_ref = shooting_root(lam_sec, kappa, mode)
    assert abs(lam_sec - float(lam_ref)) <= 16 * EPS * abs(lam_sec)
    lam_ch = chebyshev_eigenvalues(kappa, mode, n_cheb=40, n_refine=1)[0].real
    assert abs(lam_ch - float(lam_ref)) <= 1e-9 * abs(lam_sec)


@pytest.mark.parametrize("kappa", [0.1, 1.0, 5.0])
def test_trivial_roots_are_not_eigenvalues_by_shooting(kappa):
    # the basis-free determinant is far from zero at lam = 0 (gamma = 1) and lam = -1 (gamma = 0)
    for mode, lam_t in (("sinuous", 0.0), ("varicose", 0.0), ("varicose", -1.0)):
        lam1 = secular_roots(kappa, mode, 1).lam[0]
        d_t = abs(shooting_determinant(lam_t, kappa, mode, dps=30))
        d_near = abs(shooting_determinant(lam1 * (1 + 1e-6), kappa, mode, dps=30))
        assert d_t > 1e3 * d_near


@pytest.mark.parametrize("kappa", [1e-3, 0.3, 1.0, 2.0])
def test_lambda_zero_determinant_matches_closed_form(kappa):
    # In the basis {cosh kx, x sinh kx} ({sinh kx, x cosh kx}) the lambda = 0 boundary determinant is
    # 2 kappa^4 (sinh 2 kappa -+ 2 kappa); the shooting basis (unit initial data at x = 0) differs by the
    # basis-change determinant 1/(2 kappa) (1/(2 kappa^3)), so |det| = kappa^3 (sinh 2k - 2k), kappa (sinh 2k + 2k).
    with mpmath.workdps(40):
        k = mpmath.mpf(kappa)
        even = abs(shooting_determinant(0, kappa, "sinuous", dps=40)) / (k ** 3 * (mpmath.sinh(2 * k) - 2 * k))
        odd = abs(shooting_determinant(0, kappa, "varicose", dps=40)) / (k * (mpmath.sinh(2 * k) + 2 * k))
    assert abs(float(even) - 1) < 1e-13 and abs(float(odd) - 1) < 1e-13


# ----------------------------------------------------------------------------- limits


def test_single_free_surface_limit():
    fs = free_surface_limit()
    g = fs["gamma_limit"]
    assert abs(g ** 3 + g ** 2 + 3 * g - 1) < 8 * EPS
    for mode in MODES:
        assert fs["lam_kappa50"][mode] == pytest.approx(fs["lam_limit"], rel=1e-12)


@pytest.mark.parametrize("kappa", [1e-3, 1e-2])
def test_small_kappa_asymptotics(kappa):
    # sinuous: lam_1 ~ -(4/3) kappa^2 (sigma ~ -nu k^4 h^2 / 3); varicose: gamma_1 -> i sqrt(3), lam_1 -> -4
    s = secular_roots(kappa, "sinuous", 1).lam[0]
    v = secular_roots(kappa, "varicose", 1).lam[0]
    assert abs(s / (-4.0 / 3.0 * kappa ** 2) - 1) < 3 * kappa ** 2
    assert abs(v + 4.0) < 3 * kappa ** 2


# ----------------------------------------------------------------------------- argument principle


def test_winding_number_counts_manufactured_zeros():
    zeros = np.array([0.5, -2.0, 1.0 + 1.0j, -3.0 - 0.5j, 10.0])
    f = lambda s: np.prod([s - z for z in zeros], axis=0) * np.exp(1j * 40 * s)  # noqa: E731
    assert _winding_number(f, 0.0, 5.0)[0] == 4
    assert _winding_number(f, 0.0, 0.2)[0] == 0


@pytest.mark.parametrize("mode", MODES)
def test_completeness_for_many_roots(mode):
    # regression: uniform sampling of the circle aliased near s = 0 and under-counted by 2 here
    res = secular_roots(1.0, mode, 1000)
    assert res.complete and res.n_enclosed == 1000 and np.all(np.diff(res.lam) < 0)


def test_completeness_flag_detects_a_planted_complex_root():
    res = secular_roots(1.0, "sinuous", 6)
    center, radius = res.contour
    planted = center + 0.3 * radius * np.exp(0.7j)
    count = _winding_number(lambda s: _phi_complex(s, 1.0, "sinuous") * (s - planted), center, radius)[0]
    assert count == res.n_enclosed + 1


def test_reduced_function_is_continuous_across_branches():
    for kappa in (1e-3, 1.0, 50.0):
        k2 = kappa * kappa
        for mode in MODES:
            for s0 in (0.0, k2):  # branch junctions: the step across is no larger than the steps beside it
                h = 1e-6 * k2
                f = reduced_secular_function(s0 + h * np.arange(-2.0, 3.0), kappa, mode)
                steps = np.abs(np.diff(f))
                across = max(steps[1], steps[2])
                assert across <= 3.0 * max(steps[0], steps[3]) + 64 * EPS * np.abs(f).max()
            # complex evaluation agrees with the real one (positive scale factors aside) in sign
            s = np.array([-5.0, 0.3 * k2, 0.9 * k2])
            real = reduced_secular_function(s, kappa, mode)
            cplx = reduced_secular_function(s.astype(complex), kappa, mode)
            assert np.all(np.sign(real) == np.sign(cplx.real))
            assert np.all(np.abs(cplx.imag) <= 1e-12 * np.abs(cplx.real))


@settings(max_examples=25, deadline=None, derandomize=True)
@given(log_kappa=st.floats(-3.0, math.log10(50.0)), mode=st.sampled_from(MODES))
@example(log_kappa=0.6015625, mode="varicose")   # gamma = 0.01187i, ill-conditioned near KAPPA_C
def test_property_roots_solve_35_and_are_damped(log_kappa, mode):
    kappa = 10.0 ** log_kappa
    res = secular_roots(kappa, mode, 4)
    assert res.complete and np.all(res.lam < 0) and np.all(np.diff(res.lam) < 0)
    for g in res.gamma:
        assert _brackets_root_of_35(complex(g), kappa, mode)


@pytest.mark.parametrize("kappa", [10.0 ** 0.6015625, KAPPA_C * (1 - 1e-3), KAPPA_C * (1 + 1e-3),
                                   KAPPA_C * (1 + 3e-3), 4.0087967473613520])
def test_roots_near_kappa_c_are_polished_to_16_ulps(kappa):
    # the least-damped varicose root gamma -> 0 near kappa = 4 tanh kappa: kappa^4 - 4 kappa^3 tanh kappa
    # cancels, so the double-precision root is off by ~1e3 ulps (regression: 0.01187i at log kappa = 0.6015625)
    res = secular_roots(kappa, "varicose", 4)
    assert res.polished[0] and res.error_bound[0] <= POLISH_REL
    for g in res.gamma:
        assert _brackets_root_of_35(complex(g), kappa, "varicose")
    # independent: the mpmath root of (35) as printed, started from the returned value
    g0 = complex(res.gamma[0])
    with mpmath.workdps(40):
        k = mpmath.mpf(kappa)
        if g0.imag == 0:
            f = lambda x: mpmath.sinh(x * k) * (x * x + 1) ** 2 - 4 * x * mpmath.tanh(k) * mpmath.cosh(x * k)
            ref = mpmath.findroot(f, mpmath.mpf(g0.real))
            assert abs(g0.real - float(ref)) <= 2 * EPS * float(ref)
        else:
            f = lambda b: mpmath.sin(b * k) * (1 - b * b) ** 2 - 4 * b * mpmath.tanh(k) * mpmath.cos(b * k)
            ref = mpmath.findroot(f, mpmath.mpf(g0.imag))
            assert abs(g0.imag - float(ref)) <= 2 * EPS * float(ref)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kappa", [1e-3, 0.3, 1.0, 5.0, 50.0])
def test_error_bound_is_reported_and_honest(kappa, mode):
    res = secular_roots(kappa, mode, 6)
    assert res.error_bound.shape == (6,) and res.polished.shape == (6,)
    assert np.all(res.error_bound >= EPS) and np.all(res.error_bound <= POLISH_REL)
    for g, bound in zip(res.gamma, res.error_bound):
        assert _brackets_root_of_35(complex(g), kappa, mode, rel=max(4 * bound, 4 * EPS))


# ----------------------------------------------------------------------------- growth rates


def test_growth_rates_scaling():
    base = secular_roots(0.75, "sinuous", 5).lam
    np.testing.assert_allclose(growth_rates(1.5, 1.0, "sinuous", 5), 1.5 ** 2 * base, rtol=4 * EPS)
    np.testing.assert_allclose(growth_rates(3.0, 0.5, "sinuous", 5, nu=2.0), 2.0 * 9.0 * base, rtol=4 * EPS)
    sig = growth_rates(2.0, 3.0, "varicose", 7)
    assert sig.shape == (7,) and np.all(np.diff(sig) < 0) and np.all(sig < 0)


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("call, name", [
    (lambda: secular_roots(0.0, "sinuous", 3), "kappa"),
    (lambda: secular_roots(-1.0, "sinuous", 3), "kappa"),
    (lambda: secular_roots(float("nan"), "sinuous", 3), "kappa"),
    (lambda: secular_roots("1", "sinuous", 3), "kappa"),
    (lambda: secular_roots(1e4, "sinuous", 3), "kappa"),
    (lambda: secular_roots(1.0, "kink", 3), "mode"),
    (lambda: secular_roots(1.0, "sinuous", 0), "n_roots"),
    (lambda: secular_roots(1.0, "sinuous", 2.5), "n_roots"),
    (lambda: secular_roots(1.0, "sinuous", 10 ** 6), "n_roots"),
    (lambda: growth_rates(0.0, 1.0, "sinuous", 3), "k"),
    (lambda: growth_rates(1.0, -1.0, "sinuous", 3), "h"),
    (lambda: growth_rates(1.0, 1.0, "Sinuous", 3), "mode"),
    (lambda: growth_rates(1.0, 1.0, "sinuous", 0), "n_modes"),
    (lambda: growth_rates(1.0, 1.0, "sinuous", 3, nu=0.0), "nu"),
    (lambda: growth_rates(1e-8, 1.0, "sinuous", 3), "k * h / 2"),
    (lambda: chebyshev_eigenvalues(1.0, "sinuous", n_cheb=2), "n_cheb"),
    (lambda: chebyshev_eigenvalues(1.0, "sinuous", method="fd"), "method"),
])
def test_bad_input_raises_value_error_naming_parameter(call, name):
    with pytest.raises(ValueError, match=r"^" + name.replace("*", r"\*")):
        call()


# ----------------------------------------------------------------------------- CLI and validation


def test_cli_prints_both_families_and_plots(tmp_path, capsys):
    png = tmp_path / "sigma.png"
    assert cli_main(["stability", "--kh", "1.0", "--n-modes", "2", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    lam = secular_roots(0.5, "sinuous", 1).lam[0]
    assert "sinuous" in out and "varicose" in out and f"{lam:22.14g}".strip() in out
    assert png.stat().st_size > 1000
    assert cli_main(["stability", "--kh", "-1"]) == 2
    assert "--kh" in capsys.readouterr().err


def test_validation_agreement_table():
    rows = agreement_table(kappas=(0.5, 2.0), n=10, n_cheb=40)
    assert len(rows) == 4
    for r in rows:
        assert r["ultraspherical"] <= 1e-9 and r["max_imag"] == 0.0 and r["lam_first"] < 0
