"""Soft-contact kinks at cut-off 0.3 over lattice spacings: time-stepped fate, shooting existence, benchmark.

Model: Gamma = 2.5, e = 0.45, M = 2, ``method="soft"`` with ``cutoff = 0.3`` (contact time
tau_c = 0.09), the planar **Neumann** lattice of the project's default grids
(``tps_solver.core.defaults.COARSE_LATTICE``, ``validation.presets``, the kinks of
``validation.existence_map``), default sticking rule of the soft integrator
(capture speed 1e-4, docs/design.md, hazard 10).

Functions (each returns rows of measured numbers; ``main()`` prints markdown tables):

* :func:`kink_lattice` -- the lattice per spacing: 12 nodes for spacing >= 5, a length of
  about 48 for the finer ones;
* :func:`kink_start` -- the kink start: nodes with x < 0 on the soft flat orbit
  (:class:`tps_solver.SoftFlatOrbit`) at t0 = t_exit + T/4, nodes with x > 0 on it half a
  period later (a sharp step at x = 0, no linear join);
* :func:`fate` -- time stepping period by period from the kink start: per period the
  periodicity defect, contacts per node, the number of *disordered* nodes, and for an
  invading front the invasion speed;
* :func:`shoot` -- :func:`tps_solver.find_periodic_orbit` from the time-stepped state:
  converged, residual, Newton steps, seconds, contacts per node, leading multipliers;
* :func:`spacing_continuation` -- follow a converged orbit to other spacings (the fold);
* :func:`orbit_search` -- shoot from the time-stepped state every few periods and collect the
  (unstable) periodic kinks Newton reaches;
* :func:`decay_check` -- on a converged orbit: the time-stepped defect d_k against the leading
  multiplier of the shooting orbit (d_k / d_{k-1} -> |mu_1|);
* :func:`benchmark` -- wall and CPU time, Newton steps to max|P(x) - x| <= 1e-10 for a
  200-node soft kink orbit.

Definitions.  *Contacts* of a node in a period are its ``"impact"`` (entry into soft
contact) and ``"stick"`` (capture by the sticking rule) records, as in
``find_periodic_orbit``'s ``contacts_per_node``; the soft flat orbit has exactly one
(:func:`flat_count`, measured).  A node is *disordered* in a period if its number of
contacts differs from the flat orbit's or it has a ``"stick"`` record.  The *defect* of
period k is ``max(|w(t_k + T) - w(t_k)|, |zeta(t_k + T) - zeta(t_k)|)`` over the nodes.
The *invasion speed* is the least-squares slope of the number of disordered nodes against
the period number, up to the first period in which it reaches 80 % of the nodes (nodes per
period; times the spacing: length per period; a kink has two fronts, so each front moves
at half of it).

Run ``python -m validation.soft_kinks [fate] [shoot] [fold] [bench] [search] [--spacings 20,12,...] [--save DIR]``
(default: fate, shoot, fold and bench on :data:`DEFAULT_SPACINGS`, a few minutes; ``search``:
:func:`orbit_search` per spacing; the fine spacings of
:data:`SPACINGS` take 10-20 minutes each, mostly in the shooting, budgeted by ``--shoot-budget``).
Timings use ``threadpoolctl.threadpool_limits(1)`` and report wall and process CPU time
(the machine is shared).
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, one_blas_thread

__all__ = ["GAMMA", "E", "M", "CUTOFF", "SPACINGS", "DEFAULT_SPACINGS", "BENCH_CASES", "table", "fate_table",
           "summary_rows", "compact_table", "kink_lattice", "kink_start", "flat_count", "period_record",
           "fate", "invasion_speed", "shoot", "spacing_continuation", "orbit_search", "decay_check", "benchmark",
           "main"]

GAMMA, E, M, CUTOFF = 2.5, 0.45, 2, 0.3
#: Lattice spacings of the study (viscous lengths).
SPACINGS = (20.0, 12.0, 10.0, 5.0, 1.0, 0.2, 0.1)
#: Spacings of ``main()`` without arguments (the 12-node lattices around the fold; a few minutes).
DEFAULT_SPACINGS = (20.0, 12.0, 11.5, 11.0, 10.5, 10.0)
#: The verdict rules of :func:`fate` as options of :func:`tps_solver.front_fate` (disordered nodes against
#: the node count): "invades" when they reach 80 % of the lattice (no growth bound), "settles" when the last
#: defect is < 1e-6 with no disordered node, "decays" with none over the last five periods and a falling
#: defect, "localized disorder" when some are left; no "stationary".
FATE_RULES = dict(settle_tol=1e-6, front_max=math.inf, invade_fraction=0.8, settle_width=0.0, decay_periods=5,
                  stationary_periods=None, localized=True)
#: Nodes for the coarse spacings (>= 5) and the length of the fine ones.
COARSE_NODES, FINE_LENGTH = 12, 48.0


def kink_lattice(dx, n_nodes=None):
    """Planar Neumann lattice of spacing ``dx`` centred on x = 0.

    Parameters
    ----------
    dx : float
        Node spacing (viscous lengths), > 0.
    n_nodes : int, optional
        Default: 12 for ``dx >= 5``, else ``round(48 / dx) + 1`` (length 48).

    Returns
    -------
    Lattice

    Examples
    --------
    >>> kink_lattice(20.0).n_nodes, kink_lattice(1.0).n_nodes, kink_lattice(0.1).n_nodes
    (12, 49, 481)
    """
    if not (isinstance(dx, (int, float)) and math.isfinite(dx) and dx > 0):
        raise ValueError(f"dx must be a finite number > 0, got {dx!r}")
    if n_nodes is None:
        n_nodes = COARSE_NODES if dx >= 5.0 else int(round(FINE_LENGTH / dx)) + 1
    return tps.Lattice.planar(n_nodes=int(n_nodes), length=dx * (int(n_nodes) - 1), boundary="neumann")


def kink_start(lattice, cutoff=CUTOFF, Gamma=GAMMA, e=E, phase=0.25):
    """The kink start: x < 0 on the soft flat orbit at t0, x > 0 on it at t0 + T/2.

    Parameters
    ----------
    lattice : Lattice
    cutoff, Gamma, e : float
    phase : float
        ``t0 = t_exit + phase * T`` (``phase`` and ``phase + 1/2`` must be flight times).

    Returns
    -------
    w, zeta : ndarray of float, shape (n_nodes,)
    t0 : float
    orbit : SoftFlatOrbit

    Examples
    --------
    >>> w, z, t0, fo = kink_start(kink_lattice(20.0))
    >>> bool(w[0] != w[-1]), bool(abs(t0 - fo.t_exit - 0.25 * fo.period) < 1e-12)
    (True, True)
    """
    fo = tps.SoftFlatOrbit(Gamma, M, e, cutoff)
    t0 = fo.t_exit + phase * fo.period
    wa, za = fo.state(t0)
    wb, zb = fo.state(t0 + 0.5 * fo.period)
    left = lattice.nodes < 0.0
    return np.where(left, wa, wb), np.where(left, za, zb), float(t0), fo


def _contacts(events, n):
    if events is None or not events.size:
        return np.zeros(n, int), np.zeros(n, bool)
    kind = events.kind
    node = np.asarray(events.node, dtype=int)
    c = np.bincount(node[(kind == "impact") | (kind == "stick")], minlength=n)
    st = np.bincount(node[kind == "stick"], minlength=n) > 0
    return c, st


def flat_count(cutoff=CUTOFF, Gamma=GAMMA, e=E):
    """Contacts per node and period of the soft flat orbit (3-node uniform lattice, measured).

    Examples
    --------
    >>> flat_count()
    1
    """
    fo = tps.SoftFlatOrbit(Gamma, M, e, cutoff)
    lat = tps.Lattice.planar(n_nodes=3, length=10.0)
    t = fo.t_exit + 0.5 * fo.flight
    w, z = fo.state(t)
    run = tps.simulate(lat, Gamma, e, np.full(3, w), np.full(3, z), t_start=t, t_end=t + fo.period,
                       method="soft", cutoff=cutoff)
    c, _ = _contacts(run.events, 3)
    return int(np.median(c))


def period_record(k, w, z, run, lattice, ref, fo, t):
    """One period's record: defect, contacts, disordered and sticking nodes, left-phase nodes."""
    n = lattice.n_nodes
    c, st = _contacts(run.events, n)
    bad = (c != ref) | st
    wa, za = fo.state(t)
    wb, zb = fo.state(t + 0.5 * fo.period)
    da = np.maximum(np.abs(run.w - wa), np.abs(run.zeta - za))
    db = np.maximum(np.abs(run.w - wb), np.abs(run.zeta - zb))
    return dict(period=k, defect=float(max(np.max(np.abs(run.w - w)), np.max(np.abs(run.zeta - z)))),
                contacts_min=int(c.min()), contacts_max=int(c.max()),
                contacts_median=float(np.median(c)), disordered=int(np.count_nonzero(bad)),
                sticking=int(np.count_nonzero(st)), events=int(run.n_events),
                phase_a=int(np.count_nonzero(da < db)))


def invasion_speed(counts, n_nodes, fraction=0.8):
    """Least-squares slope of the disordered-node count per period, up to the first period at ``fraction``.

    :func:`tps_solver.invasion_speed` with the lattice's node count as the extent.

    The periods after the first one in which the count reaches ``fraction * n_nodes`` (the
    lattice is filled) are left out.

    Returns
    -------
    float or None
        Nodes per period (None if fewer than two periods are available).

    Examples
    --------
    >>> round(invasion_speed([4, 14, 24, 34, 44, 49, 49], 49), 9)
    10.0
    """
    return tps.invasion_speed(counts, n_nodes, fraction) if len(counts) else None


def fate(dx, periods=15, n_nodes=None, cutoff=CUTOFF, budget=None, settle_tol=1e-12, **simulate_kw):
    """Time-step the kink start on the lattice of spacing ``dx`` period by period.

    Parameters
    ----------
    dx : float
    periods : int
        Largest number of periods; the run stops early when the defect is below ``settle_tol``.
    n_nodes : int, optional
        See :func:`kink_lattice`.
    budget : float, optional
        Wall seconds; no new period is started after it.
    **simulate_kw
        Options of the soft integrator (``rtol``, ``stick_speed``, ...).

    Returns
    -------
    dict
        ``dx, n_nodes, length, ref_count, records`` (list of :func:`period_record` dicts),
        ``verdict`` ("invades": disordered nodes reach 80 % of the lattice; "settles": defect
        < 1e-6 and no disordered node in the last period; "decays": no disordered node in the
        last five periods and the defect fell over them; "localized disorder": disordered
        nodes in the last period, fewer than 80 %; otherwise "undecided"),
        ``speed_nodes`` (nodes per period), ``speed_length`` (length per period, both fronts;
        each front: half), ``seconds``, ``cpu``, ``w, zeta, t`` (final state).
    """
    lat = kink_lattice(dx, n_nodes)
    w, z, t, fo = kink_start(lat, cutoff)
    ref = flat_count(cutoff)
    T = fo.period
    recs = []
    wall, cpu = time.perf_counter(), time.process_time()
    for k in range(1, periods + 1):
        if budget is not None and time.perf_counter() - wall > budget:
            break
        run = tps.simulate(lat, GAMMA, E, w, z, t_start=t, t_end=t + T, method="soft", cutoff=cutoff,
                           **simulate_kw)
        if not run.success:
            recs.append(dict(period=k, failed=run.message))
            break
        recs.append(period_record(k, w, z, run, lat, ref, fo, t + T))
        w, z, t = run.w.copy(), run.zeta.copy(), t + T
        if recs[-1]["defect"] < settle_tol:
            break
    good = [r for r in recs if "defect" in r]
    counts = [r["disordered"] for r in good]
    n = lat.n_nodes
    if good:
        verdict, sp = tps.front_fate([r["defect"] for r in good], counts, n, **FATE_RULES)
    else:
        verdict, sp = "undecided", None
    return dict(dx=float(dx), n_nodes=n, length=float(lat.spacing * (n - 1)), ref_count=ref, records=recs,
                verdict=verdict, speed_nodes=sp, speed_length=None if sp is None else sp * lat.spacing,
                periods_run=len(good), seconds=time.perf_counter() - wall, cpu=time.process_time() - cpu,
                w=w, zeta=z, t=t)


def _summary(pattern):
    vals, cnt = np.unique(np.asarray(pattern, int), return_counts=True)
    return ", ".join(f"{int(v)}: {int(c)}" for v, c in zip(vals, cnt))


def shoot(dx, w, zeta, t, n_nodes=None, cutoff=CUTOFF, max_iter=20, krylov_dim=None, tol=None, budget=None,
          n_multipliers=6, dense_max=64, callback=None, **kw):
    """:func:`tps_solver.find_periodic_orbit` (soft, ``cutoff``) from the state ``(w, zeta)`` at ``t``.

    ``budget`` (wall seconds) interrupts Newton after the step that exceeds it (status 5).

    Returns
    -------
    dict
        ``dx, n_nodes, converged, status, residual, nit, maps, seconds, cpu, contacts`` (text
        "count: nodes"), ``contacts_min/max``, ``sticking_nodes``, ``abs_mu`` (leading |mu|),
        ``mu_kind``, ``history`` (residual per Newton step), ``steps`` (line-search factors),
        ``message``, ``orbit``.
    """
    lat = kink_lattice(dx, n_nodes)
    wall, cpu = time.perf_counter(), time.process_time()

    def cb(state):
        if callback is not None:
            callback(state)
        if budget is not None and time.perf_counter() - wall > budget:
            raise KeyboardInterrupt
    orb = tps.find_periodic_orbit(lat, Gamma=GAMMA, M=M, e=E, cutoff=cutoff, guess=(w, zeta), t_start=t,
                                  max_iter=max_iter, krylov_dim=krylov_dim, tol=tol, n_multipliers=n_multipliers,
                                  dense_max=dense_max, callback=cb, **kw)
    cpn = np.asarray(orb.contacts_per_node)
    st = (set(np.asarray(orb.events.node[orb.events.kind == "stick"], int).tolist())
          if orb.events is not None else set())
    return dict(dx=float(dx), n_nodes=lat.n_nodes, converged=bool(orb.converged), status=int(orb.status),
                residual=float(orb.residual), nit=int(orb.nit), maps=int(orb.n_period_maps),
                seconds=time.perf_counter() - wall, cpu=time.process_time() - cpu,
                contacts=_summary(cpn), contacts_min=int(cpn.min()), contacts_max=int(cpn.max()),
                sticking_nodes=len(st), abs_mu=[float(abs(m)) for m in orb.multipliers[:n_multipliers]],
                mu_kind=orb.multipliers_kind, history=[float(h) for h in orb.residual_history],
                steps=[float(s) for s in orb.step_lengths], message=orb.message, orbit=orb)


def spacing_continuation(orbit, dxs, max_iter=20, tol=1e-10, budget=None, callback=None):
    """Follow a converged 12-node kink orbit to other spacings: each shooting starts from the last orbit.

    The state ``(w0, zeta0)`` at ``t_start`` of the previous orbit is the guess on the next lattice
    (same number of nodes, new spacing); the sequence stops at the first failure.

    Returns
    -------
    list of dict
        :func:`shoot` rows, one per spacing tried.
    """
    rows = []
    for dx in dxs:
        r = shoot(dx, orbit.w0, orbit.zeta0, orbit.t_start, n_nodes=orbit.lattice.n_nodes, max_iter=max_iter,
                  tol=tol, budget=budget, callback=callback, section="fixed")
        r["guess"] = f"orbit at spacing {orbit.lattice.spacing:g}"
        rows.append(r)
        if not r["converged"]:
            break
        orbit = r["orbit"]
    return rows


def orbit_search(dx, periods=30, every=3, n_nodes=None, max_iter=12, tol=1e-10, budget=None):
    """Shoot from the time-stepped kink every ``every`` periods; collect the distinct periodic orbits found.

    Where time stepping keeps a few disordered front nodes, the state wanders near unstable
    periodic kinks; this shows which ones Newton reaches from where.

    Returns
    -------
    list of dict
        One row per attempt: ``dx, period, converged, nit, residual, contacts, abs_mu`` (leading 3),
        ``seconds``, ``growth`` (per-period growth of a 1e-10 perturbation by time stepping,
        :func:`decay_check`, converged orbits only).
    """
    lat = kink_lattice(dx, n_nodes)
    w, z, t, fo = kink_start(lat)
    rows = []
    start = time.perf_counter()
    for k in range(1, periods + 1):
        run = tps.simulate(lat, GAMMA, E, w, z, t_start=t, t_end=t + fo.period, method="soft", cutoff=CUTOFF)
        w, z, t = run.w.copy(), run.zeta.copy(), t + fo.period
        if k % every:
            continue
        if budget is not None and time.perf_counter() - start > budget:
            break
        r = shoot(dx, w, z, t, n_nodes=lat.n_nodes, tol=tol, max_iter=max_iter)
        row = dict(dx=float(dx), period=k, converged=r["converged"], nit=r["nit"], residual=r["residual"],
                   contacts=r["contacts"], abs_mu=r["abs_mu"][:3], seconds=r["seconds"], growth=None)
        if r["converged"] and r["abs_mu"]:
            unstable = r["abs_mu"][0] > 1.0
            row["growth"] = decay_check(r["orbit"], periods=5 if unstable else 8,
                                        size=1e-10 if unstable else 1e-6)["ratio"]
        rows.append(row)
    return rows


def decay_check(orb, periods=8, size=1e-4, seed=0):
    """Time-step the orbit's section state plus a random perturbation; defects against |mu_1|^k.

    Returns
    -------
    dict
        ``defects`` (distance to the orbit's section state after k = 1..periods periods),
        ``ratio`` (geometric mean of d_k / d_{k-1} over the second half), ``abs_mu1``.
    """
    rng = np.random.default_rng(seed)
    n = orb.lattice.n_nodes
    w = orb.w0 + size * rng.standard_normal(n)
    z = orb.zeta0 + size * rng.standard_normal(n)
    te = orb.t_start + orb.period * np.arange(1, periods + 1)
    run = tps.simulate(orb.lattice, orb.Gamma, orb.e, w, z, t_start=orb.t_start, t_end=te[-1], method="soft",
                       cutoff=orb.cutoff, t_eval=te)
    d = np.maximum(np.max(np.abs(run.w_eval - orb.w0), axis=1), np.max(np.abs(run.zeta_eval - orb.zeta0), axis=1))
    h = max(1, periods // 2)
    ratio = float((d[-1] / d[-1 - h]) ** (1.0 / h))
    return dict(defects=d.tolist(), ratio=ratio, abs_mu1=float(abs(orb.multipliers[0])))


#: Cases of the benchmark: 200 nodes at spacing 20 (the default grid's) from 10 and from 3 time-stepped
#: periods, with the leading multipliers, and at spacing 12 (closer to the fold).
BENCH_CASES = (dict(dx=20.0, periods=10), dict(dx=20.0, periods=3), dict(dx=20.0, periods=10, multipliers=True),
               dict(dx=12.0, periods=10), dict(dx=12.0, periods=10, section="fixed"))


def benchmark(n_nodes=200, dx=20.0, periods=10, tol=1e-10, max_iter=20, krylov_dim=None, multipliers=False,
              budget=None, section="auto"):
    """Shooting a ``n_nodes``-node soft kink orbit to ``tol``: wall and CPU time, Newton steps.

    The guess is the kink start after ``periods`` time-stepped periods (timed separately).
    Run inside ``threadpoolctl.threadpool_limits(1)`` by :func:`main`.

    Returns
    -------
    dict
        ``n_nodes, dx, step_wall, step_cpu, guess_defect`` and the :func:`shoot` row.
    """
    fr = fate(dx, periods=periods, n_nodes=n_nodes, settle_tol=0.0)
    row = shoot(dx, fr["w"], fr["zeta"], fr["t"], n_nodes=n_nodes, tol=tol, max_iter=max_iter,
                krylov_dim=krylov_dim, multipliers=multipliers, budget=budget, n_multipliers=4, section=section)
    row.update(step_wall=fr["seconds"], step_cpu=fr["cpu"], step_periods=fr["periods_run"],
               guess_defect=fr["records"][-1].get("defect"), verdict=fr["verdict"])
    return row


# ------------------------------------------------------------------ output
def _fmt(v):
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.2e}"
    if isinstance(v, (list, tuple)):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


def table(rows, keys):
    """Markdown table of ``rows`` (dicts) over ``keys``, cells written by :func:`_fmt`."""
    return markdown_table(rows, [(k, lambda r, k=k: _fmt(r.get(k))) for k in keys])


def fate_table(fr):
    """Per-period markdown table of one :func:`fate` result."""
    return table(fr["records"], ["period", "defect", "contacts_min", "contacts_max", "contacts_median",
                                 "disordered", "sticking", "phase_a", "events"])


def summary_rows(folder):
    """Summary rows (one per spacing) from the JSON results of ``main(["fate", "shoot", "--save", folder])``."""
    rows = []
    for name in sorted(os.listdir(folder)):
        if not (name.startswith("fate_dx") and name.endswith(".json")):
            continue
        with open(os.path.join(folder, name)) as fh:
            fr = json.load(fh)
        recs = [r for r in fr["records"] if "defect" in r]
        row = dict(dx=fr["dx"], n_nodes=fr["n_nodes"], length=fr["length"], periods=len(recs),
                   verdict=fr["verdict"], defect_last=recs[-1]["defect"],
                   disordered_last=recs[-1]["disordered"], contacts_last=f"{recs[-1]['contacts_min']}-"
                   f"{recs[-1]['contacts_max']} (median {recs[-1]['contacts_median']:g})",
                   speed_nodes=fr["speed_nodes"], speed_length=fr["speed_length"],
                   step_wall=fr["seconds"], step_cpu=fr["cpu"])
        sp = os.path.join(folder, f"shoot_dx{fr['dx']:g}.json")
        if os.path.exists(sp):
            with open(sp) as fh:
                sr = json.load(fh)
            row.update(converged=sr["converged"], status=sr["status"], nit=sr["nit"], residual=sr["residual"],
                       shoot_wall=sr["seconds"], shoot_cpu=sr["cpu"], shoot_contacts=sr["contacts"],
                       abs_mu=sr["abs_mu"][:3], history=sr["history"], message=sr["message"])
        rows.append(row)
    rows.sort(key=lambda r: -r["dx"])
    return rows


def compact_table(folder, spacings, periods=(1, 2, 3, 4, 5, 6, 8, 10, 12, 15, 20)):
    """Markdown table: per period and spacing "defect / disordered nodes / max contacts"."""
    fates = {}
    for dx in spacings:
        with open(os.path.join(folder, f"fate_dx{dx:g}.json")) as fh:
            fates[dx] = {r["period"]: r for r in json.load(fh)["records"] if "defect" in r}
    lines = ["| period | " + " | ".join(f"dx = {dx:g}" for dx in spacings) + " |", "|" + "---|" * (len(spacings) + 1)]
    for k in periods:
        cells = []
        for dx in spacings:
            r = fates[dx].get(k)
            cells.append("—" if r is None else f"{_fmt(r['defect'])} / {r['disordered']} / {r['contacts_max']}")
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _save(obj, name, folder):
    if folder is None:
        return
    os.makedirs(folder, exist_ok=True)
    clean = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in obj.items() if k != "orbit"}
    with open(os.path.join(folder, name + ".json"), "w") as fh:
        json.dump(clean, fh, default=str)


def main(argv=None):
    """Print the measured tables (markdown); results are also saved as JSON under ``--save``.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (module docstring); None: the defaults.
    """
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("parts", nargs="*", default=["fate", "shoot", "fold", "bench"])
    p.add_argument("--spacings", default=",".join(f"{s:g}" for s in DEFAULT_SPACINGS))
    p.add_argument("--periods", type=int, default=20)
    p.add_argument("--tol", type=float, default=1e-10)
    p.add_argument("--shoot-budget", type=float, default=900.0)
    p.add_argument("--save", default=None, help="folder for JSON results")
    args = p.parse_args([] if argv is None else argv)
    spacings = [float(s) for s in args.spacings.split(",")]
    out = {}
    with one_blas_thread():
        for dx in spacings:
            if "fate" not in args.parts and "shoot" not in args.parts:
                break
            fr = fate(dx, periods=args.periods)
            _save(fr, f"fate_dx{dx:g}", args.save)
            print(f"\n### Spacing {dx:g}: {fr['n_nodes']} nodes, length {fr['length']:g}; verdict {fr['verdict']}, "
                  f"invasion {_fmt(fr['speed_nodes'])} nodes/period ({_fmt(fr['speed_length'])} length/period); "
                  f"{fr['seconds']:.1f} s wall, {fr['cpu']:.1f} s cpu\n")
            print(fate_table(fr), flush=True)
            if "shoot" in args.parts:
                sr = shoot(dx, fr["w"], fr["zeta"], fr["t"], budget=args.shoot_budget, max_iter=20, tol=args.tol,
                           krylov_dim=None if fr["n_nodes"] <= 50 else 40)
                _save(sr, f"shoot_dx{dx:g}", args.save)
                print("\n" + table([sr], ["dx", "n_nodes", "converged", "status", "nit", "residual", "maps",
                                          "seconds", "cpu", "contacts", "sticking_nodes", "abs_mu"]))
                print(f"\n- message: {sr['message']}; history {_fmt(sr['history'])}; steps {_fmt(sr['steps'])}",
                      flush=True)
                if sr["converged"] and sr["abs_mu"]:
                    stable = sr["abs_mu"][0] < 1.0
                    dc = decay_check(sr["orbit"], periods=8 if stable else 5, size=1e-6 if stable else 1e-10)
                    sr["decay"] = dc
                    _save(dict(dx=dx, **dc), f"decay_dx{dx:g}", args.save)
                    print(f"- time stepping from the orbit + random perturbation: distance per period "
                          f"{_fmt(dc['defects'])}; ratio {dc['ratio']:.4g} against |mu_1| = {dc['abs_mu1']:.4g}",
                          flush=True)
                out[dx] = (fr, sr)
        if "search" in args.parts:
            rows = []
            for dx in spacings:
                rows += orbit_search(dx)
            _save(dict(rows=rows), "search", args.save)
            print("\n" + table(rows, ["dx", "period", "converged", "nit", "residual", "contacts", "abs_mu", "growth",
                                      "seconds"]), flush=True)
            out["search"] = rows
        if "fold" in args.parts:
            fr = fate(12.0, periods=args.periods)
            base = shoot(12.0, fr["w"], fr["zeta"], fr["t"], tol=args.tol)
            rows = [base]
            for seq in ((12.5, 13.0, 14.0, 16.0), (11.95, 11.9)):
                rows += spacing_continuation(base["orbit"], seq, tol=args.tol)
            _save(dict(rows=[{k: v for k, v in r.items() if k != "orbit"} for r in rows]), "fold", args.save)
            print("\n" + table(rows, ["dx", "converged", "status", "nit", "residual", "maps", "seconds", "contacts",
                                      "abs_mu"]))
            out["fold"] = rows
        if "bench" in args.parts:
            rows = []
            for case in BENCH_CASES:
                br = benchmark(**case)
                br["multipliers"] = case.get("multipliers", False)
                br["section"] = case.get("section", "auto")
                rows.append(br)
                _save(br, "bench_" + "_".join(f"{k}{v}" for k, v in case.items()), args.save)
            print("\n" + table(rows, ["n_nodes", "dx", "step_periods", "step_wall", "step_cpu", "guess_defect",
                                      "multipliers", "section", "converged", "nit", "residual", "maps", "seconds",
                                      "cpu", "contacts", "abs_mu"]))
            for br in rows:
                print(f"\n- dx = {br['dx']:g}, {br['step_periods']} periods: {br['message']}; "
                      f"history {_fmt(br['history'])}")
            out["bench"] = rows
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
