"""One period map of the e = 0 sticking kink: whole-free-set modes against run modes, side by side.

The kink at Gamma = 4.1, e = 0 (M = 2) on planar Neumann lattices of length 40 (every node lands,
sticks and lifts off: 4n - 2 events per period), settled for ``--settle`` periods from
``kink_state`` (a quarter period after the far field's lift-off, width 2), then one period map
(:class:`~tps_solver.solvers.shooting.period_map.PeriodMap`, ``method="exact"``) from the settled
state with

* ``free_set``: ``modes="free_set"``, one dense eigendecomposition per free set (the old path);
* ``runs``: ``modes="runs"``, closed-form run modes (:mod:`tps_solver.solvers.fda.runs`), with the
  compiled kernels when numba is installed.  Its decompositions are kept per lattice across period
  maps (as in a shooting run); ``runs s, cold`` is one map after dropping them
  (``clear_caches``), the other columns the minimum over repeats.

CPU time (``time.process_time``), one BLAS thread, minimum over ``--repeat`` interleaved runs.
Printed: seconds per period map, events per period, the scaling exponent between consecutive
sizes, the ratio, and the largest difference of the event times of the two paths (same nodes
and kinds required).

Run (from the repository root)::

    OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/period_map_benchmark.py [--sizes 41 81 161 321 641]
        [--old-max 321] [--repeat 3]

Before -> after of the run path against another checkout of the library (e.g. the commit before a
change, ``git archive <commit> | tar -x -C /tmp/base``): ``--baseline /tmp/base`` times the run path
(``modes="runs"``, default kernels) of both trees in fresh processes, interleaved ``--repeat`` times,
and prints the minimum CPU seconds per period map of each and their ratio::

    OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/period_map_benchmark.py --baseline /tmp/base
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

import tps_solver as tps
from tps_solver.solvers.fda.runs import clear_caches
from tps_solver.solvers.fda.states import kink_state
from tps_solver.solvers.shooting.period_map import PeriodMap

GAMMA, LENGTH = 4.1, 40.0


def settled_map(n, settle):
    """The period map (both paths) and the settled state ``x`` of the kink on ``n`` nodes."""
    fl = tps.FlatLayer(GAMMA, 2, e=0.0)
    lat = tps.Lattice.planar(n_nodes=n, length=LENGTH)
    t0 = float(fl.t0 + 0.25 * fl.period)
    w, z = kink_state(lat, fl, t0, width=2.0)
    r = tps.simulate(lat, GAMMA, 0.0, w, z, t_start=t0, t_end=t0 + settle * fl.period, modes="runs")
    maps = {mode: PeriodMap(lat, GAMMA, 0.0, fl.period, r.t, stuck=r.stuck, method="exact", modes=mode)
            for mode in ("free_set", "runs")}
    return maps, maps["runs"].pack(r.w, r.zeta)


def worker(sizes, settle, repeat=3):
    """Minimum CPU seconds of the run-path period map per size, in this process's library (printed as JSON)."""
    out = {}
    with threadpool_limits(1):
        for n in sizes:
            maps, x = settled_map(n, settle)
            m = maps["runs"]
            m.run(x)                # compile and fill the run caches, as in a shooting run
            best = np.inf
            for _ in range(repeat):
                tic = time.process_time()
                r = m.run(x)
                best = min(best, time.process_time() - tic)
            out[n] = (best, int(r.events.size))
    print(json.dumps(out))


def compare(baseline, sizes, settle, repeat):
    """Interleaved fresh processes of this tree and ``baseline``: a before -> after table of the run path."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    trees = {"before": os.path.abspath(baseline), "after": here}
    best = {k: {} for k in trees}
    for _ in range(repeat):
        for key, tree in trees.items():
            env = dict(os.environ, PYTHONPATH=tree, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
            cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--settle", str(settle), "--sizes",
                   *map(str, sizes)]
            res = json.loads(subprocess.run(cmd, env=env, capture_output=True, text=True, check=True,
                                            cwd=tree).stdout.strip().splitlines()[-1])
            for n, (t, ev) in res.items():
                old = best[key].get(int(n), (np.inf, ev))
                best[key][int(n)] = (min(old[0], t), ev)
        print("round done", flush=True)
    print(f"\n| nodes | events / period | runs s, before | runs s, after | ratio |")
    print("|---|---|---|---|---|")
    for n in sizes:
        (b, ev), (a, ev2) = best["before"][n], best["after"][n]
        print(f"| {n} | {ev2}{'' if ev == ev2 else f' (before: {ev})'} | {b:.3f} | {a:.3f} | {b / a:.2f} |")
    for key in trees:
        sel = [n for n in sizes if n >= 81]
        if len(sel) >= 2:
            t0, t1 = best[key][sel[0]][0], best[key][sel[-1]][0]
            print(f"exponent {key} from {sel[0]} to {sel[-1]} nodes: {math.log(t1 / t0) / math.log(sel[-1] / sel[0]):.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default=None, help="another checkout: before -> after of the run path")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", type=int, nargs="+", default=[41, 81, 161, 321, 641])
    parser.add_argument("--old-max", type=int, default=321, help="largest size timed on the old path")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--settle", type=int, default=4)
    parser.add_argument("--accuracy-max", type=int, default=161,
                        help="largest size of the 10-period comparison of the event times")
    args = parser.parse_args()
    if args.worker:
        return worker(args.sizes, args.settle)
    if args.baseline is not None:
        return compare(args.baseline, args.sizes, args.settle, args.repeat)
    rows, acc = [], {}
    with threadpool_limits(1):
        for n in args.sizes:
            maps, x = settled_map(n, args.settle)
            modes = ("free_set", "runs") if n <= args.old_max else ("runs",)
            best, runs = {}, {}
            clear_caches()          # a cold map: no run decomposition kept from the settling run
            tic = time.process_time()
            maps["runs"].run(x)
            cold = time.process_time() - tic
            for _ in range(args.repeat):
                for mode in modes:
                    tic = time.process_time()
                    runs[mode] = maps[mode].run(x)
                    best[mode] = min(best.get(mode, np.inf), time.process_time() - tic)
            b = runs["runs"].events
            dt = float("nan")
            if "free_set" in runs:
                a = runs["free_set"].events
                if a.size == b.size and np.array_equal(a.node, b.node) and np.array_equal(a.kind, b.kind):
                    dt = float(np.max(np.abs(a.t - b.t)))
                else:
                    dt = float("inf")
            if n <= args.accuracy_max:
                ten = [maps[mode].run(x, periods=10).events for mode in ("free_set", "runs")]
                same = ten[0].size == ten[1].size and np.array_equal(ten[0].node, ten[1].node) \
                    and np.array_equal(ten[0].kind, ten[1].kind)
                acc[n] = (ten[1].size, float(np.max(np.abs(ten[0].t - ten[1].t))) if same else float("inf"))
            rows.append((n, best.get("free_set", float("nan")), best["runs"], int(b.size), dt, cold))
            print(f"n = {n}: done ({best})", flush=True)
    print("\n| nodes | events / period | free_set s | runs s | runs s, cold | ratio | exponent free_set "
          "| exponent runs | max dt of events |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i, (n, old, new, ev, dt, cold) in enumerate(rows):
        if i:
            n0, old0, new0 = rows[i - 1][:3]
            e_old = math.log(old / old0) / math.log(n / n0)
            e_new = math.log(new / new0) / math.log(n / n0)
        else:
            e_old = e_new = float("nan")
        print(f"| {n} | {ev} | {old:.3f} | {new:.3f} | {cold:.3f} | {old / new:.1f} | {e_old:.2f} | {e_new:.2f} "
              f"| {dt:.1e} |")
    for n, (k, d) in acc.items():
        print(f"\n{n} nodes, 10 periods from the settled state: {k} events, same nodes and kinds, "
              f"max |t_free_set - t_runs| = {d:.1e}")
    if len(rows) > 2:
        sel = [r for r in rows if r[0] >= 81]
        if len(sel) >= 2:
            (n0, _, t0, *_), (n1, _, t1, *_) = sel[0], sel[-1]
            print(f"\nexponent of runs from {n0} to {n1} nodes: {math.log(t1 / t0) / math.log(n1 / n0):.2f}")


if __name__ == "__main__":
    main()
