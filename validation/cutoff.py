"""Well-posedness of the impacting lattice and an explicit cut-off length (docs/design.md, hazards 7-8).

What is measured
----------------
* :func:`perturbation_growth` -- growth factor per period of a small random
  zero-mean perturbation of a flat layer on a lattice, by renormalised
  twin runs (Benettin): each period the perturbed and the reference run are
  integrated, the distance ``d = max_i max(|dw_i|, |dzeta_i|)`` is recorded and
  the difference is scaled back to ``amplitude``.  The growth factor is the
  geometric mean of ``d / amplitude`` over the periods after ``discard``.
  Because the point-impact period map is piecewise linear (docs/design.md, hazard 7) the
  renormalisation keeps the measurement in the regime where it is
  amplitude-independent; :func:`amplitude_check` verifies that.
* :func:`plain_study` -- that growth factor against the lattice spacing for
  point impacts (54): both integrators, planar Neumann and axisymmetric
  (uniform and quasi-log) lattices, several (Gamma, e, M) inside
  ``FlatLayer.stability_window``; :func:`scaling_fit` fits growth ~ dx^-p.
* :func:`candidate_study` -- the instantaneous regularised rules of
  :mod:`validation.impact_rules` (normalised kernel, coherent patches) and
  the paper's unnormalised (67), at a fixed cut-off, under refinement.
* :func:`soft_study` -- the soft-contact model: per-mode monodromy
  (:class:`~tps_solver.model.soft_flat.SoftFlatOrbit`) on the lattice's
  eigenvalues under refinement at fixed cut-off (observed order), the continuum
  growth curve rho(k) for several cut-offs, and a direct-simulation cross-check
  (:func:`soft_simulation_check`).

Run ``python -m validation.cutoff`` (about 15 minutes on 2 cores) to print all
tables (markdown) and write ``validation/figures/cutoff_growth.png`` and
``validation/figures/cutoff_soft.png``.  :func:`fast_plain` and
:func:`fast_soft` are the subsets asserted by ``tests/test_cutoff.py``.
"""
import math
import os
import time

import numpy as np

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from tps_solver.model.flat import FlatLayer
from tps_solver.solvers.fda import Lattice, flat_state, simulate
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.operators.lattice import lattice_eigenvalues
from validation.impact_rules import regularised_impact

FIG_DIR = os.path.join(_ROOT, "validation", "figures")

def simulate_radau(*args, **kw):
    """The soft contact by the Radau reference integrator (``simulate(..., method="soft-radau")``)."""
    return simulate(*args, method="soft-radau", **kw)


#: The reference case of docs/design.md, hazard 8.
REFERENCE = dict(Gamma=2.5, e=0.45, M=2)
#: (Gamma, e, M) inside the flat stability window (checked in :func:`parameter_sets`).
PARAMETERS = ((2.5, 0.45, 2), (2.6, 0.45, 2), (1.75, 0.6, 2), (1.4, 0.45, 1), (1.9, 0.3, 1))
#: Node counts of the plain study (length / r_max 8): dx = 1.6, 0.8, 0.53, 0.27, 0.13.
PLANAR_NODES = (6, 11, 16, 31, 61)
QUASILOG_NODES = (6, 11, 21, 41, 81)


def parameter_sets(params=PARAMETERS):
    """The (Gamma, e, M) sets with their stability windows; raise if one lies outside.

    Returns
    -------
    rows : list of dict
        Keys ``Gamma, e, M, window_low, window_high, multiplier``.
    """
    rows = []
    for Gamma, e, M in params:
        lo, hi = FlatLayer.stability_window(e, M)
        if not lo < Gamma < hi:
            raise ValueError(f"Gamma = {Gamma} is outside the stability window ({lo:.4g}, {hi:.4g}) "
                             f"for e = {e}, M = {M}")
        mu = FlatLayer(Gamma, M, e=e).floquet_multipliers()
        rows.append(dict(Gamma=Gamma, e=e, M=M, window_low=lo, window_high=hi,
                         multiplier=float(np.max(np.abs(mu)))))
    return rows


def make_lattice(geometry, n_nodes, extent=8.0):
    """``"planar"`` (Neumann, length ``extent``), ``"uniform"`` or ``"quasilog"`` (axisymmetric, r_max ``extent``)."""
    if geometry == "planar":
        return Lattice.planar(n_nodes=n_nodes, length=extent, boundary="neumann")
    return Lattice.axisymmetric(n_nodes=n_nodes, r_max=extent, grid=geometry)


def _random_direction(n, rng):
    dw, dz = rng.standard_normal(n), rng.standard_normal(n)
    dw -= dw.mean()
    dz -= dz.mean()
    s = max(np.max(np.abs(dw)), np.max(np.abs(dz)))
    return dw / s, dz / s


def perturbation_growth(lattice, Gamma, e, M, *, propagate=None, w0=None, zeta0=None, t_section=None,
                        periods=12, discard=4, amplitude=1e-7, seed=0, **simulate_kw):
    """Renormalised growth factor per period of a random zero-mean perturbation (module docstring).

    Parameters
    ----------
    lattice : Lattice
    Gamma, e, M : float, float, int
    propagate : callable, optional
        ``propagate(w, zeta, t_start, t_end) -> SimulationResult``; default
        :func:`~tps_solver.solvers.fda.simulate` on ``lattice`` with ``**simulate_kw``.
    w0, zeta0 : ndarray of float, shape (n_nodes,), optional
        Reference state at ``t_section``; default the hard flat layer at mid-flight.
    t_section : float, optional
    periods, discard : int
    amplitude : float
    seed : int

    Returns
    -------
    dict
        ``growth`` (geometric mean after ``discard``), ``factors`` (per period),
        ``impacts_per_node`` (mean impact records per node per period of the
        perturbed run, after ``discard``), ``contact_sets`` (distinct contact
        times per period), ``sticks`` (stick events per period), ``spread``
        (spread of the impact times in a period divided by ``amplitude``),
        ``flat_defect`` (max deviation of the reference run from its start after
        each period), ``success``.
    """
    fl = FlatLayer(Gamma, M, e=e)
    T = fl.period
    if t_section is None:
        t_section = fl.t0 + 0.5 * T
    if w0 is None:
        w0, zeta0 = flat_state(lattice, fl, t_section)
    if propagate is None:
        def propagate(w, z, ta, tb):
            return simulate(lattice, Gamma, e, w, z, t_start=ta, t_end=tb, **simulate_kw)
    rng = np.random.default_rng(seed)
    dw, dz = _random_direction(lattice.n_nodes, rng)
    wr, zr = np.array(w0, float), np.array(zeta0, float)
    w, z = wr + amplitude * dw, np.maximum(zr + amplitude * dz, 0.0)
    t = t_section
    factors, imp, sets, sticks, spread, defect = [], [], [], [], [], []
    success = True
    for _ in range(periods):
        a = propagate(w, z, t, t + T)
        b = propagate(wr, zr, t, t + T)
        if not (a.success and b.success):
            success = False
            break
        d = max(np.max(np.abs(a.w - b.w)), np.max(np.abs(a.zeta - b.zeta)))
        defect.append(max(np.max(np.abs(b.w - wr)), np.max(np.abs(b.zeta - zr))))
        ev = a.events
        hits = ev[ev.kind != "liftoff"] if ev.size else ev
        imp.append(hits.size / lattice.n_nodes)
        sets.append(np.unique(hits.t).size if hits.size else 0)
        sticks.append(int(np.count_nonzero(ev.kind == "stick")) if ev.size else 0)
        spread.append(float(np.ptp(hits.t)) / amplitude if hits.size else 0.0)
        factors.append(d / amplitude)
        if not d > 0.0:
            break
        wr, zr = b.w, b.zeta
        w = wr + (a.w - b.w) * (amplitude / d)
        z = np.maximum(zr + (a.zeta - b.zeta) * (amplitude / d), 0.0)
        t += T
    factors = np.array(factors)
    tail = factors[discard:]
    growth = float(np.exp(np.mean(np.log(tail)))) if tail.size and np.all(tail > 0) else float("nan")
    return dict(growth=growth, factors=factors, impacts_per_node=float(np.mean(imp[discard:])) if imp else np.nan,
                contact_sets=float(np.mean(sets[discard:])) if sets else np.nan,
                sticks=float(np.mean(sticks[discard:])) if sticks else np.nan,
                spread=float(np.median(spread[discard:])) if spread else np.nan,
                flat_defect=float(np.max(defect)) if defect else np.nan, success=success)


def scaling_fit(dx, growth):
    """Least-squares fit ``log growth = log C - p log dx``; returns ``(p, C)``.

    Examples
    --------
    >>> p, C = scaling_fit([1.0, 0.5, 0.25], [2.0, 4.0, 8.0])
    >>> round(p, 12), round(C, 12)
    (1.0, 2.0)
    """
    slope, icpt = np.polyfit(np.log(dx), np.log(growth), 1)
    return float(-slope), float(np.exp(icpt))


def plain_growth(geometry="planar", nodes=PLANAR_NODES, Gamma=2.5, e=0.45, M=2, method="exact",
                 extent=8.0, **kw):
    """Growth factor of point-impact lattices against the smallest spacing.

    Returns
    -------
    list of dict
        Per lattice: ``geometry, method, Gamma, e, M, n_nodes, dx`` and the keys of
        :func:`perturbation_growth`.
    """
    rows = []
    for n in nodes:
        lat = make_lattice(geometry, n, extent)
        start = time.perf_counter()
        res = perturbation_growth(lat, Gamma, e, M, method=method, **kw)
        res.update(geometry=geometry, method=method, Gamma=Gamma, e=e, M=M, n_nodes=n, dx=lat.spacing,
                   seconds=time.perf_counter() - start)
        rows.append(res)
    return rows


def fast_plain():
    """Fast subset: the hazard-8 reference case, planar Neumann length 8, dx = 1.6, 0.53, 0.27, exact."""
    return plain_growth("planar", (6, 16, 31), periods=10, discard=3, **REFERENCE)


def amplitude_check(n_nodes=31, amplitudes=(1e-9, 1e-7, 1e-5), **kw):
    """Growth factor at one spacing for several perturbation amplitudes (piecewise-linear map: equal)."""
    lat = make_lattice("planar", n_nodes)
    return [dict(amplitude=a, **perturbation_growth(lat, amplitude=a, **REFERENCE, **kw)) for a in amplitudes]


def plain_study(params=PARAMETERS, periods=12, discard=4):
    """The full point-impact table (see the module docstring)."""
    rows = []
    for Gamma, e, M in params:
        rows += plain_growth("planar", PLANAR_NODES, Gamma, e, M, "exact", periods=periods, discard=discard)
    ref = REFERENCE
    # the ODE integrator with the exact integrator's simultaneity window (1e-12), and with its own default 1e-9
    rows += plain_growth("planar", PLANAR_NODES[:-1], method="ode", time_tol=1e-12, periods=periods,
                         discard=discard, **ref)
    for r in plain_growth("planar", PLANAR_NODES[:-1], method="ode", periods=periods, discard=discard, **ref):
        r["method"] = "ode, window 1e-9"
        rows.append(r)
    rows += plain_growth("uniform", PLANAR_NODES, periods=periods, discard=discard, **ref)
    rows += plain_growth("quasilog", QUASILOG_NODES, periods=periods, discard=discard, **ref)
    rows += plain_growth("uniform", PLANAR_NODES, Gamma=1.4, e=0.45, M=1, periods=periods, discard=discard)
    return rows


def fits(rows):
    """Scaling fits ``growth ~ dx^-p`` per (geometry, method, Gamma, e, M) group."""
    out = []
    keys = sorted({(r["geometry"], r["method"], r["Gamma"], r["e"], r["M"]) for r in rows},
                  key=lambda k: (k[0], k[1], -k[4], k[2]))
    for key in keys:
        grp = [r for r in rows if (r["geometry"], r["method"], r["Gamma"], r["e"], r["M"]) == key]
        dx = np.array([r["dx"] for r in grp])
        g = np.array([r["growth"] for r in grp])
        p, C = scaling_fit(dx, g)
        out.append(dict(geometry=key[0], method=key[1], Gamma=key[2], e=key[3], M=key[4], p=p, C=C,
                        growth_coarsest=g[np.argmax(dx)], growth_finest=g[np.argmin(dx)],
                        dx_finest=float(dx.min())))
    return out


# ------------------------------------------------------------ regularised candidates
def candidate_study(cutoff=0.5, nodes=(11, 21, 41, 81), periods=10, discard=3, **params):
    """Instantaneous rules at a fixed cut-off under refinement (planar Neumann, length 8).

    Candidates: ``"kernel"`` and ``"patch"`` (:func:`regularised_impact`) and the
    paper's literal (67) (``impact="diffused"``, ``rho_c = cutoff``).

    Returns
    -------
    list of dict
    """
    params = dict(REFERENCE, **params)
    rows = []
    for name in ("kernel", "patch", "stosslet67"):
        for n in nodes:
            lat = make_lattice("planar", n)
            kw = (dict(impact="diffused", rho_c=cutoff) if name == "stosslet67"
                  else dict(impact=regularised_impact(name, cutoff)))
            res = perturbation_growth(lat, periods=periods, discard=discard, **params, **kw)
            res.update(candidate=name, cutoff=cutoff, n_nodes=n, dx=lat.spacing)
            rows.append(res)
    return rows


# -------------------------------------------------------------------- soft contact
def observed_orders(dx, values, limit=None):
    """Observed orders ``log(|e_k| / |e_{k+1}|) / log(dx_k / dx_{k+1})`` of successive errors.

    With ``limit`` the errors are ``values - limit``; otherwise successive
    differences are used (Richardson: order of the differences).

    Examples
    --------
    >>> [round(p, 6) for p in observed_orders([0.4, 0.2, 0.1, 0.05], [1.16, 1.04, 1.01, 1.0025])]
    [2.0, 2.0]
    """
    dx, v = np.asarray(dx, float), np.asarray(values, float)
    if limit is not None:
        err, h = np.abs(v - limit), dx
    else:
        err, h = np.abs(np.diff(v)), dx[:-1]
    return [float(math.log(err[k] / err[k + 1]) / math.log(h[k] / h[k + 1])) for k in range(err.size - 1)]


def soft_lattice_growth(cutoff, geometry="planar", nodes=(21, 41, 81, 161, 321, 641), extent=8.0, **params):
    r"""Growth factor of the soft-contact lattice from its per-mode monodromy, under refinement.

    The linearised period map at the (uniform) soft flat orbit decouples over the
    eigenvectors of :math:`-\underline L`; the growth factor of zero-mean
    perturbations is the largest spectral radius over the non-uniform modes.

    Returns
    -------
    list of dict
        ``n_nodes, dx, growth, lam_argmax, uniform`` per lattice, and
        ``growth_above_cutoff``: the largest rho over the modes with
        :math:`\lambda \le 1/\ell^2` (scales longer than the cut-off).
    """
    p = dict(REFERENCE, **params)
    orb = SoftFlatOrbit(p["Gamma"], p["M"], p["e"], cutoff)
    rows = []
    for n in nodes:
        lat = make_lattice(geometry, n, extent)
        lam = lattice_eigenvalues(lat)
        rho = orb.growth(lam[1:])
        k = int(np.argmax(rho))
        above = lam[1:] <= 1.0 / cutoff ** 2
        rows.append(dict(geometry=geometry, cutoff=cutoff, n_nodes=n, dx=lat.spacing, growth=float(rho[k]),
                         lam_argmax=float(lam[1 + k]), uniform=float(orb.growth(0.0)[0]),
                         growth_above_cutoff=float(rho[above].max()) if np.any(above) else float("nan")))
    return rows


def soft_continuum(cutoffs=(0.03, 0.1, 0.3, 1.0), lam=None, **params):
    """Continuum growth curves rho(lambda = k^2) of the soft model per cut-off.

    Returns
    -------
    lam : ndarray of float, shape (k,)
    curves : dict
        cut-off -> rho, shape (k,); cut-offs without a continued soft orbit are skipped.
    """
    p = dict(REFERENCE, **params)
    lam = np.logspace(-3, 8, 1200) if lam is None else np.asarray(lam, float)
    curves = {}
    for c in cutoffs:
        try:
            orb = SoftFlatOrbit(p["Gamma"], p["M"], p["e"], c)
        except ValueError:
            continue
        curves[c] = orb.growth(lam)
    return lam, curves


def soft_parameter_table(cutoffs=(0.01, 0.03, 0.1, 0.3, 1.0), params=PARAMETERS):
    """Per (Gamma, e, M, cutoff): the soft flat layer's growth factors in the continuum.

    Columns: ``uniform`` (the k = 0 mode), ``peak_above_cutoff`` and ``k_peak``
    (largest rho over 0 < k <= 1/cutoff, scales longer than the cut-off),
    ``sup`` (over all k, on a grid up to k = 1e5/cutoff) and
    ``deficit_100 = 1 - rho(k = 100/cutoff)`` (the approach to the neutral
    asymptote rho -> 1 at sub-cut-off scales).
    """
    k = np.logspace(-3, 5, 2400)
    rows = []
    for Gamma, e, M in params:
        for c in cutoffs:
            kk = k / c
            try:
                orb = SoftFlatOrbit(Gamma, M, e, c)
            except ValueError as exc:
                rows.append(dict(Gamma=Gamma, e=e, M=M, cutoff=c, note=str(exc)))
                continue
            rho = orb.growth(kk ** 2)
            above = kk * c <= 1.0
            i = int(np.argmax(rho[above]))
            rows.append(dict(Gamma=Gamma, e=e, M=M, cutoff=c, uniform=float(orb.growth(0.0)[0]),
                             peak_above_cutoff=float(rho[above][i]), k_peak=float(kk[above][i]),
                             sup=float(rho.max()), deficit_100=float(1.0 - orb.growth((100.0 / c) ** 2)[0]),
                             note=""))
    return rows


def soft_simulation_check(cutoff=0.3, n_nodes=9, mode=1, amplitude=1e-5, rtol=1e-9, **params):
    """One period of the nonlinear soft lattice against the per-mode monodromy.

    A single cosine eigenmode of the planar Neumann lattice (length 8) is put on
    the soft flat orbit at mid-flight in ``w`` and in ``zeta``; after one period
    the projection of the difference onto the mode is compared with
    ``monodromy(lambda_mode) @ (dw, dzeta)``.

    Returns
    -------
    dict
        ``predicted`` and ``measured`` (2,), ``rel_error``, ``uniform_defect``
        (drift of the unperturbed run from the soft flat orbit after one period).
    """
    p = dict(REFERENCE, **params)
    orb = SoftFlatOrbit(p["Gamma"], p["M"], p["e"], cutoff)
    lat = make_lattice("planar", n_nodes)
    v = np.sqrt(lat.volumes)
    S = -lat.flux / v[:, None] / v[None, :]
    lam, vec = np.linalg.eigh(0.5 * (S + S.T))
    phi = vec[:, mode] / v
    phi /= np.max(np.abs(phi))
    t_s = orb.t_exit + 0.5 * orb.flight
    w0, z0 = orb.state(t_s)
    T = orb.period
    d0 = np.array([amplitude, amplitude])
    base = simulate_radau(lat, p["Gamma"], p["e"], np.full(n_nodes, w0), np.full(n_nodes, z0), t_start=t_s,
                         t_end=t_s + T, cutoff=cutoff, rtol=rtol, atol=1e-13)
    pert = simulate_radau(lat, p["Gamma"], p["e"], w0 + d0[0] * phi, z0 + d0[1] * phi, t_start=t_s,
                         t_end=t_s + T, cutoff=cutoff, rtol=rtol, atol=1e-13)
    proj = lambda u: float(np.sum(lat.volumes * u * phi) / np.sum(lat.volumes * phi * phi))  # noqa: E731
    measured = np.array([proj(pert.w - base.w), proj(pert.zeta - base.zeta)])
    predicted = orb.monodromy(lam[mode], t_section=t_s)[0] @ d0
    w1, z1 = orb.state(t_s + T)
    return dict(predicted=predicted, measured=measured, lam=float(lam[mode]),
                rel_error=float(np.max(np.abs(measured - predicted)) / np.max(np.abs(predicted))),
                uniform_defect=float(max(np.max(np.abs(base.w - w1)), np.max(np.abs(base.zeta - z1)))))


def fast_soft(cutoff=0.3):
    """Fast subset: soft lattice growth under refinement at a fixed cut-off, with observed orders."""
    rows = soft_lattice_growth(cutoff, nodes=(81, 161, 321, 641))
    dx = [r["dx"] for r in rows]
    g = [r["growth"] for r in rows]
    return dict(rows=rows, orders=observed_orders(dx, g), orders_to_one=observed_orders(dx, g, limit=1.0))


# ---------------------------------------------------------------------- output
def _table(rows, cols):
    from validation.report import markdown_table
    return markdown_table(rows, cols)


def plot(plain_rows, candidate_rows, soft_rows, continuum, path=None):
    """Two figures: growth against dx (point impacts and candidates), and the soft model."""
    import matplotlib
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    os.makedirs(FIG_DIR, exist_ok=True)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    groups = sorted({(r["geometry"], r["method"], r["Gamma"], r["e"], r["M"]) for r in plain_rows})
    for key in groups:
        grp = [r for r in plain_rows if (r["geometry"], r["method"], r["Gamma"], r["e"], r["M"]) == key]
        ax[0].loglog([r["dx"] for r in grp], [r["growth"] for r in grp], "o-" if key[1] == "exact" else "x--",
                     label=f"{key[0]} {key[1]} G={key[2]} e={key[3]} M={key[4]}", ms=4)
    ax[0].axhline(1.0, color="k", lw=0.8)
    ax[0].invert_xaxis()
    ax[0].set_xlabel("smallest lattice spacing dx (viscous lengths)")
    ax[0].set_ylabel("growth factor per period")
    ax[0].set_title("point impacts (54): growth of 1e-7 perturbations")
    ax[0].legend(fontsize=6)
    grp = [r for r in candidate_rows if r["candidate"] == "patch" and np.isfinite(r["growth"])]
    ax[1].loglog([r["dx"] for r in grp], [r["growth"] for r in grp], "s-", label="coherent patch, cut-off 0.5")
    kern = [r["factors"][0] for r in candidate_rows if r["candidate"] == "kernel" and len(r["factors"])]
    if kern:
        ax[1].text(0.03, 0.95, f"normalised kernel: a 1e-7 perturbation changes the state by O(1)\n"
                   f"in the first period (factor {min(kern):.1e} to {max(kern):.1e}): discontinuous",
                   transform=ax[1].transAxes, fontsize=7, va="top")
    for c in sorted({r["cutoff"] for r in soft_rows}):
        grp = [r for r in soft_rows if r["cutoff"] == c]
        ax[1].loglog([r["dx"] for r in grp], [r["growth"] for r in grp], "^-", label=f"soft contact, cut-off {c}")
    ax[1].axhline(1.0, color="k", lw=0.8)
    ax[1].set_ylim(0.3, 30.0)
    ax[1].invert_xaxis()
    for a in ax:
        a.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        a.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax[1].set_xlabel("lattice spacing dx")
    ax[1].set_title("regularised models at fixed cut-off")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    p1 = path or os.path.join(FIG_DIR, "cutoff_growth.png")
    fig.savefig(p1, dpi=120)
    plt.close(fig)
    lam, curves = continuum
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for c, rho in curves.items():
        ax.semilogx(np.sqrt(lam), rho, label=f"cut-off {c}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("wavenumber k (1 / viscous length)")
    ax.set_ylabel("growth factor per period")
    ax.set_title("soft contact, flat layer G=2.5 e=0.45 M=2")
    ax.legend(fontsize=8)
    fig.tight_layout()
    p2 = os.path.join(FIG_DIR, "cutoff_soft.png")
    fig.savefig(p2, dpi=120)
    plt.close(fig)
    return p1, p2


def main():
    start = time.perf_counter()
    print("## parameter sets\n")
    print(_table(parameter_sets(), [("Gamma", "Gamma"), ("e", "e"), ("M", "M"), ("window low", "window_low"),
                                    ("window high", "window_high"), ("flat |mu|", "multiplier")]))
    plain = plain_study()
    cols = [("geometry", "geometry"), ("method", "method"), ("Gamma", "Gamma"), ("e", "e"), ("M", "M"),
            ("n", "n_nodes"), ("dx", "dx"), ("growth", "growth"), ("impacts/node", "impacts_per_node"),
            ("contact sets", "contact_sets"), ("sticks", "sticks"), ("t spread/amp", "spread"),
            ("flat defect", "flat_defect")]
    print("\n## point impacts: growth against dx\n")
    print(_table(plain, cols))
    print("\n## fits growth ~ C dx^-p\n")
    print(_table(fits(plain), [("geometry", "geometry"), ("method", "method"), ("Gamma", "Gamma"), ("e", "e"),
                               ("M", "M"), ("p", "p"), ("C", "C"), ("growth at coarsest", "growth_coarsest"),
                               ("growth at finest", "growth_finest"), ("finest dx", "dx_finest")]))
    print("\n## amplitude independence (planar, n = 31, reference case)\n")
    print(_table(amplitude_check(), [("amplitude", "amplitude"), ("growth", "growth")]))
    cand = candidate_study()
    print("\n## instantaneous candidates at cut-off 0.5 (planar Neumann, length 8)\n")
    print(_table(cand, [("candidate", "candidate"), ("n", "n_nodes"), ("dx", "dx"), ("growth", "growth"),
                        ("first-period factor", lambda r: r["factors"][0] if len(r["factors"]) else None),
                        ("impacts/node", "impacts_per_node"), ("contact sets", "contact_sets"),
                        ("flat defect", "flat_defect"), ("success", "success")]))
    soft = []
    for c in (0.1, 0.3, 1.0):
        soft += soft_lattice_growth(c)
    soft += soft_lattice_growth(0.3, geometry="uniform")
    soft += soft_lattice_growth(0.3, geometry="quasilog", nodes=(41, 81, 161, 321, 641))
    print("\n## soft contact: lattice growth (per-mode monodromy) under refinement\n")
    for key in sorted({(r["geometry"], r["cutoff"]) for r in soft}):
        grp = [r for r in soft if (r["geometry"], r["cutoff"]) == key]
        print(f"\n{key[0]}, cut-off {key[1]}: observed orders of the differences "
              f"{np.round(observed_orders([r['dx'] for r in grp], [r['growth'] for r in grp]), 2).tolist()}\n")
        print(_table(grp, [("n", "n_nodes"), ("dx", "dx"), ("growth", "growth"), ("1 - growth",
                     lambda r: 1.0 - r["growth"]), ("lambda at max", "lam_argmax"),
                     ("max over k <= 1/cutoff", "growth_above_cutoff"), ("uniform mode", "uniform")]))
    print("\n## soft contact: continuum, per parameter set\n")
    print(_table(soft_parameter_table(), [("Gamma", "Gamma"), ("e", "e"), ("M", "M"), ("cut-off", "cutoff"),
                                          ("uniform mode", "uniform"), ("max rho, k <= 1/cutoff",
                                                                        "peak_above_cutoff"),
                                          ("at k", "k_peak"), ("sup rho", "sup"),
                                          ("1 - rho at k = 100/cutoff", "deficit_100"), ("note", "note")]))
    lam, curves = soft_continuum((0.01, 0.1, 0.3))
    kl = np.array([0.3, 1.0, 2.0, 3.0, 10.0, 30.0, 100.0])
    uni = [dict(cutoff=c, **{f"k*cutoff={x:g}": float(SoftFlatOrbit(2.5, 2, 0.45, c).growth((x / c) ** 2)[0])
                             for x in kl}) for c in (0.01, 0.1, 0.3)]
    print("\nrho against k * cutoff (reference case): a universal curve at sub-cut-off scales\n")
    print(_table(uni, [("cut-off", "cutoff")] + [(f"k cutoff = {x:g}", f"k*cutoff={x:g}") for x in kl]))
    print("\n## soft contact: one period of the nonlinear lattice vs monodromy\n")
    chk = [dict(n=n, mode=m, **soft_simulation_check(n_nodes=n, mode=m)) for n, m in ((9, 1), (9, 4), (17, 8))]
    print(_table(chk, [("n", "n"), ("mode", "mode"), ("lambda", "lam"), ("predicted dw", lambda r: r["predicted"][0]),
                       ("measured dw", lambda r: r["measured"][0]), ("predicted dzeta", lambda r: r["predicted"][1]),
                       ("measured dzeta", lambda r: r["measured"][1]), ("rel. error", "rel_error"),
                       ("uniform defect", "uniform_defect")]))
    print("\n## soft contact: renormalised twin-run growth on the nonlinear lattice (cut-off 0.3)\n")
    sim = []
    for n in (9,):
        lat = make_lattice("planar", n)
        orb = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
        t_s = orb.t_exit + 0.5 * orb.flight
        w0, z0 = orb.state(t_s)

        def prop(w, z, ta, tb, lat=lat):
            return simulate_radau(lat, 2.5, 0.45, w, z, t_start=ta, t_end=tb, cutoff=0.3, rtol=1e-9, atol=1e-13)
        res = perturbation_growth(lat, 2.5, 0.45, 2, propagate=prop, w0=np.full(n, w0), zeta0=np.full(n, z0),
                                  t_section=t_s, periods=30, discard=10, amplitude=1e-5)
        pred = soft_lattice_growth(0.3, nodes=(n,))[0]["growth"]
        sim.append(dict(n=n, dx=lat.spacing, simulated=res["growth"], predicted=pred,
                        impacts_per_node=res["impacts_per_node"]))
    print(_table(sim, [("n", "n"), ("dx", "dx"), ("simulated growth", "simulated"),
                       ("monodromy growth", "predicted"), ("impacts/node", "impacts_per_node")]))
    print("\nfigures:", plot(plain, cand, [r for r in soft if r["geometry"] == "planar"], soft_continuum()))
    print(f"\ntotal {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
