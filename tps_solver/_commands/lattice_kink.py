"""``tps-solver lattice-kink``: a periodic kink of any contact pattern on a planar lattice (settle, then shoot).

Examples
--------
$ tps-solver lattice-kink --gamma 4.1 --e 0 --dx 2 --length 40
$ tps-solver lattice-kink --gamma 2.5 --e 0.45 --cutoff 0.3 --dx 12 --length 132
"""

NAME = "lattice-kink"
HELP = ("Periodic kink on a planar Neumann lattice by time stepping and Newton-Krylov shooting, any contact "
        "pattern (e = 0 sticking kinks, soft contact): residual, contacts per node, multipliers, front width.")


def configure(parser):
    parser.add_argument("--gamma", type=float, default=4.1, help="plate acceleration Gamma (default 4.1)")
    parser.add_argument("--e", type=float, default=0.0, help="restitution in [0, 1) (default 0)")
    parser.add_argument("--M", type=int, default=2, help="even subharmonic order (default 2)")
    parser.add_argument("--dx", type=float, default=2.0, help="lattice spacing (default 2)")
    parser.add_argument("--length", type=float, default=40.0, help="lattice length, front at x = 0 (default 40)")
    parser.add_argument("--cutoff", type=float, default=None, help="soft-contact length (default: point impacts)")
    parser.add_argument("--periods", type=int, default=10, help="settling periods before Newton (default 10)")
    parser.add_argument("--max-iter", type=int, default=80, help="Newton steps (default 80)")
    parser.add_argument("--multipliers", type=int, default=4, help="leading multipliers to report (default 4)")


def run(args):
    import numpy as np

    import tps_solver as tps

    from tps_solver.core.checks import check_int, check_positive

    dx = check_positive(args.dx, "--dx")
    length = check_positive(args.length, "--length")
    n = int(round(length / dx)) + 1
    check_int(n, "--length/--dx (number of nodes)", minimum=3, maximum=2000)
    lat = tps.Lattice.planar(n_nodes=n, length=length)

    shown = {"settle": -1}

    def progress(state):
        """Settling runs report the fraction of their periods, shooting its Newton steps (by stage)."""
        if state.stage == "simulate":
            tenth = int(10 * state.fraction) if np.isfinite(state.fraction) else -1
            if tenth > shown["settle"]:
                shown["settle"] = tenth
                print(f"  settling: {10 * tenth:3d} % of {args.periods} periods", flush=True)
            return
        label = "Newton (mirrored half period)" if state.get("symmetric") else "Newton"
        print(f"  {label} {state.iteration:3d}: max|P(x) - x| = {state.residual:.3e}", flush=True)

    print(f"lattice kink: Gamma = {args.gamma:g}, e = {args.e:g}, M = {args.M}, {n} nodes, dx = {dx:g}, "
          f"{'soft contact, cutoff = %g' % args.cutoff if args.cutoff else 'point impacts'}", flush=True)
    orb = tps.lattice_kink(lat, Gamma=args.gamma, M=args.M, e=args.e, cutoff=args.cutoff, periods=args.periods,
                           max_iter=args.max_iter, n_multipliers=max(args.multipliers, 1), callback=progress)
    print(f"  {orb.message}")
    counts = dict(zip(*[a.tolist() for a in np.unique(orb.contacts_per_node, return_counts=True)]))
    print(f"  converged = {orb.converged}, localized = {orb.localized}, residual = {orb.residual:.3e}, "
          f"Newton steps = {orb.nit}, period maps = {orb.n_period_maps}")
    print(f"  contacts per node and period (count: nodes) = {counts}; sticking nodes = "
          f"{len({iv[0] for iv in orb.sticking_intervals})}/{n}")
    if orb.converged and len(orb.multipliers):
        mu = orb.multipliers[:args.multipliers]
        print("  leading |multipliers| = " + ", ".join(f"{abs(m):.6f}" for m in mu)
              + f"  ({orb.multipliers_kind}); stable = {bool(abs(mu[0]) < 1.0)}")
    if orb.converged and orb.localized:
        wl, wr = tps.front_width(orb)
        print(f"  10-90 % front width = {wl:.6g} (left far field highest), {wr:.6g} (right)")
    return 0 if orb.converged else 1
