r"""Figures (matplotlib is imported only when a function is called; the backend is the caller's choice).

* :func:`solution_figures` / :func:`plot_solution` -- space-time maps of :math:`\zeta(t, r)` and
  :math:`w - W` (paper Figs. 3-4) and snapshots: polar top views of the oscillon (Fig. 5) or
  profiles of the kink;
* :func:`growth_rates_figure` / :func:`plot_growth_rates` -- the damping rates of (35).

Every figure has labelled axes with units (heights in plate amplitudes A, velocities in
:math:`A\omega`, horizontal lengths in viscous lengths, time in units of :math:`1/\omega`),
a colour bar wherever colour carries a value, and a title that states the parameters.
A TPS result whose continuation ended before full coupling is drawn on the grid that was
asked for (``nodes_requested``), and its title says so.
"""
import math
import os

import numpy as np

__all__ = ["solution_figures", "plot_solution", "growth_rates_figure", "plot_growth_rates"]


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def _display_nodes(sol):
    """Nodes to draw on: the requested grid when the continuation stopped early (stretched nodes)."""
    req = sol.get("nodes_requested")
    if req is not None and sol.coupling < 1.0 and np.shape(req) == np.shape(sol.nodes):
        return np.asarray(req, dtype=float), True
    return np.asarray(sol.nodes, dtype=float), False


def _header(sol, kind, stretched):
    spacing = float(np.min(np.diff(sol.nodes))) if sol.nodes.size > 1 else float("nan")
    head = (f"TPS {kind}: $\\Gamma$ = {sol.Gamma:g}, e = {sol.e:.4g}, M = {sol.M}, N = {sol.N}, "
            f"{sol.nodes.size} nodes")
    if sol.converged:
        state = f"converged, max|F| = {sol.residual:.1e}, spacing {spacing:.3g}"
    else:
        state = f"NOT converged (status {sol.status})"
        if stretched:
            state += (f"; fields at coupling $\\nu_c$ = {sol.coupling:.3g} (spacing {spacing:.3g}), "
                      "drawn on the requested grid")
    return head + "\n" + state


def solution_figures(sol, n_times=160):
    """Build the standard figures of a :class:`~tps_solver.tps.PeriodicSolution`.

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
    plt = _pyplot()
    kind = "kink" if sol.geometry == "planar" else "oscillon"
    space = "x" if kind == "kink" else "r"
    x, stretched = _display_nodes(sol)
    T = sol.period
    t = np.linspace(0.0, T, n_times)
    zeta = sol.height(t)
    w_rel = sol.velocity(t) - sol.flat.velocity(t)[:, None]
    header = _header(sol, kind, stretched)
    xlabel = f"${space}$ (viscous lengths{', requested grid' if stretched else ''})"
    figures = {}
    for name, data, label, cmap, symmetric in (
            ("zeta", zeta, r"height $\zeta$ (plate amplitudes $A$)", "viridis", False),
            ("w_minus_W", w_rel, r"$w - W$ (units of $A\omega$)", "RdBu_r", True)):
        fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
        vmax = float(np.max(np.abs(data))) if symmetric else None
        im = ax.pcolormesh(x, t / math.pi, data, shading="gouraud", cmap=cmap,
                           vmin=-vmax if symmetric else None, vmax=vmax)
        fig.colorbar(im, ax=ax, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(r"time $\omega t/\pi$ (one period: $2M$)")
        ax.set_title(header + f"\n{label.split(' (')[0]} over one period", fontsize=9)
        figures[name] = fig
    # snapshots, 8 per period
    ts = np.linspace(0.0, T, 9)[:-1]
    rel = sol.height(ts) - sol.flat.height(ts)[:, None]
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
            ax.set_title(f"$\\omega t$ = {tk / math.pi:.2f}$\\pi$", fontsize=9, pad=8)
        fig.colorbar(im, ax=axes, shrink=0.8, label=r"$\zeta - Z$ (plate amplitudes $A$)")
        fig.suptitle(header + r" -- top views of $\zeta - Z_{\rm flat}$ (Fig. 5 style)", fontsize=10)
    else:
        fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
        cmap = plt.get_cmap("twilight")
        for tk, zk in zip(ts, sol.height(ts)):
            ax.plot(x, zk, color=cmap(tk / T), lw=1.4)
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        sm = ScalarMappable(norm=Normalize(0.0, T / math.pi), cmap=cmap)
        fig.colorbar(sm, ax=ax, label=r"time $\omega t/\pi$ of the profile")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(r"height $\zeta$ (plate amplitudes $A$)")
        ax.set_title(header + "\nprofiles $\\zeta(x)$ at 8 times per period", fontsize=9)
    figures["snapshots"] = fig
    return figures


def plot_solution(sol, directory, n_times=160, prefix=None):
    """Write the standard figures of a :class:`~tps_solver.tps.PeriodicSolution` (see :func:`solution_figures`).

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
    prefix = prefix or ("kink" if sol.geometry == "planar" else "oscillon")
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

    from .linear_stability import MODES, growth_rates

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
