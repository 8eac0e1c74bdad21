"""Periodic orbits of any contact pattern by shooting (``find_periodic_orbit``): measured numbers.

Functions (each returns rows of measured numbers; ``main()`` prints markdown tables):

* :func:`coarse_cycle` -- acceptance: shooting reproduces the exact single-contact cycle of the
  coarse lattice (8 nodes, spacing 20) and its multipliers agree with ``check_stability``;
* :func:`e0_kinks` -- the e = 0 kink (Gamma = 4.1, M = 2, planar Neumann lattice of length 40)
  on dx = 2, 1, 0.5: two contacts per node and period (touch-and-go + stick), residual,
  leading multipliers (the front position is nearly neutral), front width, 10-period check;
* :func:`paper_kinks` -- the paper's FDA kink lattices (41 and 81 nodes, L = 8, pinned ends,
  point impacts, Gamma = 2.5): is there a periodic orbit near the time-stepped state?

Run: ``python -m validation.shooting [coarse|e0|paper ...]`` (all by default).  Timings are
wall-clock on the shared 2-core machine, single-threaded BLAS if threadpoolctl is installed.
"""
import math
import sys
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, one_blas_thread, phase_distance
from tps_solver.solvers.fda import kink_state
from tps_solver.analyses.localized import front_width
from tps_solver.solvers.shooting.periodic import find_periodic_orbit


def verify(orb, periods=10):
    """Integrate the orbit for ``periods`` periods from its section state.

    Returns the defects ``d_k = max|x(t_s + kT) - x(t_s)|`` (k = 1..periods) and the
    per-period growth ratio fitted on them (geometric mean of d_k / d_{k-1} over the second half).
    """
    t_eval = orb.t_start + orb.period * np.arange(periods + 1)
    kw = dict(orb._sim_kw)
    if orb.method != "soft":
        kw["stuck0"] = orb.stuck0
        kw["max_events_per_cycle"] = 10 ** 7
    run = tps.simulate(orb.lattice, orb.Gamma, orb.e, orb.w0, orb.zeta0, t_start=orb.t_start,
                       t_end=t_eval[-1], method=orb.method, t_eval=t_eval, **kw)
    d = np.maximum(np.max(np.abs(run.w_eval - run.w_eval[0]), axis=1),
                   np.max(np.abs(run.zeta_eval - run.zeta_eval[0]), axis=1))[1:]
    k = d.size
    h = max(1, k // 2)
    ratio = float((d[-1] / d[k - h - 1]) ** (1.0 / h)) if k > h and d[k - h - 1] > 0 else float("nan")
    return d, ratio


def coarse_cycle():
    """Shooting on the coarse lattice against ``solve_lattice_cycle`` and ``check_stability``."""
    coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    rows = []
    rng = np.random.default_rng(7)
    for label, guess, ts in (("the exact cycle", cyc, None), ("cycle + 1e-2 noise", None, None)):
        if guess is None:
            o = rows[0]["orbit"]
            guess = (o.w0 + 1e-2 * rng.standard_normal(8), o.zeta0 + 1e-2 * rng.standard_normal(8))
            ts = o.t_start
        tic = time.perf_counter()
        orb = find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=guess, t_start=ts)
        sec = time.perf_counter() - tic
        tc = np.array([c[0] for c in orb.contact_times])
        rows.append(dict(orbit=orb, guess=label, converged=orb.converged, nit=orb.nit,
                         residual=orb.residual, maps=orb.n_period_maps, seconds=sec,
                         tc_error=float(np.max(phase_distance(tc, cyc.tc, orb.period))),
                         mu1=complex(orb.multipliers[0]), abs_mu1=float(abs(orb.multipliers[0]))))
    chk = tps.check_stability(cyc, periods=10, jacobian=True)
    mu_chk = chk.multipliers
    mu = rows[0]["orbit"].multipliers
    for r in rows:
        r["check_stability_abs_mu1"] = float(abs(mu_chk[0]))
        r["check_stability_growth"] = float(chk.growth_factor)
        k = min(mu.size, mu_chk.size)
        r["max_mu_diff"] = float(np.max(np.abs(np.sort_complex(r["orbit"].multipliers[:k])
                                               - np.sort_complex(mu_chk[:k]))))
    return rows


def e0_flat_state(Gamma, M, s, n_nodes=3):
    """The e = 0 flat orbit at time ``s`` (w, zeta of one node), by time stepping a uniform lattice
    from rest at the lift-off instant sin t = 1/Gamma for two periods."""
    T = 2.0 * math.pi * M
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=2.0)
    tl = math.asin(1.0 / Gamma) + 1e-9
    s = float(s)
    t_end = tl + 2 * T + np.mod(s - tl, T)
    r = tps.simulate(lat, Gamma, 0.0, np.zeros(n_nodes), np.zeros(n_nodes), t_start=tl, t_end=t_end + 1e-9,
                     t_eval=[t_end])
    return float(r.w_eval[0, 0]), float(r.zeta_eval[0, 0]), float(t_end)


def e0_kink_guess(lattice, Gamma=4.1, M=2, periods=10, width=2.0, phase=0.25):
    """Time-stepped e = 0 kink: :func:`tps_solver.solvers.fda.kink_state` with the e = 0 sticking far
    field (two flat layers T/2 apart joined linearly over ``width``), integrated for ``periods``
    periods from two periods after the lift-off plus ``phase`` T.  Returns the SimulationResult."""
    from tps_solver.model.sticking import sticking_orbit
    T = 2.0 * math.pi * M
    tl = math.asin(1.0 / Gamma)
    s = tl + 1e-9 + 2 * T + np.mod(phase * T - 1e-9, T)
    orb, info = sticking_orbit(Gamma, 0.0, M)
    if orb is None:
        raise ValueError(f"no e = 0 sticking orbit of period 2 pi M at Gamma = {Gamma}: {info}")
    w, z = kink_state(lattice, orb, s, width=width)
    return tps.simulate(lattice, Gamma, 0.0, w, z, t_start=s, t_end=s + periods * T)


def e0_kinks(dxs=(2.0, 1.0, 0.5), length=40.0, Gamma=4.1, M=2, periods=10, max_iter=80, callback=None):
    """Shooting for the e = 0 kink per lattice spacing (see the module docstring)."""
    rows = []
    for dx in dxs:
        n = int(round(length / dx)) + 1
        lat = tps.Lattice.planar(n_nodes=n, length=length)
        tic = time.perf_counter()
        run = e0_kink_guess(lat, Gamma, M, periods)
        t_step = time.perf_counter() - tic
        tic = time.perf_counter()
        orb = find_periodic_orbit(lat, Gamma=Gamma, M=M, e=0.0, guess=run, max_iter=max_iter,
                                  n_multipliers=6, dense_max=100, callback=callback)
        sec = time.perf_counter() - tic
        row = dict(orbit=orb, dx=dx, n_nodes=n, converged=orb.converged, status=orb.status, nit=orb.nit,
                   residual=orb.residual, maps=orb.n_period_maps, seconds=sec, step_seconds=t_step,
                   guess_defect=float(orb.residual_history[0]),
                   contacts=dict(zip(*map(lambda a: a.tolist(), np.unique(orb.contacts_per_node,
                                                                          return_counts=True)))),
                   sticking_nodes=len({iv[0] for iv in orb.sticking_intervals}),
                   mu=[complex(m) for m in orb.multipliers[:4]], kind=orb.multipliers_kind,
                   message=orb.message)
        if orb.converged:
            d, ratio = verify(orb, 10)
            row.update(defect10=float(np.max(d)), defect_ratio=ratio, width=front_width(orb))
        rows.append(row)
    return rows


def _match(a, b):
    d = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    return float(max(d.min(0).max(), d.min(1).max()))


def soft_flat_multipliers(Gamma=2.5, M=2, e=0.45, cutoff=0.3):
    """Soft contact, flat lattice: multipliers of ``check_stability`` and ``find_periodic_orbit``
    (both from the exact soft monodromy) against the closed-form per-mode soft flat monodromy
    ``SoftFlatOrbit.monodromy``.  Returns rows (case, kind, error, seconds)."""
    from tps_solver.operators.lattice import lattice_eigenvalues

    ref = tps.SoftFlatOrbit(Gamma, M, e, cutoff)
    fl = tps.FlatLayer(Gamma, M, e=e)
    rows = []
    tic = time.perf_counter()
    chk = tps.check_stability(fl, periods=3, n_nodes=3, length=2.0, method="soft", cutoff=cutoff, jacobian=True)
    sec = time.perf_counter() - tic
    want = np.concatenate([np.linalg.eigvals(Mk) for Mk in
                           ref.monodromy(lattice_eigenvalues(chk.lattice), t_section=chk.section_time)])
    rows.append(dict(case="check_stability, 3 nodes, jacobian=True", kind=chk.multipliers_kind,
                     error=_match(chk.multipliers, want), seconds=sec))
    lat = tps.Lattice.planar(n_nodes=3, length=1.0)
    t_s = ref.t_exit + 0.5 * ref.flight
    w, z = ref.state(t_s)
    guess = (np.full(3, float(w)) + 1e-4 * np.array([1.0, -1.0, 0.5]), np.full(3, float(z)))
    want = np.concatenate([np.linalg.eigvals(Mk) for Mk in ref.monodromy(lattice_eigenvalues(lat), t_section=t_s)])
    tic = time.perf_counter()
    orb = find_periodic_orbit(lat, Gamma, M, e, cutoff=cutoff, guess=guess, t_start=t_s, section="fixed")
    sec = time.perf_counter() - tic
    rows.append(dict(case=f"find_periodic_orbit, 3 nodes (residual {orb.residual:.1e}, {orb.nit} Newton steps, "
                          f"{orb.n_period_maps} maps)", kind=orb.multipliers_kind,
                     error=_match(orb.multipliers, want), seconds=sec))
    return rows


PAPER = {"e = 0.45": dict(e=0.45), "paper t0 = 0 (e = 0.4307)": dict(t0=0.0)}


def paper_kinks(n_nodes_list=(41, 81), length=8.0, Gamma=2.5, M=2, periods=20, presets=("e = 0.45",),
                max_iter=6, krylov_dim=40, verify_periods=10, callback=None):
    """Shooting from the time-stepped paper kink (pinned lattice, point impacts, kink_state IC).

    The kink initial condition (two flat layers T/2 apart joined over width 2, as in
    validation/fda_benchmark.py) is integrated for ``periods`` periods; the periodicity defect of
    every period is recorded, and the final state is handed to :func:`find_periodic_orbit`.
    """
    rows = []
    for name in presets:
        fl = tps.FlatLayer(Gamma=Gamma, M=M, **PAPER[name])
        for n in n_nodes_list:
            lat = tps.Lattice.planar(n_nodes=n, length=length, boundary="pinned")
            t0 = fl.t0 + 1.0
            w, z = kink_state(lat, fl, t0, width=2.0)
            te = t0 + fl.period * np.arange(periods + 1)
            tic = time.perf_counter()
            run = tps.simulate(lat, Gamma, fl.e, w, z, t_start=t0, t_end=te[-1], t_eval=te,
                               max_events_per_cycle=10 ** 6)
            t_step = time.perf_counter() - tic
            step_defects = np.maximum(np.abs(np.diff(run.w_eval, axis=0)).max(axis=1),
                                      np.abs(np.diff(run.zeta_eval, axis=0)).max(axis=1))
            tic = time.perf_counter()
            orb = find_periodic_orbit(lat, Gamma=Gamma, M=M, e=fl.e, guess=run, max_iter=max_iter,
                                      krylov_dim=krylov_dim, max_events_per_period=10 ** 6,
                                      n_multipliers=4, dense_max=0, callback=callback)
            sec = time.perf_counter() - tic
            hist = orb.residual_history
            kinds = orb.events.kind if orb.events is not None else np.empty(0, "U7")
            row = dict(preset=name, e=fl.e, n_nodes=n, dx=lat.spacing, step_seconds=t_step, seconds=sec,
                       step_defects=step_defects.tolist(),
                       converged=orb.converged, status=orb.status, nit=orb.nit,
                       residual0=float(hist[0]) if hist.size else float("nan"),
                       residual=orb.residual, maps=orb.n_period_maps,
                       events_per_period=orb.events_per_period,
                       impacts=int(np.sum(kinds == "impact")), sticks=int(np.sum(kinds == "stick")),
                       contacts_max=int(orb.contacts_per_node.max()),
                       contacts_min=int(orb.contacts_per_node.min()),
                       sticking_nodes=len({iv[0] for iv in orb.sticking_intervals}),
                       stuck_at_section=int(np.count_nonzero(orb.stuck0)),
                       simultaneous=orb.simultaneous_contacts, differentiable=orb.differentiable,
                       mu=[complex(m) for m in orb.multipliers[:4]], growth=orb.growth_factor,
                       message=orb.message, history=hist.tolist(), orbit=orb)
            if orb.converged and verify_periods:
                d, ratio = verify(orb, verify_periods)
                row.update(defect10=float(np.max(d)), defect_ratio=ratio)
            rows.append(row)
    return rows


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.3g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.2e}"
    if isinstance(v, complex):
        return f"{v.real:.4g}{v.imag:+.4g}j" if v.imag else f"{v.real:.4g}"
    if isinstance(v, (list, tuple)):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


def table(rows, keys):
    """Markdown table of ``rows`` (dicts) over ``keys``, cells written by :func:`_fmt`."""
    return markdown_table(rows, [(k, lambda r, k=k: _fmt(r.get(k))) for k in keys])


def _progress(state):
    print(f"    Newton step {state.iteration}: residual {state.residual:.3g}", flush=True)


def main(parts=("coarse", "soft", "e0", "paper")):
    """Print the measured tables (markdown)."""
    with one_blas_thread():
        if "soft" in parts:
            print("\n## Soft contact: multipliers of a flat lattice against the closed-form monodromy\n")
            print(table(soft_flat_multipliers(), ["case", "kind", "error", "seconds"]))
        if "coarse" in parts:
            print("\n## Shooting vs the exact coarse-lattice cycle (8 nodes, spacing 20, e = 0.45)\n")
            rows = coarse_cycle()
            print(table(rows, ["guess", "converged", "nit", "residual", "maps", "seconds", "tc_error",
                               "abs_mu1", "check_stability_abs_mu1", "max_mu_diff", "check_stability_growth"]))
        if "e0" in parts:
            print("\n## e = 0 kink, Gamma = 4.1, M = 2, Neumann lattice of length 40\n")
            rows = e0_kinks(callback=_progress)
            print(table(rows, ["dx", "n_nodes", "converged", "nit", "guess_defect", "residual", "maps", "seconds",
                               "contacts", "sticking_nodes", "mu", "defect10", "defect_ratio", "width"]))
            for r in rows:
                print(f"\n- dx = {r['dx']}: {r['message']}")
        if "paper" in parts:
            print("\n## The paper's kink lattices (pinned, L = 8, point impacts, Gamma = 2.5)\n")
            rows = paper_kinks(callback=_progress)
            print(table(rows, ["preset", "n_nodes", "dx", "converged", "status", "nit", "residual0", "residual",
                               "maps", "seconds", "events_per_period", "contacts_min", "contacts_max",
                               "sticking_nodes", "stuck_at_section", "simultaneous", "differentiable", "mu",
                               "growth", "defect10"]))
            for r in rows:
                print(f"\n- {r['preset']}, {r['n_nodes']} nodes: {r['message']}; history {r['history']}")
            return rows


if __name__ == "__main__":
    main(tuple(sys.argv[1:]) or ("coarse", "soft", "e0", "paper"))
