"""FDA validation and benchmarks: speed and contact-time error, grid-scale growth (docs/design.md, hazard 8), kink runs.

Run ``python validation/fda_benchmark.py`` (a few minutes); the functions return
their numbers so tests can assert on them.

* :func:`flat_radial_benchmark` -- exact vs ode on a 200-node quasi-log radial
  lattice carrying the flat layer: wall time per period, contact-time error
  against :class:`~tps_solver.FlatLayer` (exact reference), state error.
* :func:`growth_vs_dx` -- hazard 8 of docs/design.md: per-period growth of a small zero-mean
  perturbation of the stable flat layer on a planar Neumann lattice of length 8,
  against the lattice spacing, both integrators.
* :func:`kink_runs` -- the paper's kink initial condition on pinned 41/81-node
  lattices for 20 periods: events, sticking, wall time.
"""
import os
import sys
import time

import numpy as np


import tps_solver as tps
from tps_solver.solvers.fda import flat_state, kink_state

GAMMA, E, M = 2.5, 0.45, 2
FIGDIR = os.path.join(os.path.dirname(__file__), "figures")


def _flat():
    return tps.FlatLayer(Gamma=GAMMA, M=M, e=E)


def flat_radial_run(method, n_nodes=200, r_max=20.0, periods=2, **kw):
    """One flat-layer run on the radial quasi-log lattice; returns timing and errors.

    Returns
    -------
    dict
        ``seconds_per_period``, ``contact_time_error`` (max over the contact
        sets of |t - (t0 + kT)|), ``state_error`` (max |zeta - Z|, |w - W| at the end),
        ``n_steps``.
    """
    fl = _flat()
    lat = tps.Lattice.axisymmetric(n_nodes=n_nodes, r_max=r_max, grid="quasilog")
    t0 = fl.t0 + 1.0
    w, z = flat_state(lat, fl, t0)
    tic = time.perf_counter()
    run = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + periods * fl.period, method=method, **kw)
    sec = (time.perf_counter() - tic) / periods
    exact_times = fl.t0 + fl.period * np.arange(1, periods + 1)
    ev_t = run.events.t
    k = np.rint((ev_t - fl.t0) / fl.period).astype(int) - 1
    ok = (k >= 0) & (k < periods)
    err_t = float(np.max(np.abs(ev_t[ok] - exact_times[k[ok]]))) if np.any(ok) else float("nan")
    complete = bool(np.all(ok) and run.n_events == periods * n_nodes)
    err_s = max(float(np.max(np.abs(run.zeta - fl.height(run.t)))),
                float(np.max(np.abs(run.w - fl.velocity(run.t)))))
    return dict(method=method, solver=kw.get("ode_solver", "DOP853") if method == "ode" else "modal",
                rtol=kw.get("rtol") if method == "ode" else None, periods=periods,
                seconds_per_period=sec, contact_time_error=err_t, state_error=err_s,
                all_contacts_as_sets=complete, n_steps=run.n_steps)


def flat_radial_benchmark(n_nodes=200, ode_cases=(("DOP853", 1e-8, 1), ("Radau", 1e-8, 2),
                                                   ("Radau", 1e-10, 2), ("Radau", 1e-12, 1)),
                          periods_exact=10):
    """Exact vs ode on the 200-node radial lattice; list of result dicts (see :func:`flat_radial_run`)."""
    rows = [flat_radial_run("exact", n_nodes=n_nodes, periods=periods_exact)]
    for solver, rtol, periods in ode_cases:
        rows.append(flat_radial_run("ode", n_nodes=n_nodes, periods=periods, rtol=rtol, atol=rtol,
                                    ode_solver=solver))
    return rows


def growth_vs_dx(n_nodes_list=(6, 11, 16, 31), length=8.0, periods=8, perturbation=1e-7,
                 methods=("exact", "ode"), **kw):
    """Hazard 8: growth of a zero-mean perturbation of the stable flat layer vs lattice spacing.

    Returns rows with ``dx``, ``method``, ``growth_overall`` = (d_K/d_0)^(1/K),
    ``growth_fit`` (check_stability's fit on the linear window), ``final_distance``.
    """
    fl = _flat()
    rows = []
    for n in n_nodes_list:
        for method in methods:
            chk = tps.check_stability(fl, periods=periods, n_nodes=n, length=length, method=method,
                                      perturbation=perturbation, **kw)
            d = chk.growth_history
            rows.append(dict(n_nodes=n, dx=length / (n - 1), method=method,
                             growth_overall=float((d[-1] / d[0]) ** (1.0 / (d.size - 1))),
                             growth_fit=chk.growth_factor, final_distance=float(d[-1])))
    return rows


def kink_runs(n_nodes_list=(41, 81), periods=20, length=20.0):
    """The kink initial condition on pinned lattices; events, sticking and wall time per run."""
    fl = _flat()
    rows = []
    for n in n_nodes_list:
        lat = tps.Lattice.planar(n_nodes=n, length=length, boundary="pinned")
        t0 = fl.t0 + 1.0
        w, z = kink_state(lat, fl, t0, width=2.0)
        tic = time.perf_counter()
        run = tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + periods * fl.period)
        sec = time.perf_counter() - tic
        ev = run.events
        last = ev[ev.t >= run.t - fl.period]
        rows.append(dict(n_nodes=n, seconds=sec, success=run.success, events=run.n_events,
                         events_last_period=int(last.size),
                         impacts=int(np.count_nonzero(ev.kind == "impact")),
                         sticks=int(np.count_nonzero(ev.kind == "stick")),
                         liftoffs=int(np.count_nonzero(ev.kind == "liftoff")),
                         nodes_sticking_last_period=np.unique(last.node[last.kind == "stick"]).tolist(),
                         min_zeta=float(run.zeta.min())))
    return rows


def _table(rows, keys):
    head = "| " + " | ".join(keys) + " |"
    sep = "|" + "---|" * len(keys)
    lines = [head, sep]
    for r in rows:
        cells = []
        for k in keys:
            v = r[k]
            cells.append(f"{v:.3g}" if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _figure(rows, path):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for method, mk in (("exact", "o-"), ("ode", "s--")):
        sel = [r for r in rows if r["method"] == method]
        ax.plot([r["dx"] for r in sel], [r["growth_overall"] for r in sel], mk, label=method)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("lattice spacing dx")
    ax.set_ylabel("growth factor per period")
    ax.set_title("hazard 8 of docs/design.md: flat layer, Gamma=2.5, e=0.45, M=2, L=8")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    os.makedirs(FIGDIR, exist_ok=True)
    print("## exact vs ode, flat layer on a 200-node quasi-log radial lattice (r_max = 20)\n")
    rows = flat_radial_benchmark()
    print(_table(rows, ["method", "solver", "rtol", "periods", "seconds_per_period", "contact_time_error",
                        "state_error", "all_contacts_as_sets", "n_steps"]))
    ex = rows[0]["seconds_per_period"]
    print("\nspeed ratio ode/exact: " + ", ".join(
        f"{r['solver']} rtol={r['rtol']:g}: {r['seconds_per_period'] / ex:.0f}x" for r in rows[1:]))
    print("\n## hazard 8 of docs/design.md: growth per period vs dx (planar Neumann, length 8, perturbation 1e-7, 8 periods)\n")
    g = growth_vs_dx()
    print(_table(g, ["n_nodes", "dx", "method", "growth_overall", "growth_fit", "final_distance"]))
    _figure(g, os.path.join(FIGDIR, "fda_growth_vs_dx.png"))
    print("\n## simultaneity window as a cut-off: perturbation 1e-10, ode with its default window 1e-9\n")
    g2 = growth_vs_dx(perturbation=1e-10, methods=("exact", "ode"))
    print(_table(g2, ["n_nodes", "dx", "method", "growth_overall", "growth_fit", "final_distance"]))
    print("\n## kink initial condition, pinned lattice, length 20, 20 periods (exact)\n")
    k = kink_runs()
    print(_table(k, ["n_nodes", "seconds", "success", "events", "events_last_period", "impacts", "sticks",
                     "liftoffs", "nodes_sticking_last_period", "min_zeta"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
