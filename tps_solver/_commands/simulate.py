"""``tps-solver simulate``: event-driven FDA runs of a kink, an oscillon or a flat layer.

Examples
--------
$ tps-solver simulate flat --periods 2 --nodes 5
$ tps-solver simulate kink --method soft --cutoff 0.5 --periods 1 --nodes 21
"""
import math

NAME = "simulate"
HELP = ("Event-driven FDA (51)-(54): simulate a kink (pinned planar lattice), an oscillon (quasi-log "
        "radial lattice) or a flat layer, with progress per period.")

#: Default lattice per case: (nodes, length or r_max).
LATTICE_DEFAULTS = {"kink": (41, 20.0), "flat": (11, 8.0), "oscillon": (120, 20.0)}
#: API parameter -> flag, for error messages.
FLAGS = {"n_nodes": "--nodes", "length": "--length", "r_max": "--length", "Gamma": "--gamma", "e": "--e",
         "M": "--M", "periods": "--periods", "rho_c": "--rho-c", "cutoff": "--cutoff", "impact": "--impact",
         "method": "--method", "amplitude": "--amplitude"}


def _method_help():
    from tps_solver.solvers.fda import METHODS

    return ("FDA integrator, a key of tps_solver.METHODS: 'exact' (point impacts, closed-form modal "
            "propagation (55)-(56), the default), 'ode' (point impacts, the paper's Method 2 with a scipy "
            "ODE solver), 'soft' (the soft contact of length --cutoff, the well-posed model: results "
            "converge under grid refinement; 'soft-radau' is the same integrator); choices: "
            + ", ".join(sorted(METHODS)))


def configure(parser):
    from tps_solver.solvers.fda import METHODS

    parser.add_argument("case", choices=["kink", "oscillon", "flat"],
                        help="initial state: a kink (pinned planar lattice), a Gaussian bump on the flat "
                             "layer (oscillon, radial lattice) or the flat layer itself")
    parser.add_argument("--gamma", type=float, default=2.5, help="plate acceleration Gamma (default 2.5)")
    parser.add_argument("--e", type=float, default=0.45, help="restitution in [0, 1) (default 0.45)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order of the far field (default 2)")
    parser.add_argument("--periods", type=int, default=5, help="number of periods T = 2 pi M (default 5)")
    parser.add_argument("--nodes", type=int, default=None,
                        help="lattice nodes, >= 3 (default 41 kink, 120 oscillon, 11 flat)")
    parser.add_argument("--length", type=float, default=None,
                        help="kink/flat: total length in viscous lengths (default 20 / 8); oscillon: r_max "
                             "(default 20); > 0")
    parser.add_argument("--method", choices=sorted(METHODS), default="exact", help=_method_help())
    parser.add_argument("--cutoff", type=float, default=None,
                        help="length l of the soft contact, > 0; required with --method soft (and only used there)")
    parser.add_argument("--impact", choices=["point", "diffused"], default="point",
                        help="impact rule of the point-impact methods: 'point' (Newton's rule (11) at each "
                             "node, the cut-off is the lattice spacing) or 'diffused' (the paper's Stosslet "
                             "(67) of length --rho-c); not used by --method soft")
    parser.add_argument("--rho-c", type=float, default=None, help="length of the diffused Stosslet (67), > 0")
    parser.add_argument("--amplitude", type=float, default=1.0,
                        help="oscillon: height of the initial Gaussian bump (default 1)")
    parser.add_argument("--plot", metavar="PNG", default=None,
                        help="draw zeta(t, x) - Z(t) over the last cycles (Fig. 7 style); '.png' is appended "
                             "to a name without extension")


def initial_state(case, fl, args):
    """Lattice, start time and initial state for the chosen case."""
    import numpy as np

    from tps_solver.solvers.fda import Lattice, flat_state, kink_state

    n_default, size_default = LATTICE_DEFAULTS[case]
    n = n_default if args.nodes is None else args.nodes
    size = size_default if args.length is None else args.length
    t0 = fl.t0 + 1.0
    if case == "kink":
        lat = Lattice.planar(n_nodes=n, length=size, boundary="pinned")
        w, z = kink_state(lat, fl, t0, width=2.0)
    elif case == "flat":
        lat = Lattice.planar(n_nodes=n, length=size)
        w, z = flat_state(lat, fl, t0)
    else:
        lat = Lattice.axisymmetric(n_nodes=n, r_max=size, grid="quasilog")
        w, z = flat_state(lat, fl, t0)
        z = z + args.amplitude * np.exp(-lat.nodes ** 2)
    return lat, t0, w, z


def plot(lat, fl, t, Z, path, case, method="exact", cutoff=None):
    """Draw zeta - Z_flat over the recorded times to ``path``; returns the Figure (closed).

    Colour carries zeta - Z_flat in plate amplitudes; a difference that is round-off
    (below 1e-9 of the layer's height scale) is drawn on a fixed scale and labelled so,
    not stretched to fill the colour map.
    """
    import matplotlib.pyplot as plt
    import numpy as np

    rel = Z - fl.height(t)[:, None]
    scale = max(1.0, float(np.max(np.abs(Z))))
    amp = float(np.max(np.abs(rel))) if rel.size else 0.0
    roundoff = amp <= 1e-9 * scale
    vmax = 1e-9 * scale if roundoff else amp
    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="constrained")
    im = ax.pcolormesh(lat.nodes, t / (2 * math.pi), rel, shading="nearest", cmap="RdBu_r",
                       vmin=-vmax, vmax=vmax)
    fig.colorbar(im, ax=ax, label=r"$\zeta - Z_{\rm flat}$ (plate amplitudes)")
    space = "x" if lat.geometry == "planar" else "r"
    ax.set_xlabel(f"${space}$ (viscous lengths)")
    ax.set_ylabel(r"$t\,\omega / 2\pi$ (forcing cycles)")
    law = f"method {method}" if cutoff is None else f"method {method}, soft-contact cut-off {cutoff:g}"
    ax.set_title(f"FDA {case}: $\\Gamma$ = {fl.Gamma:g}, e = {fl.e:g}, M = {fl.M}, {lat.n_nodes} nodes "
                 f"(spacing {lat.spacing:.3g}), {law}", fontsize=9)
    if roundoff:
        ax.text(0.5, 0.5, f"$\\zeta = Z_{{\\rm flat}}$ to round-off\n(max $|\\zeta - Z_{{\\rm flat}}|$ = {amp:.1e})",
                transform=ax.transAxes, ha="center", va="center", fontsize=10,
                bbox=dict(boxstyle="round", facecolor="white", alpha=0.8))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


def run(args):
    import numpy as np

    from tps_solver.solvers.fda import simulate
    from tps_solver.model.flat import FlatLayer
    from tps_solver._commands._output import figure_path

    from tps_solver.solvers.fda import METHODS

    if args.periods < 1:
        raise ValueError(f"--periods must be an integer >= 1, got {args.periods}")
    impulsive = METHODS[args.method].impulsive
    if "cutoff" in METHODS[args.method].OPTIONS or not impulsive:
        if args.cutoff is None:
            raise ValueError(f"--cutoff is required with --method {args.method} (the length of the soft "
                             "contact, a finite number > 0)")
        if args.impact != "point" or args.rho_c is not None:
            raise ValueError(f"--impact/--rho-c do not apply to --method {args.method} (the soft contact "
                             "replaces the impact rule)")
    elif args.cutoff is not None:
        raise ValueError(f"--cutoff is only used with --method soft, got --method {args.method}")
    png = figure_path(args.plot) if args.plot else None
    fl = FlatLayer(args.gamma, args.M, e=args.e)
    lat, t, w, z = initial_state(args.case, fl, args)
    T = fl.period
    extra = dict(impact=args.impact, rho_c=args.rho_c) if impulsive else dict(cutoff=args.cutoff)
    stuck = None
    print(f"simulate {args.case}: {lat!r}, method {args.method}, Gamma = {fl.Gamma:g}, e = {fl.e:g}, "
          f"M = {fl.M}, far-field t0 = {fl.t0:.6g}")
    keep = min(args.periods, 3)
    times, heights = [], []
    total = 0
    for k in range(args.periods):
        t_eval = t + np.linspace(0.0, T, 65)[1:] if k >= args.periods - keep else None
        kw = dict(extra, stuck0=stuck) if impulsive else extra
        res = simulate(lat, fl.Gamma, fl.e, w, z, t_start=t, t_end=t + T, method=args.method,
                       t_eval=t_eval, **kw)
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
    length = res.cutoff["length"]
    print(f"  done: {total} events; cut-off {res.cutoff['kind']} = "
          f"{'none' if length is None else format(length, '.4g')}")
    if png:
        plot(lat, fl, np.concatenate(times), np.vstack(heights), png, args.case, args.method, args.cutoff)
        print(f"  figure written to {png}")
    return 0
