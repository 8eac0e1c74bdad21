"""Validation of the flat-layer linear stability: secular equation (35) vs Chebyshev vs shooting.

Three independent computations of the eigenvalues lam = lambda / k^2 = gamma^2 - 1 of (28)-(29):

1. ``tps_solver.model.linear_stability.secular_roots`` -- roots of (35) with the trivial
   factors removed analytically (float64, Brent);
2. ``tps_solver.model.linear_stability.chebyshev_eigenvalues`` -- Chebyshev discretisation
   of (28)-(29) (ultraspherical, and collocation for comparison), never using (35);
3. :func:`shooting_determinant` here -- the 2x2 boundary determinant of (29) built from
   the matrix exponential of the 4th-order ODE (28) in mpmath at 50 digits.  It uses
   no closed-form basis, so it is not fooled by the basis degeneracy at gamma = 1
   and gamma = 0 that creates the trivial roots of (35).

Run ``python validation/linear_stability.py`` to print the tables and write
``validation/figures/linear_stability_sigma.png`` and
``validation/figures/linear_stability_convergence.png``.
"""
import os

import mpmath
import numpy as np

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from tps_solver.model.linear_stability import (KAPPA_C, MODES, chebyshev_eigenvalues, growth_rates, secular_roots)

FIG_DIR = os.path.join(_ROOT, "validation", "figures")
KAPPAS = (0.1, 0.5, 1.0, 2.0, 5.0)


def shooting_determinant(lam, kappa, mode, dps=50):
    r"""Boundary determinant of (29) for the parity family, from exp of the ODE (28); mpmath.

    (28) on x = 2z/h is w'''' = (2 kappa^2 + Lambda) w'' - (kappa^4 + Lambda kappa^2) w with
    Lambda = kappa^2 lam.  The even (sinuous) solutions start from (w, w', w'', w''')(0) =
    e_1, e_3, the odd (varicose) ones from e_2, e_4; (29) at x = 1 gives
    w'' + kappa^2 w = 0 and w''' - (3 kappa^2 + Lambda) w' = 0.  Zero iff lam is an eigenvalue.

    Returns
    -------
    det : mpmath.mpf
    """
    with mpmath.workdps(dps):
        k2 = mpmath.mpf(kappa) ** 2
        L = mpmath.mpf(lam) * k2
        C = mpmath.matrix([[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [-(k2 * k2 + L * k2), 0, 2 * k2 + L, 0]])
        E = mpmath.expm(C)
        cols = (0, 2) if mode == "sinuous" else (1, 3)
        M = mpmath.matrix(2, 2)
        for c, col in enumerate(cols):
            M[0, c] = E[2, col] + k2 * E[0, col]
            M[1, c] = E[3, col] - (3 * k2 + L) * E[1, col]
        return +mpmath.det(M)


def shooting_root(lam0, kappa, mode, dps=50):
    """Root of :func:`shooting_determinant` nearest (by the secant method) to ``lam0``."""
    with mpmath.workdps(dps):
        return mpmath.findroot(lambda x: shooting_determinant(x, kappa, mode, dps), mpmath.mpf(lam0))


def agreement_table(kappas=KAPPAS, n=10, n_cheb=40):
    """Max relative difference of the first ``n`` eigenvalues: Chebyshev (both methods) vs (35).

    Returns
    -------
    rows : list of dict
        keys ``kappa, mode, ultraspherical, collocation, max_imag, lam_first, lam_last``.
    """
    rows = []
    for kappa in kappas:
        for mode in MODES:
            ref = secular_roots(kappa, mode, n).lam
            us = chebyshev_eigenvalues(kappa, mode, n_cheb, n_refine=n)[:n]
            co = chebyshev_eigenvalues(kappa, mode, n_cheb, n_refine=n, method="collocation")[:n]
            rows.append(dict(
                kappa=kappa, mode=mode,
                ultraspherical=float(np.max(np.abs(us - ref) / np.abs(ref))),
                collocation=float(np.max(np.abs(co - ref) / np.abs(ref))),
                max_imag=float(np.max(np.abs(us.imag))),
                lam_first=float(ref[0]), lam_last=float(ref[-1])))
    return rows


def convergence_study(kappa=1.0, n_chebs=tuple(range(6, 31, 2)), n=10, method="ultraspherical"):
    """Max relative error of the first ``n`` Chebyshev eigenvalues against (35), per ``n_cheb``.

    Returns
    -------
    out : dict of mode -> ndarray of float, shape (len(n_chebs),); plus ``"n_cheb"``.
    """
    out = {"n_cheb": np.array(n_chebs)}
    for mode in MODES:
        ref = secular_roots(kappa, mode, n).lam
        errs = []
        for nc in n_chebs:
            lam = chebyshev_eigenvalues(kappa, mode, nc, n_refine=n, method=method)
            errs.append(float(np.max(np.abs(lam[:n] - ref) / np.abs(ref))) if len(lam) >= n else np.inf)
        out[mode] = np.array(errs)
    return out


def third_check(kappas=(1e-3, 1.0, 5.0), n=3):
    """Compare both float64 methods with the mpmath shooting roots; probe the trivial roots.

    Returns
    -------
    out : dict
        ``rows``: list of dict (kappa, mode, index, shooting, secular_rel, chebyshev_rel);
        ``trivial``: list of dict (kappa, mode, lam_trivial, det_at_trivial, det_scale, nearest_root)
        where ``det_scale = |det(lam_1)| + |d det/d lam (lam_1)| |lam_1|`` at the least damped
        eigenvalue lam_1, and ``nearest_root`` is where the secant method started at the
        trivial root converges.
    """
    rows, trivial = [], []
    for kappa in kappas:
        for mode in MODES:
            sec = secular_roots(kappa, mode, n).lam
            che = chebyshev_eigenvalues(kappa, mode, 40, n_refine=n)[:n].real
            for i in range(n):
                ref = shooting_root(sec[i], kappa, mode)
                rows.append(dict(kappa=kappa, mode=mode, index=i, shooting=float(ref),
                                 secular_rel=float(abs((sec[i] - ref) / ref)),
                                 chebyshev_rel=float(abs((che[i] - ref) / ref))))
            lam1 = shooting_root(sec[0], kappa, mode)
            with mpmath.workdps(50):  # |d det / d lam| |lam_1| by a 1e-8 relative difference
                scale = abs(shooting_determinant(lam1 * (1 + mpmath.mpf("1e-8")), kappa, mode)
                            - shooting_determinant(lam1, kappa, mode)) / mpmath.mpf("1e-8")
            for lam_t in ([0.0] if mode == "sinuous" else [0.0, -1.0]):
                det_t = shooting_determinant(lam_t, kappa, mode)
                try:
                    nearest = float(shooting_root(lam_t, kappa, mode))
                except ValueError:  # secant did not converge
                    nearest = float("nan")
                trivial.append(dict(kappa=kappa, mode=mode, lam_trivial=lam_t,
                                    det_ratio=float(abs(det_t) / scale), nearest_root=nearest,
                                    lam_1=float(lam1)))
    return dict(rows=rows, trivial=trivial)


def missed_roots(kappas=(1e-3, 0.1, 0.5, 1.0, 2.0, KAPPA_C, 5.0, 10.0, 50.0)):
    """The least damped root of each family: real gamma in (0, 1) roots that (35)'s text omits.

    Returns
    -------
    rows : list of dict (kappa, mode, gamma, lam)
    """
    rows = []
    for kappa in kappas:
        for mode in MODES:
            r = secular_roots(kappa, mode, 1)
            rows.append(dict(kappa=float(kappa), mode=mode, gamma=complex(r.gamma[0]), lam=float(r.lam[0]),
                             complete=bool(r.complete)))
    return rows


def free_surface_limit():
    """kappa -> inf: (35) tends to 4 gamma = (gamma^2 + 1)^2, i.e. gamma^3 + gamma^2 + 3 gamma - 1 = 0."""
    g = [r.real for r in np.roots([1.0, 1.0, 3.0, -1.0]) if abs(r.imag) < 1e-12][0]
    return dict(gamma_limit=g, lam_limit=g * g - 1.0,
                lam_kappa50={m: float(secular_roots(50.0, m, 1).lam[0]) for m in MODES})


def sigma_curves(kh=None, n_modes=3):
    """sigma h^2 / nu (h = 1, nu = 1) of the leading modes against k h.

    Returns
    -------
    out : dict with ``kh`` (shape (n,)) and, per mode, an array of shape (n, n_modes).
    """
    kh = np.geomspace(1e-2, 20.0, 61) if kh is None else np.asarray(kh, dtype=float)
    out = {"kh": kh}
    for mode in MODES:
        out[mode] = np.array([growth_rates(x, 1.0, mode, n_modes) for x in kh])
    return out


def _fmt_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def main():
    import matplotlib.pyplot as plt

    from tps_solver.plotting import plot_growth_rates as plot_sigma

    os.makedirs(FIG_DIR, exist_ok=True)
    print("## Agreement of the first 10 eigenvalues, Chebyshev (n_cheb = 40) vs (35), max relative difference\n")
    rows = agreement_table()
    print(_fmt_table(["kappa", "mode", "ultraspherical", "collocation", "max Im (us)", "lam_1", "lam_10"],
                     [[f"{r['kappa']:g}", r["mode"], f"{r['ultraspherical']:.1e}", f"{r['collocation']:.1e}",
                       f"{r['max_imag']:.0e}", f"{r['lam_first']:.10g}", f"{r['lam_last']:.8g}"] for r in rows]))
    print("\n## Spectral convergence at kappa = 1 (max rel. error of the first 10 eigenvalues)\n")
    conv = convergence_study()
    print(_fmt_table(["n_cheb", "sinuous", "varicose"],
                     [[str(n), f"{a:.1e}", f"{b:.1e}"] for n, a, b in
                      zip(conv["n_cheb"], conv["sinuous"], conv["varicose"])]))
    print("\n## Third check: mpmath shooting determinant (50 digits)\n")
    tc = third_check()
    print(_fmt_table(["kappa", "mode", "i", "lam (shooting)", "secular rel", "Chebyshev rel"],
                     [[f"{r['kappa']:g}", r["mode"], str(r["index"] + 1), f"{r['shooting']:.15g}",
                       f"{r['secular_rel']:.1e}", f"{r['chebyshev_rel']:.1e}"] for r in tc["rows"]]))
    print()
    print(_fmt_table(["kappa", "mode", "trivial lam", "|det| / (|det'| |lam_1|)", "secant from trivial -> ", "lam_1"],
                     [[f"{r['kappa']:g}", r["mode"], f"{r['lam_trivial']:g}", f"{r['det_ratio']:.3g}",
                       f"{r['nearest_root']:.12g}", f"{r['lam_1']:.12g}"] for r in tc["trivial"]]))
    print("\n## Least damped root of each family (real gamma in (0,1) = root missed by the paper)\n")
    print(_fmt_table(["kappa", "mode", "gamma", "lam = sigma/(nu k^2)"],
                     [[f"{r['kappa']:.6g}", r["mode"],
                       f"{r['gamma'].real:.12g}" if r["gamma"].imag == 0 else f"{r['gamma'].imag:.12g}i",
                       f"{r['lam']:.12g}"] for r in missed_roots()]))
    fs = free_surface_limit()
    print(f"\nkappa -> inf limit: gamma = {fs['gamma_limit']:.15f}, lam = {fs['lam_limit']:.15f}; "
          f"at kappa = 50: {fs['lam_kappa50']}")

    path = os.path.join(FIG_DIR, "linear_stability_sigma.png")
    plot_sigma(path)
    print(f"\nwrote {path}")
    fig, ax = plt.subplots(figsize=(6, 4))
    for mode, st in (("sinuous", "o-"), ("varicose", "s--")):
        ax.semilogy(conv["n_cheb"], np.maximum(conv[mode], 1e-17), st, label=mode)
    ax.set_xlabel("n_cheb (Chebyshev polynomials per parity)")
    ax.set_ylabel("max rel. error, first 10 eigenvalues")
    ax.set_title(r"Ultraspherical Chebyshev vs (35), $\kappa = 1$")
    ax.legend()
    fig.tight_layout()
    path = os.path.join(FIG_DIR, "linear_stability_convergence.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
