r"""Figures (matplotlib is imported only when a function is called; the backend is the caller's choice).

* :func:`solution_figures` / :func:`plot_solution` -- space-time maps of :math:`\zeta(t, r)` and
  :math:`w - W` (paper Figs. 3-4) and snapshots: polar top views of the oscillon (Fig. 5) or
  profiles of the kink;
* :func:`growth_rates_figure` / :func:`plot_growth_rates` -- the damping rates of (35);
* :func:`orbit_period_figure` / :func:`plot_orbit_period` -- height and velocity of a lattice
  periodic orbit (e.g. a :class:`~tps_solver.solvers.shooting.periodic.ShootingOrbit`) over one period;
* :func:`contact_pattern_figure` / :func:`plot_contact_pattern` -- its contact pattern
  (node position vs time: flying, touch-and-go instants, stuck intervals).

Every figure has labelled axes with units (heights in plate amplitudes A, velocities in
:math:`A\omega`, horizontal lengths in viscous lengths), a colour bar wherever colour carries a
value, and a title that states the parameters.  Time has one convention in every figure of a
periodic orbit: :math:`t/T`, in periods :math:`T = 2\pi M/\omega` of the orbit (M forcing cycles).

The figures of a periodic orbit accept every periodic result of the package --
``PeriodicSolution``, ``LatticeCycle``, ``ShootingOrbit``, ``StickSolution`` -- and refuse
anything else, or a result without fields to draw, with a ``ValueError`` that says why.
A TPS result whose continuation ended before full coupling is drawn on the grid that was
asked for (``nodes_requested``), and its title says so.
"""
import math
import os

import numpy as np

__all__ = ["solution_figures", "plot_solution", "growth_rates_figure", "plot_growth_rates",
           "orbit_period_figure", "plot_orbit_period", "contact_pattern_figure", "plot_contact_pattern"]


#: The one time axis of the figures of a periodic orbit.
TIME_LABEL = r"time $t/T$ (periods, dimensionless; $T = 2\pi M/\omega$)"


def _geometry(orbit):
    """``"planar"`` or ``"axisymmetric"`` of any periodic result (its own, or its lattice's)."""
    geometry = orbit.get("geometry") if hasattr(orbit, "get") else getattr(orbit, "geometry", None)
    if geometry is None and getattr(orbit, "lattice", None) is not None:
        geometry = orbit.lattice.geometry
    if geometry not in ("planar", "axisymmetric"):
        raise ValueError(f"orbit must be a periodic result of the package (PeriodicSolution, LatticeCycle, "
                         f"ShootingOrbit, StickSolution) with a geometry or a lattice, got {type(orbit).__name__}")
    return geometry


def _drawable(orbit, what):
    """Refuse, with the reason, what is not a periodic orbit with fields; return (geometry, t_start)."""
    missing = [name for name in ("nodes", "period", "height", "velocity", "Gamma", "M")
               if not hasattr(orbit, name)]
    if missing:
        raise ValueError(f"{what} takes a periodic result of the package (PeriodicSolution, LatticeCycle, "
                         f"ShootingOrbit, StickSolution); {type(orbit).__name__} has no {', '.join(missing)}")
    geometry = _geometry(orbit)
    t_start = float(orbit.get("t_start", 0.0) if hasattr(orbit, "get") else getattr(orbit, "t_start", 0.0))
    try:
        orbit.height(np.array([t_start]))
    except (AttributeError, KeyError, TypeError, IndexError, ValueError) as exc:
        raise ValueError(f"{what}: this {type(orbit).__name__} holds no fields to draw (status "
                         f"{orbit.get('status', '?')}: {str(orbit.get('message', ''))[:200]}); "
                         f"missing {exc}") from None
    return geometry, t_start


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def _display_nodes(sol):
    """Nodes to draw on: the requested grid when the continuation stopped early (stretched nodes)."""
    req = sol.get("nodes_requested")
    if req is not None and sol.get("coupling", 1.0) < 1.0 and np.shape(req) == np.shape(sol.nodes):
        return np.asarray(req, dtype=float), True
    return np.asarray(sol.nodes, dtype=float), False


def _method(orbit):
    """A short name of the formulation of a periodic result."""
    if orbit.get("method") is not None:
        return f"lattice orbit ({orbit.method})"
    if orbit.get("formulation"):
        return str(orbit.formulation).split(" (")[0]
    return type(orbit).__name__


def _header(sol, kind, stretched):
    spacing = float(np.min(np.diff(sol.nodes))) if sol.nodes.size > 1 else float("nan")
    head = (f"TPS {kind}: $\\Gamma$ = {sol.Gamma:g}, e = {sol.e:.4g}, M = {sol.M}, "
            + (f"N = {sol.N}, " if sol.get("N") is not None else "") + f"{sol.nodes.size} nodes")
    if sol.get("N") is None:
        head = f"{_method(sol)}, {kind}: " + head.split(": ", 1)[1]
    if sol.converged:
        state = f"converged, max|F| = {sol.residual:.1e}, spacing {spacing:.3g}"
    else:
        state = f"NOT converged (status {sol.status})"
        if stretched:
            state += (f"; fields at coupling $\\nu_c$ = {sol.coupling:.3g} (spacing {spacing:.3g}), "
                      "drawn on the requested grid")
    return head + "\n" + state


def solution_figures(sol, n_times=160):
    """Build the standard figures of a :class:`~tps_solver.solvers.tps.PeriodicSolution`.

    Parameters
    ----------
    sol : PeriodicSolution
    n_times : int
        Time samples over one period.

    Returns
    -------
    figures : dict of str -> matplotlib.figure.Figure
        ``"zeta"``, ``"w_minus_W"`` and ``"snapshots"``; the caller saves and closes them.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from tps_solver import solve_kink
    >>> sol = solve_kink(n_harmonics=6, n_nodes=6)
    >>> figs = solution_figures(sol, n_times=16)
    >>> sorted(figs), figs["zeta"].axes[0].get_xlabel()
    (['snapshots', 'w_minus_W', 'zeta'], '$x$ (viscous lengths)')
    >>> print(figs["zeta"].axes[0].get_title().splitlines()[0])
    TPS kink: $\\Gamma$ = 2.5, e = 0.45, M = 2, N = 6, 12 nodes
    >>> len(figs["snapshots"].axes[0].lines)                  # 8 profiles per period
    8
    >>> for fig in figs.values():
    ...     plt.close(fig)
    """
    geometry, t_start = _drawable(sol, "solution_figures")
    plt = _pyplot()
    kind = "kink" if geometry == "planar" else "oscillon"
    space = "x" if kind == "kink" else "r"
    x, stretched = _display_nodes(sol)
    T = sol.period
    flat = sol.get("flat")
    if flat is None:
        from tps_solver.model.flat import FlatLayer

        flat = FlatLayer(sol.Gamma, sol.M, e=sol.e)
    t = np.linspace(0.0, T, n_times, endpoint=False)
    zeta = sol.height(t)
    w_rel = sol.velocity(t) - flat.velocity(t)[:, None]
    header = _header(sol, kind, stretched)
    xlabel = f"${space}$ (viscous lengths{', requested grid' if stretched else ''})"
    figures = {}
    for name, data, label, cmap, symmetric in (
            ("zeta", zeta, r"height $\zeta$ (plate amplitudes $A$)", "viridis", False),
            ("w_minus_W", w_rel, r"$w - W$ (units of $A\omega$)", "RdBu_r", True)):
        fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
        vmax = float(np.max(np.abs(data))) if symmetric else None
        im = ax.pcolormesh(x, t / T, data, shading="gouraud", cmap=cmap,
                           vmin=-vmax if symmetric else None, vmax=vmax)
        fig.colorbar(im, ax=ax, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(TIME_LABEL)
        ax.set_title(header + f"\n{label.split(' (')[0]} over one period", fontsize=9)
        figures[name] = fig
    # snapshots, 8 per period
    ts = np.linspace(0.0, T, 9)[:-1]
    rel = sol.height(ts) - flat.height(ts)[:, None]
    if kind == "oscillon":
        # top views of zeta(r) - Z(t) over the disk, as in the paper's polar plots (Fig. 5)
        fig, axes = plt.subplots(2, 4, figsize=(12, 7.2), subplot_kw={"projection": "polar"},
                                 layout="constrained")
        theta = np.linspace(0.0, 2 * math.pi, 121)
        vmax = max(float(np.max(np.abs(rel))), 1e-12)
        TH, R = np.meshgrid(theta, x)
        r_ticks = np.linspace(0.0, float(x[-1]), 4)[1:-1]      # the rim r_max is named in the label
        for ax, tk, zk in zip(axes.ravel(), ts, rel):
            im = ax.pcolormesh(TH, R, np.repeat(zk[:, None], theta.size, axis=1), cmap="RdBu_r",
                               vmin=-vmax, vmax=vmax, shading="gouraud")
            ax.set_xticks([])
            ax.set_rticks(r_ticks)
            ax.set_yticklabels([f"{v:.3g}" for v in r_ticks], fontsize=7)
            ax.set_rlabel_position(90)
            ax.set_xlabel(f"$r$ (viscous lengths{', requested grid' if stretched else ''}); "
                          f"rim $r$ = {float(x[-1]):.3g}", fontsize=8)
            ax.set_title(f"$t/T$ = {tk / T:.3g}", fontsize=9, pad=8)
        fig.colorbar(im, ax=axes, shrink=0.8, label=r"$\zeta - Z$ (plate amplitudes $A$)")
        fig.suptitle(header + r" -- top views of $\zeta - Z_{\rm flat}$ (Fig. 5 style)", fontsize=10)
    else:
        fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
        cmap = plt.get_cmap("twilight")
        for tk, zk in zip(ts, sol.height(ts)):
            ax.plot(x, zk, color=cmap(tk / T), lw=1.4)
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        sm = ScalarMappable(norm=Normalize(0.0, 1.0), cmap=cmap)
        fig.colorbar(sm, ax=ax, label=r"time $t/T$ of the profile (periods, dimensionless)")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(r"height $\zeta$ (plate amplitudes $A$)")
        ax.set_title(header + "\nprofiles $\\zeta(x)$ at 8 times per period", fontsize=9)
    figures["snapshots"] = fig
    return figures


def plot_solution(sol, directory, n_times=160, prefix=None):
    """Write the standard figures of a :class:`~tps_solver.solvers.tps.PeriodicSolution` (see :func:`solution_figures`).

    Parameters
    ----------
    sol : PeriodicSolution
    directory : str
        Output folder (must exist).
    n_times : int
        Time samples over one period.
    prefix : str, optional
        File-name prefix; default ``"kink"`` or ``"oscillon"``.

    Returns
    -------
    paths : list of str
        The PNG files written: ``{prefix}_zeta.png``, ``{prefix}_w_minus_W.png``,
        ``{prefix}_snapshots.png``.

    Examples
    --------
    The figures are those of :func:`solution_figures`.  Here ``Figure.savefig`` is replaced by
    a recorder, so nothing is rendered or written (rendering the three figures takes seconds);
    a real call is ``plot_solution(sol, "out")``:

    >>> import matplotlib.pyplot as plt
    >>> from unittest import mock
    >>> from matplotlib.figure import Figure
    >>> from tps_solver import solve_kink
    >>> sol = solve_kink(n_harmonics=6, n_nodes=6)
    >>> open_before = plt.get_fignums()
    >>> with mock.patch.object(Figure, "savefig", autospec=True) as savefig:
    ...     paths = plot_solution(sol, "out", n_times=16)
    >>> paths
    ['out/kink_zeta.png', 'out/kink_w_minus_W.png', 'out/kink_snapshots.png']
    >>> [c.args[1] for c in savefig.call_args_list] == paths, savefig.call_args.kwargs
    (True, {'dpi': 120})
    >>> for c in savefig.call_args_list:
    ...     print(c.args[0].axes[0].get_title().splitlines()[-1])
    height $\\zeta$ over one period
    $w - W$ over one period
    profiles $\\zeta(x)$ at 8 times per period
    >>> plt.get_fignums() == open_before                      # every figure closed
    True
    """
    plt = _pyplot()
    prefix = prefix or ("kink" if _geometry(sol) == "planar" else "oscillon")
    paths = []
    for name, fig in solution_figures(sol, n_times).items():
        path = os.path.join(directory, f"{prefix}_{name}.png")
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
    return paths


def growth_rates_figure(kh_min=1e-2, kh_max=20.0, n_modes=3, nu=1.0, n_points=121):
    """The linear-stability rates :math:`-\\sigma h^2/\\nu` of (35) against :math:`kh` (h = 1), both families.

    Parameters
    ----------
    kh_min, kh_max : float
    n_modes : int
        Modes per family.
    nu : float
    n_points : int

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    The curves are the damping rates of :func:`~tps_solver.growth_rates`, plus the
    line :math:`\\nu k^2`:

    >>> import matplotlib.pyplot as plt
    >>> from tps_solver import growth_rates
    >>> fig = growth_rates_figure(kh_min=0.5, kh_max=2.0, n_modes=1, n_points=3)
    >>> ax = fig.axes[0]
    >>> [line.get_label() for line in ax.lines][:2]
    ['sinuous mode 1', 'varicose mode 1']
    >>> bool(np.allclose(ax.lines[0].get_ydata()[1], -growth_rates(1.0, 1.0, "sinuous", 1)[0]))
    True
    >>> plt.close(fig)
    """
    plt = _pyplot()

    from tps_solver.model.linear_stability import MODES, growth_rates

    kh = np.geomspace(kh_min, kh_max, n_points)
    fig, ax = plt.subplots(figsize=(7, 5), layout="constrained")
    styles = {"sinuous": "-", "varicose": "--"}
    for mode in MODES:
        sig = np.array([growth_rates(x, 1.0, mode, n_modes, nu=nu) for x in kh])
        for j in range(n_modes):
            ax.plot(kh, -sig[:, j], styles[mode], color=f"C{j}", label=f"{mode} mode {j + 1}")
    ax.plot(kh, nu * kh ** 2, ":", color="k", label=r"$\nu k^2$ (trivial root $\gamma=0$, not an eigenvalue)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"wavenumber $k h$ (dimensionless; $h$ = layer thickness)")
    ax.set_ylabel(r"damping rate $-\sigma h^2/\nu$ (dimensionless; all $\sigma < 0$)")
    ax.set_title(f"Flat-layer perturbations decay: leading rates of (28)-(29), (35)\n"
                 f"$\\nu$ = {nu:g}, {n_modes} modes per family", fontsize=10)
    ax.legend(fontsize=7)
    return fig


def plot_growth_rates(path, kh_min=1e-2, kh_max=20.0, n_modes=3, nu=1.0, n_points=121):
    """Write :func:`growth_rates_figure` to ``path``.

    Parameters
    ----------
    path : str or binary file-like
        Output file (PNG), or an open binary stream (anything ``Figure.savefig`` accepts).
    kh_min, kh_max : float
    n_modes : int
        Modes per family.
    nu : float
    n_points : int

    Returns
    -------
    path : str or file-like
        ``path`` as given.

    Examples
    --------
    Here ``Figure.savefig`` is replaced by a recorder, so nothing is rendered or written (the
    first rendering of a figure costs a second or more); a real call is
    ``plot_growth_rates("rates.png")``, and ``path`` may also be a stream such as
    ``io.BytesIO()``:

    >>> import matplotlib.pyplot as plt
    >>> from unittest import mock
    >>> from matplotlib.figure import Figure
    >>> open_before = plt.get_fignums()
    >>> with mock.patch.object(Figure, "savefig", autospec=True) as savefig:
    ...     path = plot_growth_rates("rates.png", n_modes=1, n_points=3)
    >>> fig, = (c.args[0] for c in savefig.call_args_list)    # one figure, saved once
    >>> path, savefig.call_args.args[1:], savefig.call_args.kwargs
    ('rates.png', ('rates.png',), {'dpi': 120})
    >>> for line in fig.axes[0].lines:
    ...     print(line.get_label())
    sinuous mode 1
    varicose mode 1
    $\\nu k^2$ (trivial root $\\gamma=0$, not an eigenvalue)
    >>> plt.get_fignums() == open_before                      # the figure is closed
    True
    """
    plt = _pyplot()
    fig = growth_rates_figure(kh_min, kh_max, n_modes, nu, n_points)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _orbit_header(orbit):
    x = np.asarray(orbit.nodes, dtype=float)
    dx = float(np.min(np.diff(x))) if x.size > 1 else float("nan")
    geometry = _geometry(orbit)
    space = "x" if geometry == "planar" else "r"
    state = (f"converged, max|F| = {orbit.residual:.1e}" if orbit.converged
             else f"NOT converged (status {orbit.status})")
    head = (f"{_method(orbit)}: $\\Gamma$ = {orbit.Gamma:g}, e = {orbit.e:g}, M = {orbit.M}, "
            f"{x.size} nodes, d{space} = {dx:.3g}, {geometry}")
    return head + "\n" + state, space


def orbit_period_figure(orbit, n_times=200, n_snapshots=6):
    r"""Height :math:`\zeta(x, t)` and velocity :math:`w(x, t)` of a lattice periodic orbit over one period.

    Parameters
    ----------
    orbit : ShootingOrbit
        Any lattice periodic orbit with ``nodes``, ``geometry``, ``t_start``, ``period``,
        ``height(t)``, ``velocity(t)`` (arrays of shape (n_times, n_nodes)), ``Gamma``, ``e``,
        ``M``, ``method``, ``converged``, ``residual``, ``status``.
    n_times : int
        Time samples over ``[t_start, t_start + period)`` for the space-time images.
    n_snapshots : int
        Profiles per period in the lower panels.

    Returns
    -------
    matplotlib.figure.Figure
        Four panels: space-time images of :math:`\zeta` and :math:`w` (time upwards, from
        ``t_start``), and :math:`\zeta(x)`, :math:`w(x)` at ``n_snapshots`` equally spaced times.

    Examples
    --------
    The e = 0 flat layer on three nodes is a (uniform) periodic orbit found at once by shooting:

    >>> import matplotlib.pyplot as plt
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=4.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=tps.FlatLayer(Gamma=4.1, M=2, e=0.0),
    ...                               section="fixed", multipliers=False)
    >>> fig = orbit_period_figure(orb, n_times=8, n_snapshots=2)
    >>> [ax.get_xlabel() for ax in fig.axes[:2]]
    ['$x$ (viscous lengths)', '$x$ (viscous lengths)']
    >>> len(fig.axes[2].lines), fig.axes[1].get_title()
    (2, 'velocity $w$ (units of $A\\omega$)')
    >>> plt.close(fig)
    """
    _, t_start = _drawable(orbit, "orbit_period_figure")
    plt = _pyplot()
    x = np.asarray(orbit.nodes, dtype=float)
    T = float(orbit.period)
    t = t_start + T * np.arange(n_times) / n_times
    ts = t_start + T * np.arange(n_snapshots) / n_snapshots
    shift = T * math.floor(t_start / T)      # whole periods: t/T drawn in [0, 2), the forcing phase kept
    # unique sample times (ShootingOrbit.height drops repeated times)
    tt, inv = np.unique(np.concatenate((t, ts)), return_inverse=True)
    zeta, w = orbit.height(tt)[inv], orbit.velocity(tt)[inv]
    header, space = _orbit_header(orbit)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), layout="constrained")
    xlabel = f"${space}$ (viscous lengths)"
    for ax, data, label, cmap in ((axes[0, 0], zeta[:n_times], r"height $\zeta$ (plate amplitudes $A$)", "viridis"),
                                  (axes[0, 1], w[:n_times], r"velocity $w$ (units of $A\omega$)", "RdBu_r")):
        vmax = float(np.max(np.abs(data))) if cmap == "RdBu_r" else None
        im = ax.pcolormesh(x, (t - shift) / T, data, shading="nearest", cmap=cmap,
                           vmin=-vmax if vmax is not None else None, vmax=vmax)
        fig.colorbar(im, ax=ax, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(TIME_LABEL)
        ax.set_title(label.split(" (")[0] + " (" + label.split(" (")[1], fontsize=9)
    cmap = plt.get_cmap("viridis")
    for ax, data, label in ((axes[1, 0], zeta[n_times:], r"height $\zeta$ (plate amplitudes $A$)"),
                            (axes[1, 1], w[n_times:], r"velocity $w$ (units of $A\omega$)")):
        for k, (tk, prof) in enumerate(zip(ts, data)):
            ax.plot(x, prof, ".-", ms=3, lw=1.2, color=cmap(k / max(1, n_snapshots - 1)),
                    label=f"$t/T$ = {(tk - shift) / T:.3g}")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    fig.suptitle(header, fontsize=10)
    return fig


def plot_orbit_period(orbit, path, n_times=200, n_snapshots=6, dpi=120):
    """Write :func:`orbit_period_figure` to ``path`` (PNG or anything ``Figure.savefig`` accepts).

    Parameters
    ----------
    orbit : ShootingOrbit
    path : str or binary file-like
    n_times, n_snapshots : int
    dpi : int

    Returns
    -------
    path : str or file-like
        ``path`` as given.

    Examples
    --------
    Here ``Figure.savefig`` is replaced by a recorder, so nothing is rendered or written; a
    real call is ``plot_orbit_period(orb, "orbit.png")``:

    >>> import matplotlib.pyplot as plt
    >>> from unittest import mock
    >>> from matplotlib.figure import Figure
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=4.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=tps.FlatLayer(Gamma=4.1, M=2, e=0.0),
    ...                               section="fixed", multipliers=False)
    >>> open_before = plt.get_fignums()
    >>> with mock.patch.object(Figure, "savefig", autospec=True) as savefig:
    ...     path = plot_orbit_period(orb, "orbit.png", n_times=4, n_snapshots=1)
    >>> path, savefig.call_args.args[1:], savefig.call_args.kwargs, plt.get_fignums() == open_before
    ('orbit.png', ('orbit.png',), {'dpi': 120}, True)
    """
    plt = _pyplot()
    fig = orbit_period_figure(orbit, n_times, n_snapshots)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _events(orbit):
    """(t, node, kind, sticking intervals) of one period of any periodic result.

    A shooting orbit keeps the FDA's events (kinds ``"impact"``, ``"stick"``, ``"liftoff"``);
    the other results give their :class:`~tps_solver.core.pattern.ContactPattern`, read here in
    the same terms (a bounce or touch is an impact; a stick or chatter lands, rests, lifts off).
    """
    ev = orbit.get("events")
    if ev is not None and orbit.get("sticking_intervals") is not None:
        if len(ev):
            return (np.asarray(ev.t, dtype=float), np.asarray(ev.node, dtype=int), np.asarray(ev.kind).astype(str),
                    list(orbit.sticking_intervals))
        return np.empty(0), np.empty(0, int), np.empty(0, str), list(orbit.sticking_intervals)
    try:
        pat = orbit.contacts
    except (AttributeError, KeyError) as exc:
        raise ValueError(f"contact_pattern_figure: this {type(orbit).__name__} has no contact pattern ({exc})") from None
    node = np.asarray(pat.node, dtype=int)
    t = np.asarray(pat.t, dtype=float)
    kinds = np.asarray(pat.kind).astype(str)
    lift = np.asarray(pat.liftoff, dtype=float)
    rest = np.isin(kinds, ("stick", "chatter")) & np.isfinite(lift)
    T = float(orbit.period)
    t0 = float(orbit.get("t_start", 0.0))
    ivs = []
    for j, a, b in zip(node[rest], t[rest], lift[rest]):
        a0 = t0 + np.mod(a - t0, T)                   # in the window [t0, t0 + T); a rest across its
        b0 = a0 + (b - a)                             # end is drawn in two pieces (the orbit is periodic)
        ivs.append((int(j), float(a0), float(min(b0, t0 + T))))
        if b0 > t0 + T:
            ivs.append((int(j), t0, float(b0 - T)))
    t_out = np.concatenate([t, lift[rest]])
    node_out = np.concatenate([node, node[rest]])
    kind_out = np.concatenate([np.where(rest, "stick", "impact"), np.full(int(rest.sum()), "liftoff")])
    return t0 + np.mod(t_out - t0, T), node_out, kind_out, ivs


def contact_pattern_figure(orbit, trigger_tol=1e-9, zoom=True):
    r"""Contact pattern of a lattice periodic orbit: node position vs time over one period.

    Blank is flight; a thick bar is a stuck interval (landing to stick until lift-off); a dot
    is a touch-and-go contact (an ``"impact"`` event); an open triangle marks a lift-off that
    happens within ``trigger_tol`` of a neighbouring node's landing ("triggered").

    Parameters
    ----------
    orbit : ShootingOrbit
        Any lattice periodic orbit with ``nodes``, ``geometry``, ``t_start``, ``period``,
        ``events`` (recarray with fields ``t``, ``node``, ``kind``), ``sticking_intervals``
        (list of ``(node, t_begin, t_end)``) and the fields of the title (``Gamma``, ``e``, ``M``,
        ``method``, ``converged``, ``residual``, ``status``).
    trigger_tol : float
        Time tolerance for a triggered lift-off.
    zoom : bool
        Add one panel per cluster of events (events closer than T/8 form a cluster; at most
        three), zoomed in time; the first panel always shows the whole period.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    On the e = 0 flat layer every node touches and goes once and sticks once per period:

    >>> import matplotlib.pyplot as plt
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=4.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=tps.FlatLayer(Gamma=4.1, M=2, e=0.0),
    ...                               section="fixed", multipliers=False)
    >>> fig = contact_pattern_figure(orb)
    >>> ax = fig.axes[0]
    >>> [(c.get_label(), len(c.get_segments() if hasattr(c, "get_segments") else c.get_offsets()))
    ...  for c in ax.collections]
    [('stuck', 3), ('touch-and-go', 3), ('triggered lift-off', 0)]
    >>> len(fig.axes)                     # the period, then zooms on the sticks and on the touch-and-go
    3
    >>> plt.close(fig)
    """
    _, t0 = _drawable(orbit, "contact_pattern_figure")
    plt = _pyplot()
    x = np.asarray(orbit.nodes, dtype=float)
    T = float(orbit.period)
    header, space = _orbit_header(orbit)
    t, node, kind, ivs = _events(orbit)
    shift = T * math.floor(t0 / T)           # whole periods: t/T drawn in [0, 2), the forcing phase kept
    windows = [(t0, t0 + T)]
    if zoom and t.size:
        ts = np.sort(t)
        cut = np.flatnonzero(np.diff(ts) > T / 8)
        starts = np.concatenate(([0], cut + 1))
        ends = np.concatenate((cut, [ts.size - 1]))
        for a, b in list(zip(starts, ends))[:3]:
            pad = max(0.1 * (ts[b] - ts[a]), 1e-3 * T)
            windows.append((ts[a] - pad, ts[b] + pad))
    fig, axes = plt.subplots(1, len(windows), figsize=(6.5 + 4.0 * (len(windows) - 1), 5.5),
                             layout="constrained", squeeze=False)
    dxm = float(np.min(np.diff(x))) if x.size > 1 else 1.0
    imp = kind == "impact"
    landing = (kind == "impact") | (kind == "stick")
    trig = []
    for i in np.flatnonzero(kind == "liftoff"):
        nb = landing & (np.abs(node - node[i]) == 1)
        if nb.any():
            d = np.abs(np.mod(t[nb] - t[i] + 0.5 * T, T) - 0.5 * T)
            if np.min(d) < trigger_tol:
                trig.append(i)
    trig = np.asarray(trig, dtype=int)
    bounce_free = not float(orbit.e) > 0.0
    for k, (ax, (ta, tb)) in enumerate(zip(axes[0], windows)):
        ax.vlines([x[j] for j, _, _ in ivs], [(b - shift) / T for _, b, _ in ivs],
                  [(e_ - shift) / T for _, _, e_ in ivs], colors="k", lw=max(1.0, min(6.0, 300.0 / x.size)),
                  label="stuck")
        ax.scatter(x[node[imp]], (t[imp] - shift) / T, s=12, c="C3",
                   label="touch-and-go" if bounce_free else "impact", zorder=3)
        ax.scatter(x[node[trig]], (t[trig] - shift) / T, s=30, marker="^", facecolors="none", edgecolors="C0",
                   label="triggered lift-off", zorder=4)
        ax.set_xlim(x[0] - dxm, x[-1] + dxm)
        ax.set_ylim((ta - shift) / T, (tb - shift) / T)
        ax.set_xlabel(f"${space}$ (viscous lengths)")
        ax.set_ylabel(TIME_LABEL if k == 0 else TIME_LABEL.replace("periods", "periods, zoom"))
        if k == 0:
            ax.legend(fontsize=8, loc="upper right")
        else:
            ax.set_title(f"zoom {k}", fontsize=9)
    fig.suptitle(header + "\ncontact pattern: blank = flying", fontsize=9)
    return fig


def plot_contact_pattern(orbit, path, trigger_tol=1e-9, zoom=True, dpi=120):
    """Write :func:`contact_pattern_figure` to ``path`` (PNG or anything ``Figure.savefig`` accepts).

    Parameters
    ----------
    orbit : ShootingOrbit
    path : str or binary file-like
    trigger_tol : float
    zoom : bool
    dpi : int

    Returns
    -------
    path : str or file-like
        ``path`` as given.

    Examples
    --------
    Here ``Figure.savefig`` is replaced by a recorder, so nothing is rendered or written; a
    real call is ``plot_contact_pattern(orb, "pattern.png")``:

    >>> import matplotlib.pyplot as plt
    >>> from unittest import mock
    >>> from matplotlib.figure import Figure
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=4.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=tps.FlatLayer(Gamma=4.1, M=2, e=0.0),
    ...                               section="fixed", multipliers=False)
    >>> open_before = plt.get_fignums()
    >>> with mock.patch.object(Figure, "savefig", autospec=True) as savefig:
    ...     path = plot_contact_pattern(orb, "pattern.png")
    >>> path, savefig.call_args.args[1:], savefig.call_args.kwargs, plt.get_fignums() == open_before
    ('pattern.png', ('pattern.png',), {'dpi': 120}, True)
    """
    plt = _pyplot()
    fig = contact_pattern_figure(orbit, trigger_tol, zoom)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
