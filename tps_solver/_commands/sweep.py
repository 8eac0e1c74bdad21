"""``tps-solver sweep``: parameter sweeps on a process pool (or Dask), resumable, with a map figure.

Examples
--------
$ tps-solver sweep basins --gamma 2.4 4.6 0.2 --e 0 0.45 0.15 --samples 32 --workers 2 --plot basins.png
"""
NAME = "sweep"
HELP = ("Sweep (Gamma, e): per point, the fraction of random starts of one node (the ball) that reach a "
        "period-M attractor (any contact pattern), on a process pool; writes a map.")


def configure(parser):
    parser.add_argument("study", choices=["basins"], help="basins: f/M basin fraction of one node (the ball)")
    parser.add_argument("--gamma", type=float, nargs=3, metavar=("START", "STOP", "STEP"), required=True,
                        help="Gamma grid (inclusive)")
    parser.add_argument("--e", type=float, nargs=3, metavar=("START", "STOP", "STEP"), required=True,
                        help="restitution grid (inclusive)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order of the flat orbit (default 2)")
    parser.add_argument("--samples", type=int, default=32, help="random initial states per point (default 32)")
    parser.add_argument("--model", choices=["point", "soft"], default="point",
                        help="contact model of the ball (default point)")
    parser.add_argument("--cutoff", type=float, default=None, help="soft-contact length (with --model soft)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the initial states (default 0)")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--serial", action="store_true", help="run in this process (no pool)")
    parser.add_argument("--store", metavar="DIR", default=None,
                        help="directory that keeps finished points; a rerun skips them")
    parser.add_argument("--plot", metavar="PNG", default=None, help="draw the map")


def basin_point(Gamma, e, M, samples, model, cutoff, seed):
    """One map point: the f/M basin fraction of the ball and its binomial error (a picklable task)."""
    from tps_solver.analyses.basins import flat_basins

    res = flat_basins(Gamma, e, M=M, n_samples=samples, seed=seed, model=model, cutoff=cutoff)
    return {"flat_fraction": float(res.flat_fraction), "flat_stderr": float(res.flat_stderr),
            "n_attractors": len(res.attractors), "status": int(res.status)}


def run(args):
    import sys

    import numpy as np

    import tps_solver as tps

    from tps_solver.core.checks import check_int
    from tps_solver.analyses.sweep import param_range

    gammas = param_range(*args.gamma, name="--gamma")
    es = param_range(*args.e, name="--e")
    samples = check_int(args.samples, "--samples", minimum=1, maximum=100000)
    if args.model == "soft" and args.cutoff is None:
        raise ValueError("--cutoff must be given with --model soft (a length > 0)")
    if args.model == "point" and args.cutoff is not None:
        raise ValueError("--cutoff applies only to --model soft")
    params = [dict(Gamma=G, e=e, M=args.M, samples=samples, model=args.model, cutoff=args.cutoff,
                   seed=args.seed) for e in es for G in gammas]
    executor = "serial" if args.serial else None
    results = tps.sweep(basin_point, params, executor=executor, store=args.store,
                        max_workers=args.workers, progress=True)
    failed = list(getattr(results, "failed", []))
    for i in failed:
        print(f"  point {params[i]} failed: {results[i].error}", file=sys.stderr)
    frac = np.array([np.nan if i in failed else r["flat_fraction"] for i, r in enumerate(results)]
                    ).reshape(len(es), len(gammas))
    print(f"fraction of random starts of one node reaching a period-{args.M} (f/{args.M}) attractor of any contact "
          f"pattern -- not only the flat layer's single-bounce orbit -- ({args.model} contact, {samples} samples "
          "per point)")
    print("  e \\ Gamma " + " ".join(f"{G:7.3f}" for G in gammas))
    for e, row in zip(es, frac):
        print(f"  {e:9.3f} " + " ".join(f"{v:7.3f}" for v in row))
    if args.plot:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        im = ax.pcolormesh(gammas, es, frac, vmin=0.0, vmax=1.0, shading="nearest", cmap="viridis")
        fig.colorbar(im, ax=ax, label=f"fraction of starts on a period-{args.M} attractor (dimensionless)")
        ax.set_xlabel(r"$\Gamma = A\omega^2/g$")
        ax.set_ylabel("restitution $e$")
        ax.set_title(f"one node: fraction of random starts reaching any f/{args.M} (period-{args.M}) attractor\n"
                     f"(any contact pattern, not only the flat single-bounce orbit), M = {args.M}, "
                     f"{args.model} contact, {samples} samples/point", fontsize=9)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=130)
        print(f"wrote {args.plot}")
    return 0
