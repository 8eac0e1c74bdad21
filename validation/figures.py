"""The paper's Figs. 2, 3, 4, 5, 7 and 8 from our own solutions.

* Fig. 2 -- the kink from the FDA (51)-(54), M = 2, as a converged periodic orbit (shooting): the
  paper's kink initial state (two flat layers half a period apart, pinned
  ends) time-stepped with :func:`tps_solver.simulate`; the last periods.
* Figs. 3, 4, 5 -- oscillon velocity w - W, elevation zeta and polar
  snapshots from the TPS (:func:`tps_solver.solve_oscillon`), drawn by
  :func:`tps_solver.plotting.plot_solution` -- **only if the TPS run
  converged**; otherwise the figure is listed with the solver's status and
  message instead.
* Fig. 7 -- three cycles of zeta(r, t) - Z(t) of an FDA oscillon (quasi-log
  lattice (66)), started from the decoupled oscillon state (core at phase
  t0 + T/2, far field at t0); the periodicity defect of the last period is
  measured and printed on the figure.
* Fig. 8 -- polar snapshots of that FDA oscillon over its last period.

Every FDA figure states its lattice spacing (the cut-off in force,
hazard 8 of docs/design.md).  Run ``python -m validation.figures`` (a few minutes) to write the
PNGs under ``validation/figures/`` and ``validation/sections/figures.md``.
"""
import math
import os

import numpy as np

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from tps_solver.model.flat import FlatLayer
from validation.report import FIGURES_DIR, merged_config, optional_import, publish

#: Fast configuration (tests) and full configuration (``main``).
FAST = dict(Gamma=2.5, e=0.45, M=2, tps_N=8, tps_nodes=20, tps_r_max=8.0,
            kink_nodes=7, kink_length=8.0, kink_periods=1, kink_shown=1, kink_newton=0,
            osc_nodes=8, osc_r_max=6.0, osc_periods=1, osc_shown=1, samples=16)
FULL = dict(Gamma=2.5, e=0.45, M=2, tps_N=30, tps_nodes=120, tps_r_max=12.0,
            kink_nodes=41, kink_length=8.0, kink_periods=20, kink_shown=2, kink_newton=8,
            osc_nodes=40, osc_r_max=12.0, osc_periods=8, osc_shown=3, samples=96)


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def oscillon_state(lattice, flat, t, r_core=1.0, width=0.5):
    """Decoupled oscillon state at time ``t``: phase ``t + T/2`` inside ``r_core``, ``t`` outside.

    The two flat states are joined linearly over ``|r - r_core| < width/2``
    (the radial analogue of :func:`tps_solver.solvers.fda.kink_state`).

    Returns
    -------
    w, zeta : ndarray of float, shape (n_nodes,)
    """
    r = lattice.nodes
    theta = np.clip((r - r_core) / width + 0.5, 0.0, 1.0)          # 0 in the core, 1 outside
    t_in = t + 0.5 * flat.period
    w = theta * flat.velocity(t) + (1.0 - theta) * flat.velocity(t_in)
    z = theta * flat.height(t) + (1.0 - theta) * flat.height(t_in)
    return np.asarray(w, dtype=float), np.asarray(z, dtype=float)


def _fda_run(lattice, fl, w, z, ts, periods, shown, samples):
    """Run ``periods`` periods; sample the last ``shown`` of them (``samples`` per period)."""
    from tps_solver.solvers.fda import simulate

    T = fl.period
    t_end = ts + periods * T
    t_eval = t_end - shown * T + np.arange(shown * samples + 1) * T / samples
    t_eval = t_eval[(t_eval >= ts) & (t_eval <= t_end)]
    run = simulate(lattice, fl.Gamma, fl.e, w, z, t_start=ts, t_end=t_end, method="exact", t_eval=t_eval)
    defect = None
    if run.t_eval.size > samples:
        # periodicity defect over the last period: zeta(t) vs zeta(t - T) at the sampled times
        defect = float(np.max(np.abs(run.zeta_eval[samples:] - run.zeta_eval[:-samples])))
    return run, defect


def _surface(plt, x, t, data, xlabel, zlabel, title, path):
    X, Y = np.meshgrid(x, t / math.pi)
    fig = plt.figure(figsize=(7.5, 5.5))
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(X, Y, data, cmap="viridis", linewidth=0, antialiased=False)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"$t/\pi$")
    ax.set_zlabel(zlabel)
    ax.set_title(title, fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def fig2_fda_kink(fl, cfg, directory):
    """Fig. 2: the kink as a converged periodic orbit of the FDA (pinned lattice, the paper's initial state).

    The paper's initial state is time stepped for ``kink_periods`` periods and the periodic orbit
    near it is found by shooting (:func:`tps_solver.find_periodic_orbit`); the figure shows
    zeta(x, t), w(x, t) over one period and the contact pattern, and is made only if Newton
    converged (otherwise the entry says why).
    """
    from tps_solver.operators.lattice import Lattice
    from tps_solver.solvers.shooting.periodic import find_periodic_orbit
    from tps_solver.solvers.fda import simulate
    from tps_solver.solvers.fda import kink_state
    from tps_solver.plotting import plot_contact_pattern, plot_orbit_period

    lat = Lattice.planar(n_nodes=cfg["kink_nodes"], length=cfg["kink_length"], boundary="pinned")
    ts = fl.t0 + 0.5
    w, z = kink_state(lat, fl, ts)
    run = simulate(lat, fl.Gamma, fl.e, w, z, t_start=ts, t_end=ts + cfg["kink_periods"] * fl.period,
                   method="exact")
    entry = dict(figure="Fig. 2", what="kink zeta(x, t), w(x, t) and contact pattern over one period, "
                                       "from a converged FDA periodic orbit, M = 2", paths=[],
                 solver=f"FDA exact, pinned planar lattice, {lat.n_nodes} nodes, dx = {lat.spacing:.3g}, "
                        f"{cfg['kink_periods']} periods then shooting",
                 run_status=run.message, n_events=int(run.n_events), residual=None)
    if not run.success:
        entry.update(made=False, reason=f"the FDA run failed: {run.message}")
        return entry
    orb = find_periodic_orbit(lat, Gamma=fl.Gamma, M=fl.M, e=fl.e, guess=run, multipliers=False,
                              max_iter=cfg.get("kink_newton", 8), krylov_dim=40)
    entry.update(residual=float(orb.residual), solver=entry["solver"] + f": {orb.message}")
    if not orb.converged:
        entry.update(made=False, reason=f"no periodic orbit found near the time-stepped kink: {orb.message}")
        return entry
    paths = [plot_orbit_period(orb, os.path.join(directory, "fig2_fda_kink_period.png")),
             plot_contact_pattern(orb, os.path.join(directory, "fig2_fda_kink_contacts.png"))]
    entry.update(made=True, paths=paths,
                 reason=f"contacts per node and period {int(orb.contacts_per_node.min())}-"
                        f"{int(orb.contacts_per_node.max())}, {len(orb.sticking_intervals)} sticking intervals")
    return entry


def _fmt(value):
    return "n/a" if value is None else f"{value:.2g}"


def figs345_tps_oscillon(fl, cfg, directory):
    """Figs. 3-5 from a TPS oscillon, if it converged; else the reason."""
    from tps_solver.solvers.tps import solve_oscillon
    from tps_solver.plotting import plot_solution

    sol = solve_oscillon(Gamma=fl.Gamma, M=fl.M, t0=fl.t0, n_harmonics=cfg["tps_N"], n_nodes=cfg["tps_nodes"],
                         r_max=cfg["tps_r_max"])
    solver = (f"TPS oscillon, N = {sol.N}, {cfg['tps_nodes']} nodes, r_max = {cfg['tps_r_max']:g}: "
              f"converged {sol.converged} (status {sol.status}), physical checks pass {sol.checks.all_pass}")
    whats = {"Fig. 3": "oscillon velocity w - W from the TPS", "Fig. 4": "oscillon elevation zeta(t, r) from the TPS",
             "Fig. 5": "polar snapshots of the TPS oscillon"}
    if not sol.converged:
        reason = f"no converged TPS oscillon: {sol.message}"
        return [dict(figure=f, what=w, made=False, paths=[], solver=solver, reason=reason) for f, w in whats.items()]
    paths = plot_solution(sol, directory, prefix="fig345_tps_oscillon")
    note = "" if sol.checks.all_pass else ("converged, but the physical checks FAIL (min zeta "
                                           f"{sol.checks.min_zeta:.3g}, single contact {sol.checks.single_contact})")
    by_fig = {"Fig. 3": [p for p in paths if "w_minus_W" in p], "Fig. 4": [p for p in paths if p.endswith("_zeta.png")],
              "Fig. 5": [p for p in paths if "snapshots" in p]}
    return [dict(figure=f, what=w, made=True, paths=by_fig[f], solver=solver, reason=note) for f, w in whats.items()]


def _polar_snapshots(plt, r, times, rel, title, path):
    fig, axes = plt.subplots(2, 4, figsize=(11, 6), subplot_kw={"projection": "polar"})
    theta = np.linspace(0.0, 2 * math.pi, 73)
    vmax = max(float(np.max(np.abs(rel))), 1e-12)
    TH, R = np.meshgrid(theta, r)
    for ax, tk, zk in zip(axes.ravel(), times, rel):
        ax.pcolormesh(TH, R, np.broadcast_to(zk[:, None], TH.shape), cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                      shading="auto")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"t = {tk / math.pi:.3f} pi", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figs78_fda_oscillon(fl, cfg, directory):
    """Fig. 7 (cycles of zeta - Z) and Fig. 8 (polar snapshots) of an FDA oscillon."""
    from tps_solver.operators.lattice import Lattice

    plt = _pyplot()
    lat = Lattice.axisymmetric(n_nodes=cfg["osc_nodes"], r_max=cfg["osc_r_max"], grid="quasilog")
    ts = fl.t0 + 0.5
    w, z = oscillon_state(lat, fl, ts)
    run, defect = _fda_run(lat, fl, w, z, ts, cfg["osc_periods"], cfg["osc_shown"], cfg["samples"])
    solver = (f"FDA exact, quasi-log axisymmetric lattice (66), {lat.n_nodes} nodes, r_max = {cfg['osc_r_max']:g}, "
              f"smallest spacing {lat.spacing:.3g}; {cfg['osc_periods']} periods from the decoupled oscillon state")
    base = dict(solver=solver, run_status=run.message, defect=defect, n_events=int(run.n_events),
                stuck_at_end=int(np.sum(run.stuck)))
    if run.t_eval.size < cfg["samples"] + 1:
        reason = f"the FDA run stopped before the sampled periods: {run.message}"
        return [dict(base, figure="Fig. 7", what="cycles of zeta - Z from the FDA", made=False, paths=[],
                     reason=reason),
                dict(base, figure="Fig. 8", what="polar snapshots of the FDA oscillon", made=False, paths=[],
                     reason=reason)]
    rel = run.zeta_eval - fl.height(run.t_eval)[:, None]
    title = (f"Fig. 7 (ours): FDA oscillon $\\zeta - Z$, last {cfg['osc_shown']} of {cfg['osc_periods']} periods, "
             f"dr_min={lat.spacing:.3g}; defect of last period {_fmt(defect)}")
    p7 = _surface(plt, lat.nodes, run.t_eval, rel, "r", r"$\zeta - Z$", title,
                  os.path.join(directory, "fig7_fda_oscillon_cycles.png"))
    last = run.t_eval >= run.t_eval[-1] - fl.period
    idx = np.nonzero(last)[0]
    pick = idx[np.linspace(0, idx.size - 1, 9).astype(int)[:-1]]
    p8 = _polar_snapshots(plt, lat.nodes, run.t_eval[pick], rel[pick],
                          f"Fig. 8 (ours): FDA oscillon snapshots of $\\zeta - Z$ over the last period "
                          f"(dr_min={lat.spacing:.3g})", os.path.join(directory, "fig8_fda_oscillon_snapshots.png"))
    note = ("" if defect is not None and defect < 1e-6 else
            f"not periodic to 1e-6 after {cfg['osc_periods']} periods (defect of the last period {_fmt(defect)})")
    return [dict(base, figure="Fig. 7", what="cycles of zeta - Z from the FDA", made=True, paths=[p7], reason=note),
            dict(base, figure="Fig. 8", what="polar snapshots of the FDA oscillon", made=True, paths=[p8],
                 reason=note)]


def make_figures(config=None, directory=FIGURES_DIR, **overrides):
    """Make every figure that our solutions support.

    Parameters
    ----------
    config : dict, optional
        :data:`FAST` (default) or :data:`FULL`; ``overrides`` replace entries.
    directory : str
        Output folder of the PNGs.

    Returns
    -------
    entries : list of dict
        One per paper figure: ``figure``, ``what``, ``made`` (bool), ``paths``,
        ``solver`` (what produced it), ``reason`` (why it was not made, or a
        caveat), and for FDA figures ``defect``, ``run_status``, ``n_events``.

    Examples
    --------
    >>> entries = make_figures(FAST, directory="/tmp/figs")       # doctest: +SKIP
    >>> [(e["figure"], e["made"]) for e in entries][:2]           # doctest: +SKIP
    [('Fig. 2', True), ('Fig. 3', False)]
    """
    cfg = merged_config(FAST, config, overrides)
    os.makedirs(directory, exist_ok=True)
    fl = FlatLayer(cfg["Gamma"], cfg["M"], e=cfg["e"])
    fda = optional_import("tps_solver.solvers.fda") is not None
    entries = []
    if fda:
        entries.append(fig2_fda_kink(fl, cfg, directory))
    else:
        entries.append(dict(figure="Fig. 2", what="kink elevation from the FDA", made=False, paths=[], solver="",
                            reason="the FDA (tps_solver.solvers.fda) does not exist yet"))
    entries += figs345_tps_oscillon(fl, cfg, directory)
    if fda:
        entries += figs78_fda_oscillon(fl, cfg, directory)
    else:
        entries += [dict(figure=f, what=w, made=False, paths=[], solver="",
                         reason="the FDA (tps_solver.solvers.fda) does not exist yet")
                    for f, w in (("Fig. 7", "cycles of zeta - Z from the FDA"),
                                 ("Fig. 8", "polar snapshots of the FDA oscillon"))]
    for e in entries:
        e["config"] = cfg
    return entries


def render(entries, command="python -m validation.figures"):
    """The markdown section text of :func:`make_figures` entries."""
    cfg = entries[0]["config"] if entries else {}
    lines = ["## The paper's figures from our solutions", "",
             "Script: `validation/figures.py`. Reproduce:", "", f"    {command}", "",
             f"Parameters: Gamma = {cfg.get('Gamma')}, e = {cfg.get('e')}, M = {cfg.get('M')} (the stable-interior "
             "preset; the paper's far field t0 = 0 sits at the fold of the flat orbit). A figure whose underlying "
             "solution does not exist or did not converge is listed with the reason, not drawn.", "",
             "| figure | content | made | produced by | note / reason |", "|---|---|---|---|---|"]
    seen = {}
    for e in entries:
        notes = [e["reason"]] if e["reason"] else []
        if e.get("residual") is not None:
            notes.append(f"shooting residual max|P(x) - x| = {e['residual']:.2g}, {e.get('n_events')} events in the "
                         f"settling run")
        elif e.get("defect") is not None:
            notes.append(f"periodicity defect of the last period {e['defect']:.2g}, {e.get('n_events')} events "
                         f"in the run, {e.get('stuck_at_end')} node(s) stuck at its end")
        note = "; ".join(notes)
        if note and note in seen:
            note = f"as {seen[note]}"
        elif note:
            seen[note] = e["figure"]
        lines.append(f"| {e['figure']} | {e['what']} | {'yes' if e['made'] else '**no**'} | {e['solver']} | "
                     f"{note} |")
    lines.append("")
    for e in entries:
        for p in e["paths"]:
            rel = os.path.relpath(p, os.path.dirname(FIGURES_DIR))
            lines += [f"{e['figure']}: `{rel}`", "", f"![{e['figure']}]({rel})", ""]
    return "\n".join(lines)


def main(config=None):
    """Make the full-size figures, print the list and write ``validation/sections/figures.md``."""
    entries = make_figures(FULL if config is None else config)
    publish("figures", render(entries))
    return entries


if __name__ == "__main__":
    main()
