r"""Independent references and measured checks for the flat layer, eqs. (17)-(19).

The references here deliberately avoid the code paths of :mod:`tps_solver.model.flat`:

* the flight is written in the paper's *first* form of (17)-(18)
  (``zeta = (W0 + cos t0) tau + sin t0 - sin t - tau^2/2Gamma``), whereas
  ``FlatLayer.height`` uses the second form obtained after imposing (19);
* the impact map is integrated as an ODE (``scipy.integrate.solve_ivp``,
  DOP853, terminal event ``zeta = 0``) instead of root-finding on monotone
  pieces of the closed form;
* admissibility is judged by dense sampling plus a bounded local minimiser;
* Fourier coefficients come from QUADPACK's oscillatory rule
  (``quad(weight='cos'/'sin')``), not from the closed form;
* the upper end of the stability window is found by bisection on the
  largest multiplier modulus, not on the trace criterion that
  :meth:`FlatLayer.stability_window` uses, and Jacobians are cross-checked
  by central differences of the exact map.

Every function returns numbers; ``main()`` prints the tables quoted in
``validation/sections/flat.md`` and draws ``validation/figures/flat_multipliers.png``.

Run ``python validation/flat_layer_analytics.py`` from the repository root.
"""
import math
import os

import numpy as np
from scipy import integrate, optimize

from tps_solver.model.flat import FlatLayer

__all__ = [
    "paper_flight", "interior_min_height", "quad_coefficients", "mpmath_coefficient", "ode_impact_map",
    "fd_jacobian", "upper_end_by_bisection", "window_table", "jacobian_table",
    "harmonics_table", "main",
]


def paper_flight(t, t_start, v, Gamma):
    r"""Velocity and height of a flight launched from the plate, first form of (17)-(18).

    Parameters
    ----------
    t : array_like of float
        Times (no periodic wrapping).
    t_start : float
        Launch time, where ``zeta = 0``.
    v : float
        Launch (post-impact) velocity.
    Gamma : float

    Returns
    -------
    W, zeta : ndarray of float, same shape as ``t``
    """
    t = np.asarray(t, dtype=float)
    tau = t - t_start
    W = v + math.cos(t_start) - np.cos(t) - tau / Gamma
    zeta = (v + math.cos(t_start)) * tau + math.sin(t_start) - np.sin(t) - tau * tau / (2.0 * Gamma)
    return W, zeta


def interior_min_height(Gamma, t0, W0, T, n_samples=20001):
    """Smallest interior local minimum of the paper's zeta on the open flight (t0, t0 + T).

    Dense sampling locates every sampled local minimum; each is refined by
    ``scipy.optimize.minimize_scalar`` (bounded) between its neighbours.

    Returns
    -------
    t_min, zeta_min : float
        ``(nan, inf)`` if zeta has no interior local minimum.
    """
    t = np.linspace(t0, t0 + T, n_samples)
    z = paper_flight(t, t0, W0, Gamma)[1]
    idx = np.flatnonzero((z[1:-1] <= z[:-2]) & (z[1:-1] <= z[2:])) + 1
    best = (math.nan, math.inf)
    for i in idx:
        res = optimize.minimize_scalar(lambda s: float(paper_flight(s, t0, W0, Gamma)[1]),
                                       bounds=(t[i - 1], t[i + 1]), method="bounded",
                                       options={"xatol": 1e-13})
        if res.fun < best[1]:
            best = (float(res.x), float(res.fun))
    return best


def quad_coefficients(f, t_start, T, M, N, epsrel=1e-13):
    r"""Fourier coefficients :math:`(1/T)\int_{t_s}^{t_s+T} f e^{-in t/M} dt` by QUADPACK.

    ``f`` must be smooth on the open interval (it is only evaluated inside).
    Uses ``quad(weight='cos'/'sin')`` (QAWO) for ``n != 0``.

    Returns
    -------
    c : ndarray of complex, shape (2N+1,)
        Entry ``N + n`` is the ``n``-th coefficient.
    err : float
        Largest QUADPACK error estimate divided by ``T``.
    """
    c = np.zeros(2 * N + 1, dtype=complex)
    err = 0.0
    a, b = t_start, t_start + T
    # absolute tolerance at the round-off level of the integral: eps-ish times T times max|f|
    scale = max(abs(f(s)) for s in np.linspace(a, b, 257)[1:-1])
    epsabs = 1e-14 * T * scale
    for n in range(-N, N + 1):
        if n == 0:
            val, e0 = integrate.quad(f, a, b, epsabs=epsabs, epsrel=epsrel, limit=200)
            c[N] = val / T
            err = max(err, e0 / T)
            continue
        re, e1 = integrate.quad(f, a, b, weight="cos", wvar=n / M, epsabs=epsabs, epsrel=epsrel, limit=200)
        im, e2 = integrate.quad(f, a, b, weight="sin", wvar=n / M, epsabs=epsabs, epsrel=epsrel, limit=200)
        c[N + n] = (re - 1j * im) / T
        err = max(err, e1 / T, e2 / T)
    return c, err


def mpmath_coefficient(Gamma, M, e, branch, n, which="velocity", dps=24):
    r"""One Fourier coefficient of the flat orbit's W or zeta by ``mpmath.quad`` at ``dps`` digits.

    The orbit itself is rebuilt at that precision from (19) (``e`` is taken as
    the decimal string of the float), so this reference shares nothing with
    the package.

    Returns
    -------
    c : complex
    """
    import mpmath

    with mpmath.workdps(dps):
        G = mpmath.mpf(repr(float(Gamma)))
        e = mpmath.mpf(repr(float(e)))
        T = 2 * mpmath.pi * M
        c = (1 - e) / (1 + e) * T / (2 * G)
        t0 = mpmath.acos(c) if branch == "stable" else -mpmath.acos(c)
        W0 = T / (2 * G) - mpmath.cos(t0)
        if which == "velocity":
            def f(t):
                return W0 + mpmath.cos(t0) - mpmath.cos(t) - (t - t0) / G
        else:
            def f(t):
                return (W0 + mpmath.cos(t0)) * (t - t0) + mpmath.sin(t0) - mpmath.sin(t) - (t - t0) ** 2 / (2 * G)
        nodes = mpmath.linspace(t0, t0 + T, 2 * abs(n) + 3)
        return complex(mpmath.quad(lambda t: f(t) * mpmath.expj(-n * t / M), nodes, method="gauss-legendre") / T)


def ode_impact_map(Gamma, e, t, v, max_time):
    """The impact map by integrating dW/dt = sin t - 1/Gamma, dzeta/dt = W (DOP853).

    Returns
    -------
    t_next, v_next : float
        First return to ``zeta = 0`` (descending) and ``-e`` times the
        arrival velocity.
    """
    def rhs(s, y):
        return [math.sin(s) - 1.0 / Gamma, y[0]]

    def hit(s, y):
        return y[1]

    hit.terminal = True
    hit.direction = -1.0
    sol = integrate.solve_ivp(rhs, (t, t + max_time), [v, 0.0], method="DOP853", events=hit,
                              rtol=1e-13, atol=1e-14, max_step=0.05)
    if sol.status != 1:
        raise RuntimeError("ode_impact_map: no impact found")
    t_next = float(sol.t_events[0][0])
    return t_next, -e * float(sol.y_events[0][0][0])


def fd_jacobian(fl, t, v, h=1e-6):
    """Central-difference Jacobian of ``fl.impact_map`` at ``(t, v)``, rows (t', v').

    Steps are ``h`` in ``t`` and ``h * max(1, v)`` in ``v``.
    """
    J = np.empty((2, 2))
    steps = (h, h * max(1.0, abs(v)))
    for j, d in enumerate(steps):
        dp = np.array([t, v], dtype=float)
        dm = dp.copy()
        dp[j] += d
        dm[j] -= d
        fp = np.array(fl.impact_map(*dp))
        fm = np.array(fl.impact_map(*dm))
        J[:, j] = (fp - fm) / (2.0 * d)
    return J


def _max_modulus(Gamma, M, e):
    return float(np.max(np.abs(FlatLayer(Gamma, M, e=e).floquet_multipliers())))


def upper_end_by_bisection(e, M, rtol=1e-13):
    """Upper end of the stable Gamma-interval by bisection on ``max |mu| = 1``.

    Independent of the trace criterion of :meth:`FlatLayer.stability_window`:
    start just above the fold ``s pi M`` (where the stable branch is born),
    walk up in steps of 1 % until the largest multiplier modulus exceeds 1,
    then bisect.

    Returns
    -------
    Gamma_pd : float
    """
    s = (1.0 - e) / (1.0 + e)
    a = s * math.pi * M * (1.0 + 1e-6)
    if _max_modulus(a, M, e) >= 1.0:
        raise RuntimeError("stable branch not stable just above the fold")
    b = a
    while _max_modulus(b, M, e) < 1.0:
        a, b = b, b * 1.01
    while b - a > rtol * b:
        mid = 0.5 * (a + b)
        if _max_modulus(mid, M, e) < 1.0:
            a = mid
        else:
            b = mid
    return 0.5 * (a + b)


def window_table(cases=((0.45, 1), (0.45, 2), (0.45, 4), (0.2, 2), (0.7, 3), (0.9, 1)), delta=1e-8):
    """Stability-window endpoints and the multipliers next to them.

    Returns
    -------
    rows : list of dict
        ``e, M, low, high`` (:meth:`FlatLayer.stability_window`), ``high_bisect``
        (:func:`upper_end_by_bisection`), ``mu_low`` (largest multiplier of the
        stable branch at ``low (1 + delta)``), ``mu_high_in``/``mu_high_out``
        (the multiplier of largest modulus at ``high (1 -+ delta)``).
    """
    rows = []
    for e, M in cases:
        low, high = FlatLayer.stability_window(e, M)
        rows.append(dict(
            e=e, M=M, low=low, high=high, high_bisect=upper_end_by_bisection(e, M),
            mu_low=FlatLayer(low * (1 + delta), M, e=e).floquet_multipliers()[0],
            mu_high_in=FlatLayer(high * (1 - delta), M, e=e).floquet_multipliers()[0],
            mu_high_out=FlatLayer(high * (1 + delta), M, e=e).floquet_multipliers()[0],
        ))
    return rows


JACOBIAN_CASES = (
    # (Gamma, M, e, branch)
    (1.4, 1, 0.45, "stable"), (1.4, 1, 0.45, "unstable"),
    (2.5, 2, 0.45, "stable"), (2.5, 2, 0.45, "unstable"),
    (2.62, 2, 0.45, "stable"), (2.42, 2, 0.45, "unstable"),
    (4.8, 4, 0.45, "stable"), (4.8, 4, 0.45, "unstable"),
)


def jacobian_table(cases=JACOBIAN_CASES, h=1e-6):
    """Analytic Jacobian of the impact map vs central differences, and det J vs e^2.

    Returns
    -------
    rows : list of dict
        ``Gamma, M, e, branch, fd_err`` (max abs entry difference at the
        periodic orbit, over max abs entry), ``fd_err_off`` (same at the
        off-orbit point ``(t0 + 0.01, 1.02 W0)``), ``det_err`` (``|det J - e^2|``),
        ``mu`` (multipliers).
    """
    rows = []
    for G, M, e, branch in cases:
        fl = FlatLayer(G, M, e=e, branch=branch)
        J = fl.impact_map_jacobian()
        Jfd = fd_jacobian(fl, fl.t0, fl.W0, h)
        t1, v1 = fl.t0 + 0.01, 1.02 * fl.W0
        Joff = fl.impact_map_jacobian(t1, v1)
        Joff_fd = fd_jacobian(fl, t1, v1, h)
        rows.append(dict(
            Gamma=G, M=M, e=e, branch=branch,
            fd_err=float(np.max(np.abs(J - Jfd)) / np.max(np.abs(J))),
            fd_err_off=float(np.max(np.abs(Joff - Joff_fd)) / np.max(np.abs(Joff))),
            det_err=abs(float(np.linalg.det(J)) - e * e),
            mu=fl.floquet_multipliers(),
        ))
    return rows


def harmonics_table(cases=((2.5, 2, 0.45, "stable"), (2.5, 2, 0.45, "unstable"), (1.4, 1, 0.45, "stable"),
                           (4.8, 4, 0.45, "stable"), (0.8, 4, 0.9, "stable")), N=30):
    """Closed-form ``harmonics``/``height_harmonics`` vs QUADPACK quadrature of the paper's W and zeta.

    Returns
    -------
    rows : list of dict
        ``w_rel`` / ``z_rel``: max over ``n != 0`` of ``|closed - quad| / |closed|``;
        ``w0_abs``/``z0_rel``: the mean (n = 0) errors; ``quad_err``: largest
        QUADPACK error estimate (already divided by T); ``w_rel_mp``/``z_rel_mp``:
        relative error of the n = N coefficient against :func:`mpmath_coefficient`.
    """
    rows = []
    n = np.arange(-N, N + 1)
    nz = n != 0
    for G, M, e, branch in cases:
        fl = FlatLayer(G, M, e=e, branch=branch)
        W = lambda s: float(paper_flight(s, fl.t0, fl.W0, G)[0])  # noqa: E731
        Z = lambda s: float(paper_flight(s, fl.t0, fl.W0, G)[1])  # noqa: E731
        wq, ew = quad_coefficients(W, fl.t0, fl.period, M, N)
        zq, ez = quad_coefficients(Z, fl.t0, fl.period, M, N)
        w = fl.harmonics(N)
        z = fl.height_harmonics(N)
        rows.append(dict(
            Gamma=G, M=M, e=e, branch=branch, N=N,
            w_rel=float(np.max(np.abs(w[nz] - wq[nz]) / np.abs(w[nz]))),
            w0_abs=abs(w[N] - wq[N]),
            z_rel=float(np.max(np.abs(z[nz] - zq[nz]) / np.abs(z[nz]))),
            z0_rel=abs(z[N] - zq[N]) / abs(z[N]),
            quad_err=max(ew, ez),
            w_rel_mp=abs(w[2 * N] - mpmath_coefficient(G, M, e, branch, N, "velocity")) / abs(w[2 * N]),
            z_rel_mp=abs(z[2 * N] - mpmath_coefficient(G, M, e, branch, N, "height")) / abs(z[2 * N]),
        ))
    return rows


def _plot_multipliers(path, e=0.45, M=2):
    import matplotlib.pyplot as plt

    low, high = FlatLayer.stability_window(e, M)
    G = np.linspace(low * (1 + 1e-9), high + 0.6 * (high - low), 400)
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for branch, style in (("stable", "-"), ("unstable", "--")):
        mods, gs = [], []
        for g in G:
            try:
                mods.append(np.abs(FlatLayer(g, M, e=e, branch=branch).floquet_multipliers()))
                gs.append(g)
            except ValueError:
                continue
        mods = np.array(mods)
        ax.plot(gs, mods[:, 0], style, color="C0" if branch == "stable" else "C3", label=f"{branch}: max|mu|")
        ax.plot(gs, mods[:, 1], style, color="C0" if branch == "stable" else "C3", alpha=0.4)
    ax.axhline(1.0, color="k", lw=0.5)
    ax.axvline(low, color="k", ls=":", lw=0.8)
    ax.axvline(high, color="k", ls=":", lw=0.8)
    ax.set_ylim(0, 3)
    ax.set_xlabel(r"$\Gamma$")
    ax.set_ylabel(r"$|\mu|$")
    ax.set_title(f"flat layer multipliers, e = {e}, M = {M}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    """Print the tables of ``validation/sections/flat.md`` and draw the multiplier figure."""
    print("| e | M | Gamma_low (fold) | Gamma_high (trace) | Gamma_high (bisection on max abs mu) | rel. diff |"
          " mu_max at low(1+1e-8) | mu_max at high(1-1e-8) | mu_max at high(1+1e-8) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in window_table():
        print(f"| {r['e']} | {r['M']} | {r['low']:.12f} | {r['high']:.12f} | {r['high_bisect']:.12f} | "
              f"{abs(r['high'] - r['high_bisect']) / r['high']:.1e} | {r['mu_low'].real:.6f} | "
              f"{r['mu_high_in'].real:.8f} | {r['mu_high_out'].real:.8f} |")
    print()
    print("| Gamma | M | e | branch | multipliers | FD err (orbit) | FD err (off orbit) | abs(det J - e^2) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in jacobian_table():
        mu = ", ".join(f"{m.real:+.6f}{m.imag:+.6f}j" for m in r["mu"])
        print(f"| {r['Gamma']} | {r['M']} | {r['e']} | {r['branch']} | {mu} | {r['fd_err']:.1e} | "
              f"{r['fd_err_off']:.1e} | {r['det_err']:.1e} |")
    print()
    print("| Gamma | M | e | branch | N | W_n rel err | abs W_0 | zeta_n rel err | zeta_0 rel err | quad err est |"
          " W_N vs mpmath | zeta_N vs mpmath |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in harmonics_table():
        print(f"| {r['Gamma']} | {r['M']} | {r['e']} | {r['branch']} | {r['N']} | {r['w_rel']:.1e} | "
              f"{r['w0_abs']:.1e} | {r['z_rel']:.1e} | {r['z0_rel']:.1e} | {r['quad_err']:.1e} | "
              f"{r['w_rel_mp']:.1e} | {r['z_rel_mp']:.1e} |")
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "figures")
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "flat_multipliers.png")
    _plot_multipliers(path)
    print(f"\nfigure: {path}")


if __name__ == "__main__":
    main()
