"""``tps-solver stability``: growth rates of flat-layer perturbations, eqs. (28)-(35).

Examples
--------
$ tps-solver stability --kh 1.0
$ tps-solver stability --kh 1.0 --n-modes 5 --plot sigma.png
"""
NAME = "stability"
HELP = "Linear stability of a flat layer: leading growth rates sigma of sinuous and varicose modes, eq. (35)."


def configure(parser):
    parser.add_argument("--kh", type=float, required=True, help="wavenumber times layer thickness, k h > 0")
    parser.add_argument("--n-modes", type=int, default=3, help="modes per family to print (default 3)")
    parser.add_argument("--nu", type=float, default=1.0, help="viscosity nu (default 1)")
    parser.add_argument("--plot", metavar="PNG", default=None,
                        help="draw sigma h^2/nu against k h for both families")


def describe(kh, n_modes, nu=1.0):
    """Return the text table of the leading growth rates at ``kh`` (thickness h = 1)."""
    from ..linear_stability import MODES, secular_roots

    kappa = kh / 2.0
    lines = [f"flat-layer linear stability at k h = {kh:g} (kappa = k h/2 = {kappa:g}, h = 1, nu = {nu:g})",
             "  sigma = nu k^2 (gamma^2 - 1); trivial roots of (35) (gamma = 1, and 0 for varicose) are not",
             "  eigenvalues of (28)-(29) and are not listed.",
             f"  {'family':9s} {'n':>2s} {'gamma':>26s} {'sigma/(nu k^2)':>22s} {'sigma h^2/nu':>22s}"]
    for mode in MODES:
        res = secular_roots(kappa, mode, n_modes)
        for i, (g, lam) in enumerate(zip(res.gamma, res.lam)):
            gtxt = f"{g.real:.12g}" if g.imag == 0 else f"{g.imag:.12g}i"
            lines.append(f"  {mode:9s} {i + 1:2d} {gtxt:>26s} {lam:22.14g} {nu * lam * kh * kh:22.14g}")
        flag = "" if res.complete else "  (WARNING: argument-principle count disagrees)"
        lines.append(f"  {mode:9s} zeros in checked disc: {res.n_enclosed} (all real){flag}")
    return "\n".join(lines)


def plot(path, kh_min=1e-2, kh_max=20.0, n_modes=3, nu=1.0, n_points=121):
    """Draw sigma h^2 / nu against k h (h = 1) for both families to ``path`` (Agg backend)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..linear_stability import MODES, growth_rates

    kh = np.geomspace(kh_min, kh_max, n_points)
    fig, ax = plt.subplots(figsize=(7, 5))
    styles = {"sinuous": "-", "varicose": "--"}
    for mode in MODES:
        sig = np.array([growth_rates(x, 1.0, mode, n_modes, nu=nu) for x in kh])
        for j in range(n_modes):
            ax.plot(kh, -sig[:, j], styles[mode], color=f"C{j}", label=f"{mode} mode {j + 1}")
    ax.plot(kh, nu * kh ** 2, ":", color="k", label=r"$\nu k^2$ (trivial root $\gamma=0$, not an eigenvalue)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"$k h$")
    ax.set_ylabel(r"$-\sigma h^2/\nu$ (all $\sigma < 0$)")
    ax.set_title("Flat-layer perturbations decay: leading rates of (28)-(29)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def run(args):
    from .._validation import check_in_range, check_int, check_positive

    check_in_range(args.kh, "--kh", 2e-6, 2e3)
    check_int(args.n_modes, "--n-modes", minimum=1, maximum=1000)
    check_positive(args.nu, "--nu")
    print(describe(args.kh, args.n_modes, args.nu))
    if args.plot:
        plot(args.plot, n_modes=args.n_modes, nu=args.nu)
        print(f"wrote {args.plot}")
    return 0
