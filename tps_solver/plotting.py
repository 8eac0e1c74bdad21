"""Figures (matplotlib is imported only when a function is called; the backend is the caller's choice).

* :func:`plot_solution` -- surfaces of zeta(t, r) and w - W (paper Figs. 3-4)
  and polar snapshots of the oscillon (Fig. 5) or profiles of the kink.
"""
import math
import os

import numpy as np

__all__ = ["plot_solution", "plot_growth_rates"]


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def plot_solution(sol, directory, n_times=160, prefix=None):
    """Write the standard figures of a :class:`~tps_solver.tps.PeriodicSolution`.

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
        The PNG files written.
    """
    plt = _pyplot()
    kind = "kink" if sol.geometry == "planar" else "oscillon"
    prefix = prefix or kind
    T = sol.period
    t = np.linspace(0.0, T, n_times)
    zeta = sol.height(t)
    w_rel = sol.velocity(t) - sol.flat.velocity(t)[:, None]
    x = sol.nodes
    X, Y = np.meshgrid(x, t / math.pi)
    paths = []
    for name, data, label in (("zeta", zeta, r"$\zeta(t, r)$"), ("w_minus_W", w_rel, r"$w - W$")):
        fig = plt.figure(figsize=(7, 5))
        ax = fig.add_subplot(projection="3d")
        ax.plot_surface(X, Y, data, cmap="viridis", linewidth=0, antialiased=False, rstride=2, cstride=1)
        ax.set_xlabel("x" if kind == "kink" else "r")
        ax.set_ylabel(r"$t/\pi$")
        ax.set_zlabel(label)
        ax.set_title(f"{kind}: {label}, converged={sol.converged}, N={sol.N}")
        path = os.path.join(directory, f"{prefix}_{name}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    # snapshots (polar for the oscillon, profiles for the kink), 8 per period
    ts = np.linspace(0.0, T, 9)[:-1]
    zs = sol.height(ts)
    if kind == "oscillon":
        # top views of zeta(r) - Z(t) over the disk, as in the paper's polar plots (Fig. 5)
        fig, axes = plt.subplots(2, 4, figsize=(11, 6), subplot_kw={"projection": "polar"})
        theta = np.linspace(0.0, 2 * math.pi, 73)
        rel = zs - sol.flat.height(ts)[:, None]
        vmax = max(float(np.max(np.abs(rel))), 1e-12)
        for ax, tk, zk in zip(axes.ravel(), ts, rel):
            TH, R = np.meshgrid(theta, x)
            ax.pcolormesh(TH, R, np.repeat(zk[:, None], theta.size, axis=1), cmap="RdBu_r",
                          vmin=-vmax, vmax=vmax, shading="auto")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"t = {tk / math.pi:.2f} pi", fontsize=9)
        fig.suptitle(r"oscillon snapshots of $\zeta - Z$ (Fig. 5 style)")
    else:
        fig, axes = plt.subplots(2, 4, figsize=(11, 5), sharey=True)
        for ax, tk, zk in zip(axes.ravel(), ts, zs):
            ax.plot(x, zk)
            ax.set_title(f"t = {tk / math.pi:.2f} pi", fontsize=9)
        fig.suptitle("kink snapshots of zeta")
    fig.tight_layout()
    path = os.path.join(directory, f"{prefix}_snapshots.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)
    return paths


def plot_growth_rates(path, kh_min=1e-2, kh_max=20.0, n_modes=3, nu=1.0, n_points=121):
    """Draw the linear-stability rates sigma h^2 / nu of (35) against k h (h = 1), both families.

    Parameters
    ----------
    path : str
        Output file (PNG).
    kh_min, kh_max : float
    n_modes : int
        Modes per family.
    nu : float
    n_points : int

    Returns
    -------
    path : str
    """
    plt = _pyplot()

    from .linear_stability import MODES, growth_rates

    kh = np.geomspace(kh_min, kh_max, n_points)
    fig, ax = plt.subplots(figsize=(7, 5))
    styles = {"sinuous": "-", "varicose": "--"}
    for mode in MODES:
        sig = np.array([growth_rates(x, 1.0, mode, n_modes, nu=nu) for x in kh])
        for j in range(n_modes):
            ax.plot(kh, -sig[:, j], styles[mode], color=f"C{j}", label=f"{mode} mode {j + 1}")
    ax.plot(kh, nu * kh ** 2, ":", color="k", label=r"$\nu k^2$ (trivial root $\gamma=0$, not an eigenvalue)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"$k h$")
    ax.set_ylabel(r"$-\sigma h^2/\nu$ (all $\sigma < 0$)")
    ax.set_title("Flat-layer perturbations decay: leading rates of (28)-(29)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
