"""``tps-solver flat``: the bouncing flat layer of (17)-(19) and its multipliers."""

NAME = "flat"
#: API parameter -> flag, for error messages.
FLAGS = {"Gamma": "--gamma", "e": "--e", "t0": "--t0", "M": "--M", "branch": "--branch"}
HELP = "Flat-layer (bouncing-ball) orbit: launch phase, W0, peak height, Floquet multipliers."


def configure(parser):
    parser.add_argument("--gamma", type=float, default=2.5, help="plate acceleration Gamma (default 2.5)")
    parser.add_argument("--e", type=float, default=None, help="restitution in [0, 1) (default 0.45)")
    parser.add_argument("--t0", type=float, default=None, help="launch phase; fixes e by (19) (paper: 0)")
    parser.add_argument("--M", type=int, default=2, help="subharmonic order (default 2)")
    parser.add_argument("--branch", default="stable", choices=["stable", "unstable"],
                        help="which of the two period-M orbits of (19): 'stable' (t0 > 0, default) or "
                             "'unstable' (t0 < 0)")
    parser.add_argument("--plot", metavar="PNG", default=None,
                        help="draw zeta(t) and W(t) over two periods; '.png' is appended to a name without extension")


def describe(fl):
    """Return the multi-line text summary of a FlatLayer."""
    mu = fl.floquet_multipliers()
    lines = [
        f"flat layer: Gamma = {fl.Gamma:g}, M = {fl.M}, e = {fl.e:.10g}, branch = {fl.branch}",
        f"  launch phase t0      = {fl.t0:.12g}",
        f"  period T             = {fl.period:.12g}",
        f"  post-impact W0       = {fl.W0:.12g}",
        f"  pre-impact W(T-)     = {fl.impact_velocity:.12g}",
        f"  peak height          = {fl.peak_height:.12g}",
        "  Floquet multipliers  = " + ", ".join(f"{m.real:+.10f}{m.imag:+.10f}j" for m in mu),
        "  |multipliers|        = " + ", ".join(f"{abs(m):.10f}" for m in mu),
        f"  stable?              = {fl.is_stable}",
    ]
    if abs(abs(mu[0]) - 1.0) < 1e-9:
        lines.append("  note: a multiplier of modulus 1 -- this orbit sits at a bifurcation (t0 = 0 is the fold)")
    return "\n".join(lines)


def plot(fl, path):
    """Draw zeta(t) and W(t) over two periods to ``path``; returns the Figure (closed)."""
    import matplotlib.pyplot as plt
    import numpy as np

    t = np.linspace(fl.t0, fl.t0 + 2 * fl.period, 2000)
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 5), layout="constrained")
    ax[0].plot(t / fl.period, fl.height(t))
    ax[0].set_ylabel(r"height $\zeta$ (plate amplitudes)")
    ax[1].plot(t / fl.period, fl.velocity(t))
    ax[1].axhline(0.0, color="0.6", lw=0.6)
    ax[1].set_ylabel(r"velocity $W$ ($A\omega$)")
    ax[1].set_xlabel(r"time $t/T$ (periods, dimensionless; $T = 2\pi M/\omega$)")
    ax[0].set_title(f"flat layer (17)-(19): $\\Gamma$ = {fl.Gamma:g}, e = {fl.e:.4g}, M = {fl.M}, "
                    f"$t_0$ = {fl.t0:.4g}, {fl.branch} branch", fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


def run(args):
    from tps_solver.model.flat import FlatLayer
    from tps_solver._commands._output import figure_path

    png = figure_path(args.plot) if args.plot else None
    e = args.e
    if e is None and args.t0 is None:
        e = 0.45
    fl = FlatLayer(args.gamma, args.M, e=e, t0=args.t0, branch=args.branch)
    print(describe(fl))
    if png:
        plot(fl, png)
        print(f"  figure written to {png}")
    return 0
