"""Validation of the impact-and-stick TPS (tps_solver.tps_stick) for e = 0.

Run ``python -m validation.tps_stick`` (lattice cases take minutes each; ``--quick``
keeps only the flat layer and the dx = 2 lattice).  Every function returns measured
numbers; ``main()`` prints markdown tables.
"""
import argparse
import time

import numpy as np

import tps_solver as tps
from tps_solver import tps_stick as ts

GAMMAS = (3.9, 4.1, 4.4)


def flat_errors(Gamma, n_nodes=1, perturbation=1e-2):
    """Max errors of contact and lift-off times of the flat e = 0 TPS against the closed form."""
    orb = ts.flat_stick_orbit(Gamma, 2)
    start = time.perf_counter()
    sol = ts.solve_stick_flat(Gamma, 2, n_nodes=n_nodes, length=2.0 * n_nodes,
                              perturbation=perturbation)
    return dict(Gamma=Gamma, n_nodes=n_nodes, converged=sol.converged, nit=sol.nit,
                contact_error=float(np.max(np.abs(sol.contact_times - orb.t[None, :]))),
                liftoff_error=float(np.nanmax(np.abs(sol.liftoff_times - orb.tau[None, :]))),
                t_liftoff=orb.t_liftoff, t1=orb.t[0], t2=orb.t[1], seconds=time.perf_counter() - start)


def front_width(sol, n_times=2048):
    r"""10-90 % width of :math:`\theta = (\zeta - \zeta_L)/(\zeta_R - \zeta_L)`.

    Evaluated at the phase where :math:`|\zeta_R - \zeta_L|` of the two end nodes is largest
    (the far fields are half a period apart, so this is where the kink is most pronounced);
    crossings by linear interpolation between nodes, the outermost ones if theta is not
    monotone.  Returns (width, phase).
    """
    T = sol.period
    t = np.linspace(0.0, T, n_times, endpoint=False)
    z = sol.height(t)
    k = int(np.argmax(np.abs(z[:, -1] - z[:, 0])))
    zt = z[k]
    theta = (zt - zt[0]) / (zt[-1] - zt[0])
    x = sol.nodes

    def crossing(level, first):
        above = theta >= level
        idx = np.nonzero(above[1:] != above[:-1])[0]
        i = idx[0] if first else idx[-1]
        return x[i] + (level - theta[i]) * (x[i + 1] - x[i]) / (theta[i + 1] - theta[i])

    lo, hi = crossing(0.1, True), crossing(0.9, False)
    return float(abs(hi - lo)), float(t[k])


def lattice_case(n_nodes, length=40.0, Gamma=4.1, n_basis=6, periods=20, fda_periods=2):
    """Lattice kink: TPS solve, FDA started on the TPS state, FDA-from-kink distance, front width."""
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=length)
    start = time.perf_counter()
    sol = ts.solve_stick_lattice(lat, Gamma, 2, 0.0, periods=periods, n_basis=n_basis, tol=1e-10)
    elapsed = time.perf_counter() - start
    out = dict(n_nodes=n_nodes, dx=length / (n_nodes - 1), Gamma=Gamma, n_basis=n_basis,
               converged=sol.converged, residual=sol.residual, nit=sol.nit, seconds=elapsed,
               stick_w_max=sol.checks.stick_w_max, all_pass=sol.checks.all_pass,
               K=sol.K, message=sol.message)
    p = sol.pattern
    out["n_stick"] = int(np.sum(p.kind == "stick"))
    out["n_bounce"] = int(np.sum(p.kind == "bounce"))
    out["n_triggered"] = int(np.sum(p.trigger >= 0))
    # distance of the FDA-from-kink state (after `periods`) to the TPS
    fda_pat = ts.pattern_from_fda(sol.fda, lat, sol.period)
    out["fda_kink_distance"] = float(np.max(np.abs(fda_pat.t - p.t))) if fda_pat.t.size == p.t.size else np.nan
    if sol.converged:
        chk = ts.check_with_fda(sol, periods=fda_periods)
        out.update(fda_contact_error=chk.contact_error, fda_liftoff_error=chk.liftoff_error,
                   fda_events_per_period=float(np.max(chk.events_per_period)))
        out["front_width"], out["front_phase"] = front_width(sol)
    # pattern per node summary: kinds of the two contacts
    kinds = ["".join(k[0] for k in row if k) for row in sol.contact_kinds]
    out["patterns"] = sorted(set(kinds))
    out["solution"] = sol
    return out


def fda_on_tps(sol, periods=10):
    """Max distance per period between the FDA started on the TPS state and the TPS contact times."""
    chk = ts.check_with_fda(sol, periods=periods)
    run, T, p = chk.run, sol.period, sol.pattern
    out = []
    for m in range(periods):
        err = 0.0
        for j in range(p.n_nodes):
            e = run.events[(run.events.node == j) & (run.events.kind != "liftoff")]
            for c in np.nonzero(p.node == j)[0]:
                tc = chk.t_start + np.mod(p.t[c] - chk.t_start, T) + m * T
                err = max(err, float(np.min(np.abs(e.t - tc))))
        out.append(err)
    return out


def fda_from_kink(sol, checkpoints=(20, 40, 80, 160)):
    """Max distance of the FDA contacts (run from the kink start) to the TPS contacts, per checkpoint."""
    lat, T, p = sol.lattice, sol.period, sol.pattern
    t0, w0, z0 = ts.kink_state(lat, sol.Gamma, sol.M)
    run = tps.simulate(lat, sol.Gamma, sol.e, w0, z0, t_start=t0, t_end=t0 + max(checkpoints) * T)
    out = []
    for P in checkpoints:
        err = 0.0
        for j in range(p.n_nodes):
            ev = run.events
            e = ev[(ev.node == j) & (ev.kind != "liftoff") & (ev.t > t0 + (P - 2) * T) & (ev.t < t0 + P * T)]
            for c in np.nonzero(p.node == j)[0]:
                ph = np.mod(e.t - p.t[c] + T / 2, T) - T / 2
                err = max(err, float(np.min(np.abs(ph))) if e.size else np.inf)
        out.append((P, err))
    return out


def _table(rows, cols):
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            cells.append(f"{v:.3g}" if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--dx", type=float, nargs="*", default=None)
    ap.add_argument("--periods", type=int, default=160, help="FDA periods for the initial pattern")
    args = ap.parse_args(argv)
    print("## Flat e = 0 orbit: TPS from a perturbed uniform start (perturbation 1e-2)\n")
    rows = [flat_errors(G, n) for G in GAMMAS for n in (1, 4)]
    print(_table(rows, ["Gamma", "n_nodes", "converged", "nit", "contact_error", "liftoff_error",
                        "t_liftoff", "t1", "t2"]))
    dxs = [2.0] if args.quick else (args.dx or [2.0, 1.0])
    print("\n## Lattice kinks (Neumann, L = 40), e = 0, M = 2\n")
    rows = []
    for G in GAMMAS:
        for dx in dxs:
            r = lattice_case(int(round(40.0 / dx)) + 1, Gamma=G, periods=args.periods)
            rows.append(r)
    print(_table(rows, ["Gamma", "dx", "n_basis", "converged", "residual", "stick_w_max", "all_pass",
                        "fda_contact_error", "fda_liftoff_error", "fda_kink_distance", "front_width",
                        "n_stick", "n_bounce", "n_triggered", "patterns", "seconds"]))
    if not args.quick:
        print("\n## Convergence in the reaction basis (Gamma = 4.1, dx = 2)\n")
        rows = [lattice_case(21, Gamma=4.1, n_basis=nb) for nb in (2, 3, 4, 5, 6)]
        print(_table(rows, ["n_basis", "converged", "residual", "stick_w_max", "fda_contact_error",
                            "fda_liftoff_error", "seconds"]))
        sol = rows[-1]["solution"]
        if sol.converged:
            print("\n## FDA on the TPS state, and FDA from the kink start (Gamma = 4.1, dx = 2)\n")
            print("max contact-time distance per period, FDA started on the TPS state:",
                  ", ".join(f"{v:.2e}" for v in fda_on_tps(sol)))
            print("\nFDA from the kink start, distance to the TPS contacts:",
                  ", ".join(f"{P} periods: {v:.2e}" for P, v in fda_from_kink(sol)))


if __name__ == "__main__":
    main()
