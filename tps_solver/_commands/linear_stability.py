"""``tps-solver linear-stability``: growth rates of flat-layer perturbations, eqs. (28)-(35).

Examples
--------
$ tps-solver linear-stability --kh 1.0
$ tps-solver linear-stability --kh 1.0 --n-modes 5 --plot sigma.png

(``tps-solver stability`` is kept as an alias.)
"""
NAME = "linear-stability"
ALIASES = ["stability"]
HELP = "Linear stability of a flat layer: leading growth rates sigma of sinuous and varicose modes, eq. (35)."


def configure(parser):
    parser.add_argument("--kh", type=float, required=True, help="wavenumber times layer thickness, k h > 0")
    parser.add_argument("--n-modes", type=int, default=3, help="modes per family to print (default 3)")
    parser.add_argument("--nu", type=float, default=1.0, help="viscosity nu (default 1)")
    parser.add_argument("--plot", metavar="PNG", default=None,
                        help="draw sigma h^2/nu against k h for both families; '.png' is appended to a name "
                             "without extension")


def describe(kh, n_modes, nu=1.0):
    """Return the text table of the leading growth rates at ``kh`` (thickness h = 1)."""
    from tps_solver.model.linear_stability import MODES, secular_roots

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


def run(args):
    from tps_solver.core.checks import check_in_range, check_int, check_positive
    from tps_solver._commands._output import figure_path

    check_in_range(args.kh, "--kh", 2e-6, 2e3)
    check_int(args.n_modes, "--n-modes", minimum=1, maximum=1000)
    check_positive(args.nu, "--nu")
    png = figure_path(args.plot) if args.plot else None
    print(describe(args.kh, args.n_modes, args.nu))
    if png:
        from tps_solver.plotting import plot_growth_rates

        plot_growth_rates(png, n_modes=args.n_modes, nu=args.nu)
        print(f"wrote {png}")
    return 0
