"""``tps-solver simulate``: event-driven FDA runs of a kink, an oscillon or a flat layer."""
import math

NAME = "simulate"
HELP = ("Event-driven FDA (51)-(54): simulate a kink (pinned planar lattice), an oscillon (quasi-log "
        "radial lattice) or a flat layer, with progress per period.")


def configure(parser):
    parser.add_argument("case", choices=["kink", "oscillon", "flat"])
    parser.add_argument("--gamma", type=float, default=2.5, help="plate acceleration Gamma (default 2.5)")
    parser.add_argument("--e", type=float, default=0.45, help="restitution in [0, 1) (default 0.45)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order of the far field (default 2)")
    parser.add_argument("--periods", type=int, default=5, help="number of periods T = 2 pi M (default 5)")
    parser.add_argument("--nodes", type=int, default=None,
                        help="lattice nodes (default 41 kink, 120 oscillon, 11 flat)")
    parser.add_argument("--length", type=float, default=None,
                        help="kink/flat: total length (default 20 / 8); oscillon: r_max (default 20)")
    parser.add_argument("--method", choices=["exact", "ode"], default="exact")
    parser.add_argument("--impact", choices=["point", "diffused"], default="point")
    parser.add_argument("--rho-c", type=float, default=None, help="length of the diffused Stosslet (67)")
    parser.add_argument("--amplitude", type=float, default=1.0,
                        help="oscillon: height of the initial Gaussian bump (default 1)")
    parser.add_argument("--plot", metavar="PNG", default=None,
                        help="draw zeta(t, x) - Z(t) over the last cycles (Fig. 7 style)")


def initial_state(case, fl, args):
    """Lattice, start time and initial state for the chosen case."""
    import numpy as np

    from ..fda import Lattice, flat_state, kink_state

    t0 = fl.t0 + 1.0
    if case == "kink":
        lat = Lattice.planar(n_nodes=args.nodes or 41, length=args.length or 20.0, boundary="pinned")
        w, z = kink_state(lat, fl, t0, width=2.0)
    elif case == "flat":
        lat = Lattice.planar(n_nodes=args.nodes or 11, length=args.length or 8.0)
        w, z = flat_state(lat, fl, t0)
    else:
        lat = Lattice.axisymmetric(n_nodes=args.nodes or 120, r_max=args.length or 20.0, grid="quasilog")
        w, z = flat_state(lat, fl, t0)
        z = z + args.amplitude * np.exp(-lat.nodes ** 2)
    return lat, t0, w, z


def plot(lat, fl, t, Z, path, case):
    """Draw zeta - Z_flat over the recorded times (Agg backend)."""
    import matplotlib
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    rel = Z - fl.height(t)[:, None]
    im = ax.pcolormesh(lat.nodes, t / (2 * math.pi), rel, shading="auto", cmap="viridis")
    fig.colorbar(im, ax=ax, label=r"$\zeta - Z_{\rm flat}$")
    ax.set_xlabel("x" if lat.geometry == "planar" else "r")
    ax.set_ylabel(r"$t / 2\pi$")
    ax.set_title(f"FDA {case}: $\\Gamma$={fl.Gamma:g}, e={fl.e:g}, {lat.n_nodes} nodes, "
                 f"spacing {lat.spacing:.3g}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(args):
    import numpy as np

    from ..fda import simulate
    from ..flat import FlatLayer

    fl = FlatLayer(args.gamma, args.M, e=args.e)
    if args.periods < 1:
        raise ValueError(f"periods must be an integer >= 1, got {args.periods}")
    lat, t, w, z = initial_state(args.case, fl, args)
    T = fl.period
    stuck = None
    print(f"simulate {args.case}: {lat!r}, method {args.method}, Gamma = {fl.Gamma:g}, e = {fl.e:g}, "
          f"M = {fl.M}, far-field t0 = {fl.t0:.6g}")
    keep = min(args.periods, 3)
    times, heights = [], []
    total = 0
    for k in range(args.periods):
        t_eval = t + np.linspace(0.0, T, 65)[1:] if k >= args.periods - keep else None
        res = simulate(lat, fl.Gamma, fl.e, w, z, t_start=t, t_end=t + T, method=args.method,
                       stuck0=stuck, impact=args.impact, rho_c=args.rho_c, t_eval=t_eval)
        total += res.n_events
        kinds = {kd: int(np.count_nonzero(res.events.kind == kd)) for kd in ("impact", "stick", "liftoff")}
        print(f"  period {k + 1:4d}/{args.periods}: t = {res.t:10.4f}, events {res.n_events:6d} "
              f"(impact {kinds['impact']}, stick {kinds['stick']}, liftoff {kinds['liftoff']}), "
              f"stuck nodes {int(np.count_nonzero(res.stuck))}, min zeta {res.zeta.min():.3g}", flush=True)
        if not res.success:
            print(f"  stopped: {res.message}")
            return 1
        if res.t_eval.size:
            times.append(res.t_eval)
            heights.append(res.zeta_eval)
        t, w, z, stuck = res.t, res.w, res.zeta, res.stuck
    print(f"  done: {total} events; cut-off {res.cutoff['kind']} = {res.cutoff['length']:.4g}")
    if args.plot:
        plot(lat, fl, np.concatenate(times), np.vstack(heights), args.plot, args.case)
        print(f"  figure written to {args.plot}")
    return 0
