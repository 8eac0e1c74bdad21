"""The e = 0 kink under refinement: both pinned kinks, which is stable, the pinning strength, the width.

On a lattice the front of a kink is pinned: a kink whose mirror point is a node and one whose
mirror point is midway between two nodes are two different periodic orbits.  Both are computed
here as fixed points of the mirrored half-period map
(:class:`tps_solver.solvers.shooting.symmetric.MirroredHalfPeriodMap`, ``tps.lattice_kink(...,
symmetric=True)``): on ``Lattice.planar`` with an odd number of nodes the mirror point x = 0 is a
node, with an even number it is midway between two, at the same spacing (lengths 40 and
40 - dx).  :func:`pinned_kink` measures each (its symmetry centre, :func:`symmetry_centre`, as a
check; the leading Floquet multiplier of the period map; the width; the time), and
:func:`both_pinned` pairs them: the stable one (|mu1| < 1), the pinning strength
1 - |mu1| of the stable kink and |mu1| - 1 of the saddle, and the width gap between them.

Widths: the package's first-crossing width (:func:`tps_solver.front_width`,
``instant="lower_far_field_top"``: the 10--90 % width of the height at the instant where the
lower far field is highest, linear interpolation) is recorded, but it switches between pairs of
nodes as dx changes.  The width whose convergence is studied is the integral width
:func:`integral_width` of the height profile at that same instant (saved in the cache), a smooth
function of the nodal heights.  :func:`fit_convergence` fits W(dx) = w0 + c dx^p to the finest
spacings (p fitted, and p = 1/2, p = 1), and :func:`continuum_fit` states w0 with an error bar.
The former estimate (:func:`continuum_width`: mean of the two pinned widths at the finest
spacing) is kept for comparison.

Run ``python -m validation.kink_pinning [--gamma 3.9 4.1 4.4] [--dx 2 1 0.5 0.25 0.125 0.0625 0.03125]
[--only-cached]`` (one BLAS thread).  Results are cached per case in ``validation/data/kink_pinning/`` (``*_node.json``,
``*_bond.json``) so that an interrupted run resumes.
"""
import argparse
import json
import os
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, one_blas_thread, publish

LENGTH = 40.0
CACHE = os.path.join(os.path.dirname(__file__), "data", "kink_pinning")


def symmetry_centre(orbit, n_samples=64):
    """Where the kink is centred: the mirror point c with zeta(x, t) = zeta(2c - x, t + T/2).

    Returns ``(kind, x_c, error)``: ``kind`` "node" or "bond" (c on a node or midway between two),
    ``x_c`` the position and ``error`` the max mismatch of heights over the period within 12 of c
    (rounding level for a symmetric kink).
    """
    x = np.asarray(orbit.lattice.nodes, float)
    n = x.size
    T = orbit.period
    ts = (orbit.t_start or 0.0) + T * np.arange(n_samples) / n_samples
    Z, Zs = np.asarray(orbit.height(ts)), np.asarray(orbit.height(ts + T / 2))
    dx = x[1] - x[0]
    best = (np.inf, 0)
    for k in range(2, 2 * n - 3):                       # mirror about index k / 2
        i = np.arange(n)
        m = k - i
        keep = (m >= 0) & (m < n) & (np.abs(i - k / 2) * dx <= 12.0)
        if keep.sum() < 3:
            continue
        best = min(best, (float(np.max(np.abs(Z[:, i[keep]] - Zs[:, m[keep]]))), k))
    err, k = best
    return ("node" if k % 2 == 0 else "bond"), float(x[0] + k / 2 * dx), err


def refined_instant(orbit, t_grid, half_step):
    """The instant where the lower far field is highest, min(zeta_L, zeta_R) maximised continuously.

    ``front_width`` picks it on a grid of the period; W changes by ~5e-3 per 1/1024 of a period there
    (measured at Gamma = 4.1, dx = 0.5), so the grid's instant would add that much noise in dx.
    A bounded scalar search within ``half_step`` of ``t_grid`` (tolerance 1e-12).
    """
    from scipy.optimize import minimize_scalar

    def minus_low(t):
        z = np.asarray(orbit.height(np.array([t])))[0]
        return -min(z[0], z[-1])
    res = minimize_scalar(minus_low, bounds=(t_grid - half_step, t_grid + half_step), method="bounded",
                          options=dict(xatol=1e-12))
    return float(res.x)


def pinned_kink(Gamma, dx, centre="node", length=LENGTH):
    """The kink centred on a node (``centre="node"``) or between two (``"bond"``) at (Gamma, dx).

    ``tps.lattice_kink(..., symmetric=True)`` on ``Lattice.planar`` with ``round(length / dx) + 1``
    nodes (node) or one fewer (bond); a dict of measured numbers (|mu1| says if it is stable).
    """
    if centre not in ("node", "bond"):
        raise ValueError(f"centre must be 'node' or 'bond', got {centre!r}")
    n = int(round(length / dx)) + 1
    if (n % 2 == 1) != (centre == "node"):
        n -= 1
    lat = tps.Lattice.planar(n_nodes=n, length=dx * (n - 1))
    start = time.perf_counter()
    with one_blas_thread():
        orb = tps.lattice_kink(lat, Gamma=Gamma, e=0.0, symmetric=True)
    seconds = time.perf_counter() - start
    row = dict(Gamma=Gamma, dx=dx, centre=centre, n_nodes=n, converged=bool(orb.converged),
               residual=float(orb.residual), symmetric_nit=orb.symmetric_nit, nit=int(orb.nit),
               seconds=seconds)
    if not orb.converged:
        row.update(mu1=None, pinning=None, width=None, found_centre=None, symmetry_error=None,
                   message=orb.message)
        return row
    (w,), (t_w,) = tps.front_width(orb, instant="lower_far_field_top", return_times=True)
    t_w = refined_instant(orb, t_w, orb.period / 512)
    profile = np.asarray(orb.height(np.array([t_w])))[0]
    kind, xc, err = symmetry_centre(orb)
    mu1 = float(np.abs(np.asarray(orb.multipliers)[0]))
    row.update(mu1=mu1, pinning=1.0 - mu1, width=float(w), found_centre=kind, x_centre=xc, symmetry_error=err,
               message="", t_width=float(t_w), instant="refined",
               profile=[float(z) for z in profile])
    return row


def cached_kink(Gamma, dx, centre="node", need_profile=False):
    """:func:`pinned_kink`, cached as JSON in ``validation/data/kink_pinning/``.

    With ``need_profile`` a cached row without the height profile at the refined instant (an earlier
    run) is recomputed.
    """
    os.makedirs(CACHE, exist_ok=True)
    path = os.path.join(CACHE, f"G{Gamma:g}_dx{dx:g}_{centre}.json")
    if os.path.exists(path):
        with open(path) as fh:
            row = json.load(fh)
        if not need_profile or row.get("instant") == "refined" or not row["converged"]:
            return row
    row = pinned_kink(Gamma, dx, centre)
    with open(path, "w") as fh:
        json.dump(row, fh)
    return row


def both_pinned(node, bond):
    """The pair at one (Gamma, dx): which is stable, the two pinning strengths, the widths' mean and gap."""
    out = dict(Gamma=node["Gamma"], dx=node["dx"], mu_node=node["mu1"], mu_bond=bond["mu1"],
               width_node=node["width"], width_bond=bond["width"], stable=None, pinning=None, mean=None, gap=None)
    if node["converged"] and bond["converged"]:
        stable = [c for c, r in (("node", node), ("bond", bond)) if r["mu1"] < 1.0]
        out["stable"] = "+".join(stable) if stable else "neither"
        out["pinning"] = min(abs(1.0 - node["mu1"]), abs(1.0 - bond["mu1"]))
        out["mean"] = 0.5 * (node["width"] + bond["width"])
        out["gap"] = node["width"] - bond["width"]
    out["seconds"] = node["seconds"] + bond["seconds"]
    return out


def continuum_width(pairs):
    """Continuum width and error bar from the pairs of :func:`both_pinned` at one Gamma (None if < 2).

    The mean of the two pinned widths at the finest spacing; error bar: half their gap there plus
    the change of the mean from the next coarser spacing.
    """
    s = sorted([p for p in pairs if p["mean"] is not None], key=lambda p: -p["dx"])
    if len(s) < 2:
        return None, None
    return s[-1]["mean"], 0.5 * abs(s[-1]["gap"]) + abs(s[-1]["mean"] - s[-2]["mean"])


def mean_increments(pairs):
    """Changes of the mean pinned width from each spacing to the next finer one (coarse to fine)."""
    s = sorted([p for p in pairs if p["mean"] is not None], key=lambda p: -p["dx"])
    return [b["mean"] - a["mean"] for a, b in zip(s[:-1], s[1:])]


LN9 = float(np.log(9.0))


def integral_width(x, zeta):
    r"""Integral front width of one height profile: :math:`W = 2\ln 9\int \theta(1 - \theta)\,dx`.

    :math:`\theta = (\zeta - \zeta_L)/(\zeta_R - \zeta_L)` with :math:`\zeta_{L,R}` the end nodes
    (as in :func:`tps_solver.front_width`), the integral by the trapezoid rule over the nodes.
    The factor makes W the 10--90 % width of a tanh front: for
    :math:`\theta = (1 + \tanh(x/\delta))/2`, :math:`\int\theta(1-\theta)\,dx = \delta/2` and the
    10--90 % width is :math:`\delta\ln 9`.  Unlike a first-crossing width with linear
    interpolation, W has no switch from one pair of nodes to the next as the lattice is refined:
    it is a smooth function of the nodal heights and (trapezoid rule) of dx.

    Parameters
    ----------
    x : array_like of float, shape (n,)
        Node positions, increasing, n >= 2.
    zeta : array_like of float, shape (n,)
        Heights at one instant.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If the shapes differ, n < 2, x is not increasing or the end heights coincide (no front).

    Examples
    --------
    >>> x = np.linspace(-40.0, 40.0, 801)
    >>> round(float(integral_width(x, np.tanh(x / 3.0)) / (3.0 * np.log(9.0))), 9)
    1.0
    """
    x, zeta = np.asarray(x, float), np.asarray(zeta, float)
    if x.ndim != 1 or x.shape != zeta.shape or x.size < 2:
        raise ValueError(f"x and zeta must be 1D of one length >= 2, got shapes {x.shape} and {zeta.shape}")
    if np.any(np.diff(x) <= 0):
        raise ValueError("x must be strictly increasing")
    contrast = zeta[-1] - zeta[0]
    if not abs(contrast) > 1e-12 * max(float(np.max(np.abs(zeta))), np.finfo(float).tiny):
        raise ValueError("zeta has no front: its end heights coincide")
    th = (zeta - zeta[0]) / contrast
    f = th * (1.0 - th)
    return float(2.0 * LN9 * np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))


def spline_width(x, zeta):
    """10--90 % width of a cubic-spline interpolant of theta (first crossing of each level); a cross-check."""
    from scipy.interpolate import CubicSpline
    x, zeta = np.asarray(x, float), np.asarray(zeta, float)
    th = (zeta - zeta[0]) / (zeta[-1] - zeta[0])
    cs = CubicSpline(x, th)
    lo, hi = cs.solve(0.1, extrapolate=False), cs.solve(0.9, extrapolate=False)
    if lo.size == 0 or hi.size == 0:
        return None
    return float(hi[0] - lo[0])


def profile_widths(row):
    """Integral and spline widths of a cached row's saved profile (None if it has none)."""
    if row.get("profile") is None or row.get("instant") != "refined":
        return None, None
    z = np.asarray(row["profile"], float)
    x = row["dx"] * (np.arange(z.size) - (z.size - 1) / 2.0)
    return integral_width(x, z), spline_width(x, z)


def fit_convergence(dx, width, p=None):
    r"""Least-squares fit of :math:`w(\Delta x) = w_0 + c\,\Delta x^p`.

    With ``p`` given the fit is linear in (w0, c); with ``p=None`` the exponent is fitted too
    (the residual minimised over p in [0.05, 4] by a bounded scalar search, w0 and c linear for
    each p).  Standard errors from the linearised covariance, :math:`s^2 (J^T J)^{-1}` with
    :math:`s^2` the residual sum of squares over the degrees of freedom; None where there are
    none (as many points as parameters: the fit interpolates).

    Parameters
    ----------
    dx, width : array_like of float, shape (m,)
        Spacings (> 0) and widths; m >= 2 (fixed p) or m >= 3 (fitted p).
    p : float or None
        The exponent, or None to fit it.

    Returns
    -------
    dict
        ``w0, w0_err, c, p, p_err, rms`` (rms of the residuals), ``dof``.

    Raises
    ------
    ValueError
        Too few points, or dx not positive.

    Examples
    --------
    >>> d = np.array([0.25, 0.125, 0.0625, 0.03125])
    >>> f = fit_convergence(d, 7.5 - 0.2 * np.sqrt(d))
    >>> round(f["w0"], 10), round(f["p"], 6)
    (7.5, 0.5)
    """
    from scipy.optimize import minimize_scalar
    d, w = np.asarray(dx, float), np.asarray(width, float)
    need = 2 if p is not None else 3
    if d.ndim != 1 or d.shape != w.shape or d.size < need:
        raise ValueError(f"dx and width need >= {need} points of one shape, got {d.shape} and {w.shape}")
    if np.any(d <= 0):
        raise ValueError("dx must be > 0")
    scale = float(np.max(d))

    def linear(q):
        A = np.column_stack([np.ones_like(d), (d / scale) ** q])
        coef, *_ = np.linalg.lstsq(A, w, rcond=None)
        return coef, float(np.sum((A @ coef - w) ** 2))

    if p is None:
        res = minimize_scalar(lambda q: linear(q)[1], bounds=(0.05, 4.0), method="bounded",
                              options=dict(xatol=1e-10))
        q = float(res.x)
    else:
        q = float(p)
    (w0, cs), ssr = linear(q)
    dof = d.size - (2 if p is not None else 3)
    u = (d / scale) ** q
    J = [np.ones_like(d), u] + ([cs * u * np.log(d / scale)] if p is None else [])
    J = np.column_stack(J)
    w0_err = p_err = None
    if dof > 0:
        cov = ssr / dof * np.linalg.pinv(J.T @ J)
        w0_err = float(np.sqrt(cov[0, 0]))
        if p is None:
            p_err = float(np.sqrt(cov[2, 2]))
    return dict(w0=float(w0), w0_err=w0_err, c=float(cs) / scale ** q, p=q, p_err=p_err,
                rms=float(np.sqrt(ssr / d.size)), dof=dof)


def continuum_fit(dx, width):
    """w0 and its error bar from the finest spacings: the fitted-p fit, fixed-p fits, a dropped spacing.

    The stated w0 is the fitted-p value.  Its error bar is the root sum of squares of (a) that
    fit's standard error (0 if it has no degrees of freedom), (b) the largest change of w0 from it
    to the fixed-p fits (p = 1/2, p = 1) whose rms residual is within 10 times the fitted-p one's
    (or the better fixed-p fit if none is): the uncertainty of the law, and (c) with four or more
    spacings, the change of the fitted-p w0 when the coarsest spacing is dropped: whether the
    spacings are yet in the asymptotic range.  Returns ``(w0, error, fits)`` with ``fits`` the
    fits by name (``"p fitted, coarsest dropped"`` only with four or more spacings).

    Examples
    --------
    >>> d = np.array([0.25, 0.125, 0.0625, 0.03125])
    >>> w0, err, fits = continuum_fit(d, 7.5 - 0.2 * np.sqrt(d))
    >>> round(w0, 8), bool(err < 1e-7), sorted(fits)
    (7.5, True, ['p = 1', 'p = 1/2', 'p fitted', 'p fitted, coarsest dropped'])
    """
    d, w = np.asarray(dx, float), np.asarray(width, float)
    fits = {"p fitted": fit_convergence(d, w), "p = 1/2": fit_convergence(d, w, 0.5),
            "p = 1": fit_convergence(d, w, 1.0)}
    free = fits["p fitted"]
    fixed = [fits["p = 1/2"], fits["p = 1"]]
    close = [f for f in fixed if f["rms"] <= 10.0 * free["rms"]] or [min(fixed, key=lambda f: f["rms"])]
    spread = max(abs(f["w0"] - free["w0"]) for f in close)
    drop = 0.0
    if d.size >= 4:
        keep = d < np.max(d)
        fits["p fitted, coarsest dropped"] = fit_convergence(d[keep], w[keep])
        drop = abs(fits["p fitted, coarsest dropped"]["w0"] - free["w0"])
    return free["w0"], float(np.sqrt((free["w0_err"] or 0.0) ** 2 + spread ** 2 + drop ** 2)), fits


def old_shooting(Gamma, dx):
    """The cached row of the former study (period-map shooting from the default start), or None."""
    path = os.path.join(CACHE, f"G{Gamma:g}_dx{dx:g}.json")
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        return json.load(fh)


def load_or_run(Gamma, dx, centre, only_cached):
    """The cached row (computed and cached unless ``only_cached``), or None if absent and ``only_cached``."""
    path = os.path.join(CACHE, f"G{Gamma:g}_dx{dx:g}_{centre}.json")
    if only_cached and not os.path.exists(path):
        return None
    return cached_kink(Gamma, dx, centre, need_profile=not only_cached)


def convergence_rows(rows):
    """Per spacing (coarse to fine) of one Gamma and centre: the widths, the increment of W per halving, its ratio."""
    out, prev, prev_inc = [], None, None
    for r in sorted(rows, key=lambda r: -r["dx"]):
        w_int, w_spl = profile_widths(r)
        inc = None if (prev is None or w_int is None or prev["dx"] != 2 * r["dx"]) else w_int - prev["w_int"]
        ratio = None if (inc is None or prev_inc is None or prev_inc == 0) else inc / prev_inc
        row = dict(Gamma=r["Gamma"], dx=r["dx"], centre=r.get("centre", "node"), n_nodes=r["n_nodes"],
                   converged=r["converged"], mu1=r["mu1"],
                   width=r["width"], w_int=w_int, w_spline=w_spl, increment=inc, ratio=ratio, seconds=r["seconds"])
        out.append(row)
        prev, prev_inc = (row if w_int is not None else None), inc
    return out


def f5(key):
    return lambda r: None if r.get(key) is None else f"{r[key]:.5f}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gamma", type=float, nargs="+", default=[3.9, 4.1, 4.4])
    ap.add_argument("--dx", type=float, nargs="+", default=[2.0, 1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125])
    ap.add_argument("--fit-dx-max", type=float, default=0.25, help="fit the spacings dx <= this")
    ap.add_argument("--only-cached", action="store_true",
                    help="report the cached cases only (missing ones are listed, not computed)")
    args = ap.parse_args(argv)
    rows, pairs, conv, fits, est, missing = [], [], [], [], [], []
    for G in args.gamma:
        family = dict(node=[], bond=[])
        for dx in args.dx:
            node = load_or_run(G, dx, "node", args.only_cached)
            bond = load_or_run(G, dx, "bond", args.only_cached)
            for c, r in (("node", node), ("bond", bond)):
                if r is None:
                    missing.append(f"Gamma {G:g} dx {dx:g} {c}")
                else:
                    rows.append(r)
                    family[c].append(r)
            if node is not None and bond is not None:
                pairs.append(both_pinned(node, bond))
        for c in ("node", "bond"):
            cr = convergence_rows(family[c])
            conv += [r for r in cr if r["w_int"] is not None]
            fine = [r for r in cr if r["dx"] <= args.fit_dx_max and r["w_int"] is not None]
            if len(fine) >= 3:
                w0, err, fs = continuum_fit([r["dx"] for r in fine], [r["w_int"] for r in fine])
                for name, f in fs.items():
                    fits.append(dict(Gamma=G, centre=c, law=name, **f))
                est.append(dict(Gamma=G, centre=c, w0=w0, error=err, finest=min(r["dx"] for r in fine),
                                w_finest=fine[-1]["w_int"], spacings=", ".join(f"{r['dx']:g}" for r in fine)))
            elif c == "node":
                est.append(dict(Gamma=G, centre=c, w0=None, error=None, finest=None, w_finest=None, spacings=None))

    def mu(key):
        return lambda r: None if r.get(key) is None else f"{r[key]:.7f}"

    cols = [(k, mu(k) if k == "mu1" else k)
            for k in ("Gamma", "dx", "centre", "n_nodes", "converged", "symmetric_nit", "nit", "residual",
                      "found_centre", "symmetry_error", "mu1", "pinning", "width", "seconds")]
    e = lambda k: (lambda r: None if r.get(k) is None else f"{r[k]:.2e}")
    text = [
        "Both pinned e = 0 kinks at each spacing, as fixed points of the mirrored half-period map "
        "(`tps.lattice_kink(..., symmetric=True)`: ten settling periods, Newton on G = S o P_{T/2}, then the "
        "period map for the multipliers) on planar Neumann lattices with an odd (mirror point on a node, "
        "length 40) or even (midway between two nodes, length 40 - dx) number of nodes, one BLAS thread "
        "(`python -m validation.kink_pinning`). `symmetric_nit`: Newton steps on G; `nit`: further steps on "
        "the period map; `found_centre` and `symmetry_error`: the mirror point measured on the orbit. `width`: "
        "`tps.front_width(orbit, instant='lower_far_field_top')` (linear interpolation, first crossing). "
        "`seconds`: wall time of the solve, one BLAS thread, on a 2-core machine shared with other jobs (two "
        "or three of these solves ran at once). Reproduce the tables from the cache with "
        "`OMP_NUM_THREADS=1 PYTHONPATH=. python -m validation.kink_pinning --only-cached`; without "
        "`--only-cached` every missing case (and every cached row without a profile at the refined instant) "
        "is computed and cached.", "",
        markdown_table(rows, cols), "",
        "Not computed (absent from the cache): " + (", ".join(missing) if missing else "none") + ".", "",
        f"Sum of the `seconds` above (the solves only; the measurements after each solve, symmetry centre and "
        f"widths, add about 30 % at 1281 nodes): {sum(r['seconds'] for r in rows):.0f} s, of which the "
        f"node-centred kinks at dx = 0.0625 and 0.03125: "
        f"{sum(r['seconds'] for r in rows if r['centre'] == 'node' and r['dx'] < 0.1):.0f} s.", "",
        "The pair at each spacing where both were computed: which is stable, the pinning strength (the smaller "
        "|1 - |mu1|| of the two), the mean and the gap (node - bond) of the widths:", "",
        markdown_table(pairs, [(k, mu(k) if k.startswith("mu_") else k)
                               for k in ("Gamma", "dx", "mu_node", "mu_bond", "stable", "pinning", "width_node",
                                         "width_bond", "mean", "gap", "seconds")]), "",
        "Below dx = 0.25 the pinning (|mu1| - 1 of a few 1e-6 or less) is at the accuracy of the "
        "finite-difference multipliers, so 'neither' or a stable/unstable label there means: not resolved.", "",
        "**The width under refinement** (both pinned kinks where their profile at the refined instant is "
        "cached). The width used for convergence is the integral "
        "width W = 2 ln 9 * integral of theta (1 - theta) dx (`integral_width`; theta = (zeta - zeta_L) / "
        "(zeta_R - zeta_L) normalised by the end nodes, trapezoid rule over the nodes; the factor makes W the "
        "10-90 % width of a tanh front), of the height profile at the instant of `front_width(..., "
        "instant='lower_far_field_top')`. It is a smooth function of the nodal heights, unlike the "
        "first-crossing width, which switches between pairs of nodes as dx changes. `w_spline`: the 10-90 % "
        "width of a cubic-spline interpolant of the same profile (cross-check). `increment`: change of W from "
        "the next coarser spacing; `ratio`: increment over the one before (1/sqrt 2 = 0.707 for "
        "convergence like sqrt(dx), 0.5 like dx).", "",
        markdown_table(conv, [("Gamma", "Gamma"), ("centre", "centre"), ("dx", "dx"), ("n_nodes", "n_nodes"),
                              ("mu1", mu("mu1")),
                              ("width (linear)", f5("width")), ("W (integral)", f5("w_int")),
                              ("w_spline", f5("w_spline")), ("increment", f5("increment")),
                              ("ratio", lambda r: None if r["ratio"] is None else f"{r['ratio']:.3f}"),
                              ("seconds", "seconds")]), "",
        f"**Fits of W(dx) = w0 + c dx^p** to the spacings dx <= {args.fit_dx_max:g} (least squares; "
        "`fit_convergence`): p fitted, and p fixed at 1/2 (the heat-kernel correction sqrt(dx/s) along a "
        "landing front of tilt s) and at 1. Standard errors from the residuals (none where the fit has no "
        "degrees of freedom).", "",
        markdown_table(fits, [("Gamma", "Gamma"), ("centre", "centre"), ("law", "law"), ("w0", f5("w0")),
                              ("w0 s.e.", e("w0_err")), ("p", lambda r: f"{r['p']:.3f}"),
                              ("p s.e.", e("p_err")), ("c", f5("c")), ("rms residual", e("rms")), ("dof", "dof")]),
        "",
        "Continuum width per Gamma (`continuum_fit`): w0 of the fitted-p fit; the error bar is the root sum of "
        "squares of (a) its standard error, (b) the largest change of w0 to a fixed-p fit (p = 1/2 or 1) whose "
        "rms residual is within 10 times the fitted-p one's (or the better fixed-p fit): the uncertainty of "
        "the law, and (c) with four spacings, the change of w0 when the coarsest is dropped: whether the "
        "spacings are in the asymptotic range yet.",
        "",
        markdown_table(est, [("Gamma", "Gamma"), ("centre", "centre"), ("spacings fitted", "spacings"),
                             ("w0", f5("w0")), ("error", f5("error")), ("W at finest dx", f5("w_finest"))]),
        "",
        "Reading of the cached run (2026-12-05; node-centred kinks at every spacing, bond-centred ones where "
        "listed). (1) The pinning barely touches W: node and bond W agree to 1.1e-4 at dx <= 0.25, so the bond "
        "fits are not an independent estimate, and the stated continuum width is the node family's over its "
        "four finest spacings. (2) W converges: from dx = 0.25 on, every increment is smaller than the one "
        "before at all three Gamma (the largest ratio 0.90, Gamma = 3.9 at dx = 0.0625); the ratios at "
        "the last halving are 0.72, 0.53, 0.46 at Gamma = 3.9, 4.1, 4.4. The former 'does not converge' "
        "came from the criterion (each increment at most half the one before), not from the data. (3) No "
        "single power law fits yet: the fitted exponent over dx <= 0.25 is 0.29 +- 0.07, 0.68 +- 0.08, "
        "0.94 +- 0.05 at Gamma = 3.9, 4.1, 4.4, growing with the landing front's tilt s (0.075, 0.16, 0.32), "
        "i.e. with s/dx (2.4, 5.1, 10 at dx = 0.03125): the spacings sit in the crossover from the "
        "sqrt(dx / s) regime towards a faster one, which is what the error bars (dropping the coarsest "
        "spacing, and the p = 1/2 fit where it is within 10x the residual) carry. (4) Continuum width W "
        "(10-90 % of a tanh-equivalent front, at the instant the lower far field is highest): 8.83 +- 0.06 "
        "(Gamma = 3.9), 7.283 +- 0.018 (4.1), 6.847 +- 0.029 (4.4), each 0.01-0.05 above W at dx = 0.03125. "
        "The first-crossing width (`front_width`) is larger by a near-constant 0.14-0.27 at dx <= 0.25 (a "
        "different definition) and moves with W.",
    ]
    publish("kink_pinning", "\n".join(text))


if __name__ == "__main__":
    main()
