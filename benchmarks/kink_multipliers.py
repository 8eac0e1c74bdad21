"""The multiplier stage of `lattice_kink`: mirrored half-period map against the period map.

The e = 0 kink (Gamma 4.1, planar Neumann lattice of length 40) solved by `tps.lattice_kink`
twice side by side per lattice: with ``multiplier_map="period"`` (the period map: one-sided
Arnoldi of dimension 20 after a differentiability test of 4 maps, the path before) and with the
default (``"auto"``: the mirrored half-period map G, central differences, Arnoldi stopped at
convergence, mu = lambda_G^2).  Prints per lattice the whole solve time, the multiplier-stage
time and its periods of the FDA (minimum over repeats), and the leading multipliers of both.
A dense central-difference period-map Jacobian (step 1e-5) is the accuracy reference where
affordable (``--dense``, 41 nodes by default).

Run (one BLAS thread):

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/kink_multipliers.py --nodes 41 81 161 --repeats 2
"""
import argparse
import sys
import time

import numpy as np

import tps_solver as tps


def solve(lat, mode):
    kw = {} if mode == "new" else {"multiplier_map": "period"}
    t = time.perf_counter()
    orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, **kw)
    return time.perf_counter() - t, orb


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[41, 81, 161])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--dense", type=int, nargs="*", default=[41], help="node counts with the dense reference")
    args = ap.parse_args(argv)
    rows = []
    for n in args.nodes:
        lat = tps.Lattice.planar(n_nodes=n, length=40.0)
        best = {}
        for rep in range(args.repeats if n < 161 else 1):
            for mode in ("old", "new"):
                dt, orb = solve(lat, mode)
                if mode not in best or dt < best[mode][0]:
                    best[mode] = (dt, orb)
        (t_old, o_old), (t_new, o_new) = best["old"], best["new"]
        k = min(o_old.multipliers.size, o_new.multipliers.size, 4)
        diff = float(np.max(np.abs(o_old.multipliers[:k] - o_new.multipliers[:k]))) if k else float("nan")
        ref_diff = float("nan")
        if n in args.dense and o_new.converged:
            o_ref = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, guess=o_new, multiplier_map="period",
                                            dense_max=10 ** 6, jacobian_step=1e-5)
            mu = o_ref.multipliers[:k]
            ref_diff = (float(np.max(np.abs(o_old.multipliers[:k] - mu))),
                        float(np.max(np.abs(o_new.multipliers[:k] - mu))))
        rows.append((n, t_old, t_new, o_old.multiplier_time, o_new.multiplier_time, o_old.multiplier_periods,
                     o_new.multiplier_periods, o_new.multipliers_map, diff, ref_diff,
                     o_old.multipliers[:k], o_new.multipliers[:k]))
        r = rows[-1]
        print(f"nodes {n}: whole solve {r[1]:.2f} s -> {r[2]:.2f} s ({r[1] / r[2]:.2f}x); multiplier stage "
              f"{r[3]:.2f} s -> {r[4]:.2f} s ({r[3] / r[4]:.2f}x), {r[5]:g} -> {r[6]:g} periods of the FDA "
              f"(new via {r[7]}); stage share {r[3] / r[1]:.0%} -> {r[4] / r[2]:.0%}", flush=True)
        print(f"   leading multipliers old {np.round(r[10].real, 9).tolist()}", flush=True)
        print(f"   leading multipliers new {np.round(r[11].real, 9).tolist()}", flush=True)
        print(f"   max |old - new| (leading {k}) = {diff:.2e}; against the dense central-difference period map "
              f"(step 1e-5): old {ref_diff if np.isscalar(ref_diff) else ref_diff[0]:.2e}, new "
              f"{ref_diff if np.isscalar(ref_diff) else ref_diff[1]:.2e}", flush=True)
    print()
    print("| nodes | whole solve old -> new (s) | multiplier stage old -> new (s) | periods old -> new | "
          "max abs(mu_old - mu_new), leading 4 |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.2f} -> {r[2]:.2f} | {r[3]:.2f} -> {r[4]:.2f} | {r[5]:g} -> {r[6]:g} | {r[8]:.1e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
