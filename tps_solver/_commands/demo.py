"""``tps-solver demo``: a fast tour of the solvers with one summary table (under a minute).

1. the bouncing flat layer (17)-(19): launch phase, W0, Floquet multipliers;
2. the flat layer reproduced by the TPS (oscillon geometry, Newton from a
   perturbed contact time): errors against the closed form;
3. the oscillon and the kink TPS on the library's defaults
   (:mod:`tps_solver.core.defaults`: e = 0.45, 8 nodes at spacing 20, N = 30;
   continuation from the decoupled limit): convergence status and the physical
   checks of the single-contact assumption; then the oscillon on a fine grid
   (20 nodes at spacing 0.21), where the single-contact branch ends at a fold
   (status 4, expected: such solutions need spacing above about 11);
4. the exact lattice cycle on the default coarse lattice and its FDA stability
   check (a periodic orbit of the FDA to round-off);
5. the FDA stability check of the flat layer: uniform-mode multipliers against
   the exact ones, growth factor.

A TPS run that does not converge is reported as such in the table; it does not
make the demo fail.  The exit status is 1 only if the flat-layer reproduction
(items 2 and 5) misses its acceptance bound, which would be a bug.
"""
import importlib
import math
import time

import numpy as np

NAME = "demo"
#: API parameter -> flag, for error messages (tps_solver.cli.flag_error).
FLAGS = {"Gamma": "--gamma", "e": "--e", "M": "--M", "n_harmonics": "--N", "n_nodes": "--nodes",
         "r_max": "--size", "length": "--size", "half_length": "--size"}
HELP = "Fast demo (< 1 min): flat layer, TPS vs flat layer, small oscillon and kink, FDA check; summary table."

#: Acceptance bounds of the flat-layer reproduction (the flat orbit to round-off in every method).
TC_TOL = 1e-10
HARMONIC_TOL = 1e-12
MULTIPLIER_TOL = 1e-7


def configure(parser):
    from tps_solver.core import defaults as d

    parser.add_argument("--gamma", type=float, default=d.GAMMA, help=f"plate acceleration Gamma (default {d.GAMMA})")
    parser.add_argument("--e", type=float, default=d.E, help=f"restitution (default {d.E}, stable interior)")
    parser.add_argument("--M", type=int, default=d.M, help=f"subharmonic order (default {d.M})")
    parser.add_argument("--N", type=int, default=d.N_HARMONICS,
                        help=f"harmonics of the TPS runs (default {d.N_HARMONICS})")
    parser.add_argument("--nodes", type=int, default=d.N_NODES, help=f"nodes of the TPS runs (default {d.N_NODES})")
    parser.add_argument("--size", type=float, default=None,
                        help=f"r_max / half-length of the TPS runs (default {d.R_MAX:g} / {d.HALF_LENGTH:g}: "
                             f"spacing {d.SPACING:g} with the default nodes)")


def _module(name):
    try:
        return importlib.import_module(f"tps_solver.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == f"tps_solver.{name}":
            return None
        raise


def _timed(func):
    start = time.perf_counter()
    value = func()
    return value, time.perf_counter() - start


def _mu_text(mu):
    return ", ".join(f"{m.real:+.6f}{m.imag:+.6f}j" for m in mu)


def _flat_by_tps(fl, N):
    """TPS (oscillon geometry, no continuation) from tc = t0 + 0.05 cos r; max errors vs the closed form."""
    from tps_solver.solvers.tps import solve_oscillon

    sol, dt = _timed(lambda: solve_oscillon(
        Gamma=fl.Gamma, M=fl.M, t0=fl.t0, n_harmonics=N, n_nodes=24, r_max=8.0, tol=1e-13,
        tc_initial=lambda r: fl.t0 + 0.05 * np.cos(r), continuation=False))
    T = fl.period
    tc_err = float(np.max(np.abs(np.mod(sol.tc - fl.t0 + T / 2, T) - T / 2)))
    w_err = float(np.max(np.abs(sol.w_hat - fl.harmonics(N)[:, None])))
    return sol, tc_err, w_err, dt


def _physics(sol):
    c = sol.checks
    return (("(of the returned fields) " if not sol.converged else "")
            + f"min zeta {c.min_zeta:.2e}, single contact {c.single_contact}, "
            f"steep crossing {bool(np.all(c.tc_is_steep_crossing))}, "
            f"restitution residual {c.restitution_residual:.1e}")


def summary_rows(Gamma=None, e=None, M=None, N=None, n_nodes=None, size=None):
    """Run the demo and return the rows of its table (``None``: the value of :mod:`tps_solver.core.defaults`).

    Returns
    -------
    rows : list of tuple of str
        ``(item, result, criterion, verdict)``; ``verdict`` is ``"ok"``,
        ``"FAIL"``, ``"not converged"``, ``"checks fail"`` or ``"n/a"``.
    flat_ok : bool
        Whether the flat-layer reproduction met its acceptance bounds.
    """
    from tps_solver.core import defaults as d
    from tps_solver.model.flat import FlatLayer
    from tps_solver.operators.lattice import Lattice
    from tps_solver.solvers.tps import solve_kink, solve_lattice_cycle, solve_oscillon

    Gamma = d.GAMMA if Gamma is None else Gamma
    e = d.E if e is None else e
    M = d.M if M is None else M
    N = d.N_HARMONICS if N is None else N
    n_nodes = d.N_NODES if n_nodes is None else n_nodes
    rows = []
    fl = FlatLayer(Gamma, M, e=e)
    mu = fl.floquet_multipliers()
    rows.append(("flat layer (17)-(19)", f"t0 = {fl.t0:.10f}, W0 = {fl.W0:.10f}", "exact", "ok"))
    rows.append(("  Floquet multipliers", _mu_text(mu), "|mu| < 1: stable",
                 "stable" if fl.is_stable else "unstable"))

    _, tc_err, w_err, dt = _flat_by_tps(fl, 16)
    flat_ok = tc_err <= TC_TOL and w_err <= HARMONIC_TOL
    rows.append(("TPS reproduces flat layer", f"max|tc - t0| = {tc_err:.1e}, max|w_n - W_n| = {w_err:.1e} "
                 f"({dt:.2f} s)", f"<= {TC_TOL:.0e}, <= {HARMONIC_TOL:.0e}", "ok" if flat_ok else "FAIL"))

    r_max = d.R_MAX if size is None else size
    half = d.HALF_LENGTH if size is None else size
    for label, func, kw in (
            (f"oscillon TPS (N={N}, {n_nodes} nodes, r_max {r_max:g})", solve_oscillon, dict(r_max=r_max)),
            (f"kink TPS (N={N}, {n_nodes} half-line nodes, half-length {half:g})", solve_kink,
             dict(half_length=half))):
        sol, dt = _timed(lambda: func(Gamma=Gamma, M=M, e=e, n_harmonics=N, n_nodes=n_nodes, **kw))
        verdict = ("not converged" if not sol.converged
                   else ("ok" if sol.checks.all_pass else "checks fail"))
        rows.append((label,
                     f"converged {sol.converged} (status {sol.status}, {sol.nit} it, "
                     f"max|F| {sol.residual:.1e}, spacing {sol.spacing:.3g}, {dt:.2f} s)",
                     "converged, max|F| <= 1e-10", verdict))
        rows.append(("  physical checks", _physics(sol), "zeta >= 0, one contact",
                     ("ok" if sol.checks.all_pass else "FAIL") + ("" if sol.converged else " (partial)")))
        if not sol.converged:
            rows.append(("  message", sol.message, "", ""))

    fine, dt = _timed(lambda: solve_oscillon(Gamma=Gamma, M=M, e=e, n_harmonics=8, n_nodes=20, r_max=4.0))
    rows.append(("oscillon TPS, fine grid (N=8, 20 nodes, spacing 0.21)",
                 f"status {fine.status}: branch ends at coupling {fine.coupling:.3g} (spacing "
                 f"{fine.spacing:.3g} reached), {dt:.2f} s", "status 4: no single-contact solution "
                 f"below spacing ~{d.FOLD_SPACING_TPS:g}", "expected" if fine.status == 4 else "unexpected"))

    from tps_solver.analyses.stability import check_stability

    lat = Lattice.planar(**d.COARSE_LATTICE)
    cyc, dt = _timed(lambda: solve_lattice_cycle(lat, Gamma=Gamma, M=M, e=e))
    if cyc.converged:
        chk, dt2 = _timed(lambda: check_stability(cyc, periods=6))
        rows.append(("exact lattice cycle + FDA check", f"defect {float(chk.defects.max()):.1e}, growth/period "
                     f"{chk.growth_factor:.3g}, stable {chk.stable} ({dt + dt2:.2f} s, {lat.n_nodes} nodes, dx = "
                     f"{lat.spacing:g})", "defect <= 1e-10", "ok" if float(chk.defects.max()) <= 1e-10 else "FAIL"))
    else:
        rows.append(("exact lattice cycle + FDA check", cyc.message, "converged", "not converged"))

    stability = _module("analyses.stability")
    if stability is None:
        rows.append(("FDA check of flat layer", "tps_solver.analyses.stability not available", "", "n/a"))
    else:
        chk, dt = _timed(lambda: stability.check_stability(fl, periods=8, n_nodes=5))
        um = np.asarray(chk.uniform_multipliers, dtype=complex)
        err = (float(min(np.max(np.abs(um - mu)), np.max(np.abs(um[::-1] - mu))))
               if um.size == 2 else math.inf)
        ok = err <= MULTIPLIER_TOL
        flat_ok = flat_ok and ok
        rows.append(("FDA check of flat layer", f"uniform-mode multipliers err {err:.1e}, growth/period "
                     f"{chk.growth_factor:.3g}, stable {chk.stable} ({dt:.2f} s, 5 nodes, dx = "
                     f"{chk.lattice.spacing:.3g})", f"mu err <= {MULTIPLIER_TOL:.0e}", "ok" if ok else "FAIL"))
        if chk.grid_instability:
            rows.append(("  note", chk.message.split(". Measured")[0], "", ""))
    return rows, flat_ok


def format_table(rows):
    """Plain-text table of ``rows`` (list of 4-tuples of str)."""
    head = ("item", "result", "criterion", "verdict")
    widths = [max(len(r[i]) for r in list(rows) + [head]) for i in (0, 2, 3)]
    lines = [f"{head[0]:<{widths[0]}}  {head[3]:<{widths[2]}}  {head[2]:<{widths[1]}}  {head[1]}"]
    lines.append("-" * len(lines[0]))
    for item, result, crit, verdict in rows:
        lines.append(f"{item:<{widths[0]}}  {verdict:<{widths[2]}}  {crit:<{widths[1]}}  {result}")
    return "\n".join(lines)


def run(args):
    start = time.perf_counter()
    rows, flat_ok = summary_rows(args.gamma, args.e, args.M, args.N, args.nodes, args.size)
    print(f"tps-solver demo: Gamma = {args.gamma:g}, e = {args.e:g}, M = {args.M}")
    print(format_table(rows))
    print(f"total wall time {time.perf_counter() - start:.1f} s")
    if not flat_ok:
        print("FAIL: the flat layer is not reproduced to its acceptance bounds")
    return 0 if flat_ok else 1
