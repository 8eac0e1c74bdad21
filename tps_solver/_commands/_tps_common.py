"""Shared options and summary of the ``kink`` and ``oscillon`` commands."""
import math
import os

import numpy as np


def configure(parser, geometry):
    parser.add_argument("--gamma", type=float, default=2.5, help="plate acceleration Gamma (default 2.5)")
    parser.add_argument("--e", type=float, default=None, help="restitution; default: the paper preset t0 = 0")
    parser.add_argument("--t0", type=float, default=None, help="far-field launch phase (paper preset: 0)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order (default 2)")
    parser.add_argument("--N", type=int, default=30, help="number of harmonics (default 30)")
    parser.add_argument("--nodes", type=int, default=120, help="nodes on the half-line / radius (default 120)")
    size = "--length" if geometry == "planar" else "--r-max"
    parser.add_argument(size, dest="size", type=float, default=12.0,
                        help="half-width (kink) or radius (oscillon) of the domain (default 12)")
    if geometry == "axisymmetric":
        parser.add_argument("--r-core", type=float, default=1.0, help="core radius of the initial guess")
    parser.add_argument("--tol", type=float, default=1e-10, help="tolerance on max|F| of (46)")
    parser.add_argument("--max-iter", type=int, default=50)
    parser.add_argument("--scheme", default="newton", choices=["newton", "picard", "paper"])
    parser.add_argument("--no-continuation", action="store_true", help="plain Newton from the step guess")
    parser.add_argument("--min-shift", action="store_true", help="apply the paper's (64)-(65) (diagnostic)")
    parser.add_argument("--save", metavar="NPZ", default=None, help="save the solution (.npz)")
    parser.add_argument("--plot", metavar="DIR", default=None, help="write surface and polar figures to DIR")


def summary(sol):
    """Return the text summary of a PeriodicSolution."""
    c = sol.checks
    T = sol.period
    dist = lambda a, b: np.abs(np.mod(a - b + T / 2, T) - T / 2)
    d_far, d_shift = dist(sol.tc, sol.t0), dist(sol.tc, sol.t0 + T / 2)
    x = np.abs(sol.nodes)
    if sol.geometry == "planar":
        # the transition zone: nodes off both flat phases (by more than 1e-3 T)
        off = np.minimum(d_far, d_shift) > 1e-3 * T
        size_label = "front half-width (tc off both flat phases by > T/1000)"
    else:
        off = d_shift < d_far
        size_label = "core radius (tc nearer t0 + T/2)"
    width = float(np.max(x[off])) if np.any(off) else 0.0
    lines = [
        f"{'kink' if sol.geometry == 'planar' else 'oscillon'}: Gamma = {sol.Gamma:g}, M = {sol.M}, "
        f"e = {sol.e:.6g}, t0 = {sol.t0:.6g}, N = {sol.N}, nodes = {sol.nodes.size}, scheme = {sol.scheme}",
        f"  converged?            {sol.converged} (status {sol.status})",
        f"  message               {sol.message}",
        f"  iterations            {sol.nit}",
        f"  residual max|F|       {sol.residual:.3e}",
        f"  wall time             {sol.time:.3f} s",
        f"  coupling reached      {sol.coupling:.6g} (node spacing {sol.spacing:.4g})",
        f"  min zeta              {c.min_zeta:.3e}  (zeta >= 0: {c.zeta_nonnegative})",
        f"  single contact        {c.single_contact} (max contacts per period {int(np.max(c.contacts_per_period))})",
        f"  tc is steep crossing  {bool(np.all(c.tc_is_steep_crossing))} "
        f"({int(np.sum(~c.tc_is_steep_crossing))} node(s) fail)",
        f"  restitution residual  {c.restitution_residual:.3e} (max |measured jump / (T/Gamma) - 1|)",
        f"  all physical checks   {c.all_pass}",
        f"  {size_label}   {width:.4g}",
    ]
    if sol.min_shift:
        lines.append("  NOTE: zeta was min-shifted by (64)-(65); this is not a solution of the contact problem")
    return "\n".join(lines)


def run(args, geometry):
    from .. import tps

    e, t0 = args.e, args.t0
    if e is None and t0 is None:
        t0 = 0.0
    common = dict(Gamma=args.gamma, M=args.M, e=e, t0=t0, n_harmonics=args.N, n_nodes=args.nodes,
                  tol=args.tol, max_iter=args.max_iter, scheme=args.scheme,
                  continuation=not args.no_continuation, min_shift=args.min_shift)
    if geometry == "planar":
        sol = tps.solve_kink(length=args.size, **common)
    else:
        sol = tps.solve_oscillon(r_max=args.size, r_core=args.r_core, **common)
    print(summary(sol))
    if args.save:
        sol.save(args.save)
        print(f"  saved to {args.save}")
    if args.plot:
        from ..plotting import plot_solution

        os.makedirs(args.plot, exist_ok=True)
        for path in plot_solution(sol, args.plot):
            print(f"  figure {path}")
    return 0 if sol.converged else 1
