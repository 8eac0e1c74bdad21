"""``tps-solver branch``: continue a branch of periodic orbits in one parameter and draw it.

Examples
--------
$ tps-solver branch flat --e 0.45 --parameter Gamma --bounds 2.3 3.2 --plot branch.png
$ tps-solver branch cycle --nodes 8 --length 140 --parameter spacing --bounds 8 30 --no-multipliers
"""
import sys

NAME = "branch"
HELP = "Continue periodic orbits (flat layer or exact lattice cycle) in one parameter: folds, period doublings."


def configure(parser):
    parser.add_argument("start", choices=["flat", "cycle"],
                        help="flat: the single-bounce flat layer; cycle: the exact single-contact kink "
                             "cycle of a planar Neumann lattice")
    parser.add_argument("--gamma", type=float, default=2.5, help="plate acceleration Gamma of the start (default 2.5)")
    parser.add_argument("--e", type=float, default=0.45, help="restitution of the start (default 0.45)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order (default 2)")
    parser.add_argument("--parameter", default="Gamma",
                        help="continued parameter: Gamma or e (flat); spacing, Gamma or e (cycle)")
    parser.add_argument("--bounds", type=float, nargs=2, metavar=("LOW", "HIGH"), required=True,
                        help="interval of the parameter")
    parser.add_argument("--nodes", type=int, default=8, help="cycle: lattice nodes (default 8)")
    parser.add_argument("--length", type=float, default=140.0,
                        help="cycle: total lattice length in viscous lengths (default 140: spacing 20)")
    parser.add_argument("--no-multipliers", action="store_true",
                        help="cycle: skip the Floquet multipliers (folds are still found; much faster)")
    parser.add_argument("--one-side", action="store_true", help="follow the branch in one direction only")
    parser.add_argument("--plot", metavar="PNG", default=None, help="draw max|mu| along the branch")
    parser.add_argument("--save", metavar="NPZ", default=None, help="save the branch (.npz)")


def run(args):
    import tps_solver as tps

    from tps_solver.core.checks import check_int, check_positive

    check_positive(args.gamma, "--gamma")
    check_int(args.M, "--M", minimum=1)
    if args.start == "flat":
        start = tps.FlatLayer(args.gamma, args.M, e=args.e)
        multipliers = True
    else:
        nodes = check_int(args.nodes, "--nodes", minimum=3, maximum=400)
        length = check_positive(args.length, "--length")
        lattice = tps.Lattice.planar(n_nodes=nodes, length=length)
        start = tps.solve_lattice_cycle(lattice, Gamma=args.gamma, M=args.M, e=args.e, t0=None)
        if not start.converged:
            print(f"tps-solver branch: error: no single-contact cycle at the start: {start.message}",
                  file=sys.stderr)
            return 1
        multipliers = not args.no_multipliers

    def progress(state):
        verdict = "stability unknown (no multipliers)" if state.stable is None else (
            "stable" if state.stable else "unstable")
        print(f"  point {state.iteration:4d}: {args.parameter} = {state.parameter_value:.10g}  {verdict}",
              flush=True)

    br = tps.continue_branch(start, args.parameter, tuple(args.bounds), bothsides=not args.one_side,
                             multipliers=multipliers, callback=progress)
    print(f"branch of {br.problem} in {br.parameter}: {br.message}")
    for kind, value in br.special_points:
        print(f"  {kind:16s} at {br.parameter} = {value:.12g}")
    if args.save:
        print(f"wrote {br.save(args.save)}")
    if args.plot:
        br.plot(args.plot)
        print(f"wrote {args.plot}")
    return 0 if br.success else 1
