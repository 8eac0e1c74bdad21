"""Shared options and summary of the ``kink`` and ``oscillon`` commands."""
import os

import numpy as np


def flags(geometry):
    """API parameter -> flag of the ``kink`` / ``oscillon`` commands, for error messages."""
    size = "--length" if geometry == "planar" else "--r-max"
    return {"Gamma": "--gamma", "e": "--e", "t0": "--t0", "M": "--M", "n_harmonics": "--N",
            "n_nodes": "--nodes", "length": size, "half_length": size, "r_max": size, "r_core": "--r-core",
            "tol": "--tol", "max_iter": "--max-iter", "scheme": "--scheme", "core_radius": "--r-core",
            "spacing": "--dx", "dx": "--dx"}


def configure(parser, geometry):
    from tps_solver.core import defaults as d

    parser.add_argument("--gamma", type=float, default=None,
                        help=f"plate acceleration Gamma (default {d.GAMMA}; {d.GAMMA_STICK} with --e 0)")
    parser.add_argument("--e", type=float, default=None,
                        help=f"restitution (default {d.E}, a stable interior flat layer, unless --t0 is given)")
    parser.add_argument("--t0", type=float, default=None,
                        help="far-field launch phase instead of --e (the paper's preset 0 is at the fold)")
    parser.add_argument("--M", type=int, default=d.M, help=f"subharmonic order (default {d.M})")
    parser.add_argument("--N", type=int, default=d.N_HARMONICS, help=f"number of harmonics (default {d.N_HARMONICS})")
    parser.add_argument("--nodes", type=int, default=None,
                        help=f"nodes on the half-line / radius of the single-contact TPS (default {d.N_NODES}, "
                             f"spacing {d.SPACING:g}: "
                             "single-contact solutions need spacing above about 11)")
    size = "--length" if geometry == "planar" else "--r-max"
    default_size = d.HALF_LENGTH if geometry == "planar" else d.R_MAX
    parser.add_argument(size, dest="size", type=float, default=None,
                        help=f"half-width (kink) or radius (oscillon) of the domain, in viscous lengths "
                             f"(default {default_size:g}; for --e 0 the lattice's, 20 (kink) or 40 (oscillon))")
    parser.add_argument("--dx", type=float, default=None,
                        help="--e 0 only: spacing of the lattice of the completely inelastic orbit, the "
                             "model's cut-off (default 1)")
    if geometry == "axisymmetric":
        parser.add_argument("--r-core", type=float, default=d.R_CORE,
                            help="core radius of the initial guess, in viscous lengths")
    parser.add_argument("--tol", type=float, default=d.TOL, help="tolerance on max|F| of (46)")
    parser.add_argument("--max-iter", type=int, default=d.MAX_ITER, help="Newton iteration limit")
    parser.add_argument("--scheme", default="newton", choices=["newton", "picard", "paper"],
                        help="iteration: 'newton' (Newton-GMRES with continuation, default), 'picard' or "
                             "'paper' (the paper's fixed-point sweeps)")
    parser.add_argument("--no-continuation", action="store_true", help="plain Newton from the step guess")
    parser.add_argument("--min-shift", action="store_true", help="apply the paper's (64)-(65) (diagnostic)")
    parser.add_argument("--save", metavar="NPZ", default=None,
                        help="save the solution (tps_solver.core.archive format; '.npz' is appended if missing)")
    parser.add_argument("--plot", metavar="DIR", default=None,
                        help="write the figures (space-time maps of zeta and w - W, snapshots) to DIR "
                             "(created if missing; its parent must exist)")


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


def stick_summary(sol, what):
    """Return the text summary of an e = 0 result (a StickSolution)."""
    fda = sol.get("fda_check")
    mu = sol.get("multipliers")
    lines = [
        f"{what} (e = 0): Gamma = {sol.Gamma:g}, M = {sol.M}, lattice of {sol.nodes.size} nodes, "
        f"spacing {sol.get('spacing', float('nan')):g}",
        f"  converged?            {sol.converged} (status {sol.status})",
        f"  message               {sol.message}",
        f"  formulation           {sol.get('formulation', '')}",
        f"  residual max|F|       {sol.residual:.3e}",
        f"  localized             {sol.get('localized')}",
        f"  far field stable      {sol.get('far_field_stable')}",
    ]
    if mu is not None and len(mu):
        lines.append(f"  leading |multipliers| {', '.join(f'{abs(m):.6f}' for m in mu[:4])}; stable by them: "
                     f"{bool(abs(mu[0]) < 1.0)}")
    else:
        lines.append("  multipliers           not computed (stability unknown)")
    if fda is not None:
        lines.append(f"  FDA check             passed = {fda.passed} over {fda.periods} periods "
                     f"(event error {max(fda.contact_error, fda.liftoff_error):.2e}, state defect "
                     f"{fda.state_defect:.2e})")
    seconds = sol.get("seconds")
    if seconds is not None:
        lines.append("  wall time             " + ", ".join(f"{k} {v:.2f} s" for k, v in seconds.items()))
    lines.append(f"  all checks            {sol.checks.all_pass}")
    return "\n".join(lines)


def _inelastic(args, geometry, bar):
    """``--e 0``: the completely inelastic orbit on a lattice (solve_kink / solve_oscillon with lattice=)."""
    from tps_solver.core.checks import check_int, check_positive
    from tps_solver.core.defaults import R_CORE
    from tps_solver.operators.lattice import Lattice
    from tps_solver.solvers import tps

    given = [flag for flag, value, default in (("--t0", args.t0, None), ("--nodes", args.nodes, None),
                                                ("--no-continuation", args.no_continuation, False),
                                                ("--min-shift", args.min_shift, False)) if value != default]
    if given:
        raise ValueError(f"{given[0]} applies to the single-contact TPS (e > 0); the e = 0 orbit is solved "
                         "on a lattice (give --dx and --length / --r-max)")
    dx = 1.0 if args.dx is None else check_positive(args.dx, "dx")
    kw = dict(Gamma=args.gamma, M=args.M, e=0.0, n_harmonics=args.N, scheme=args.scheme, tol=args.tol,
              max_iter=args.max_iter, callback=bar)
    if geometry == "planar":
        half = 20.0 if args.size is None else check_positive(args.size, "half_length")
        n = check_int(int(round(2.0 * half / dx)) + 1, "--length/--dx (number of nodes)", minimum=3, maximum=2001)
        return tps.solve_kink(lattice=Lattice.planar(n_nodes=n, length=2.0 * half), **kw)
    r_max = 40.0 if args.size is None else check_positive(args.size, "r_max")
    n = check_int(int(round(r_max / dx)) + 1, "--r-max/--dx (number of nodes)", minimum=3, maximum=2001)
    if args.r_core != R_CORE:
        kw["r_core"] = args.r_core
    return tps.solve_oscillon(lattice=Lattice.axisymmetric(n_nodes=n, r_max=r_max, grid="uniform"), **kw)


def run(args, geometry):
    from tps_solver.solvers import tps

    from tps_solver._commands._output import figure_directory, result_path
    from tps_solver.core import defaults as d

    npz = result_path(args.save) if args.save else None
    plot_dir = figure_directory(args.plot) if args.plot else None
    e, t0 = args.e, args.t0              # neither given: the solvers' default model (tps_solver.core.defaults)
    inelastic = e is not None and e == 0.0 and t0 is None
    what = "kink" if geometry == "planar" else "oscillon"
    from tps_solver.core.progress import Progress

    if inelastic:
        with Progress(f"{what} (e = 0)") as bar:
            sol = _inelastic(args, geometry, bar)
        print(stick_summary(sol, what))
    else:
        if args.dx is not None:
            raise ValueError("--dx applies to --e 0 only (the lattice of the completely inelastic orbit); "
                             "the single-contact TPS takes --nodes and " + ("--length" if geometry == "planar"
                                                                            else "--r-max"))
        size = args.size if args.size is not None else (d.HALF_LENGTH if geometry == "planar" else d.R_MAX)
        nodes = d.N_NODES if args.nodes is None else args.nodes
        common = dict(Gamma=args.gamma, M=args.M, e=e, t0=t0, n_harmonics=args.N, n_nodes=nodes,
                      tol=args.tol, max_iter=args.max_iter, scheme=args.scheme,
                      continuation=not args.no_continuation, min_shift=args.min_shift)
        with Progress(f"{what} TPS") as bar:
            common["callback"] = bar
            if geometry == "planar":
                sol = tps.solve_kink(length=size, **common)
            else:
                sol = tps.solve_oscillon(r_max=size, r_core=args.r_core, **common)
        print(summary(sol))
    if npz:
        print(f"  saved to {sol.save(npz)}")
    if plot_dir:
        from tps_solver.plotting import plot_solution

        os.makedirs(plot_dir, exist_ok=True)
        for path in plot_solution(sol, plot_dir):
            print(f"  figure {path}")
    return 0 if sol.converged else 1
