"""One problem, one Newton: what every solver of the package gives through the one engine.

Every nonlinear solve of the package is :func:`tps_solver.core.newton.newton` on a problem of
the protocol (:mod:`tps_solver.core.problem`).  This study measures, for each former loop, the
numbers it gives now: Newton steps, residuals, period maps, and the agreement of the
continuation of impact-and-stick orbits with independent references (the closed-form flat
orbit; direct Newton solves at the same Gamma).  The counts at commit 33c4ade (before the one
engine, five loops) are quoted as measured there by ``python validation/house.py`` on that
checkout's equivalents.

Run ``python -m validation.house``.
"""
import time

import numpy as np

import tps_solver as tps
from tps_solver.solvers.tps.stick_problem import flat_stick_orbit
from validation.report import one_blas_thread, write_section

#: Measured at commit 33c4ade (five Newton loops, the private GMRES of shooting) with the same calls.
BEFORE = {"kink_nit": 9, "cycle_nit": 13, "stick_flat_nit_4.1": 7, "stick_flat_nit_4.6": 6,
          "shooting_nit": 4, "shooting_maps": 29}


def engine_counts():
    """Newton steps of every former loop on its standard case, through the one engine."""
    out = {}
    k = tps.solve_kink(n_harmonics=8)
    out.update(kink_nit=k.nit, kink_residual=float(k.residual))
    c = tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=6, length=100.0))
    out.update(cycle_nit=c.nit, cycle_residual=float(c.residual))
    for G in (4.1, 4.6):
        s = tps.solve_stick_flat(G, 2, n_nodes=3, length=6.0, perturbation=1e-2)
        orb = flat_stick_orbit(G, 2)
        out[f"stick_flat_nit_{G:g}"] = s.nit
        out[f"stick_flat_error_{G:g}"] = float(np.max(np.abs(s.contact_times - orb.t[None, :])))
    coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    w, z = cyc.velocity(1.0)[0] * 1.01, cyc.height(1.0)[0] * 1.01
    orb = tps.find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=(w, z), t_start=1.0, multipliers=False)
    out.update(shooting_nit=orb.nit, shooting_maps=int(orb.n_period_maps), shooting_residual=float(orb.residual),
               shooting_products=int(np.sum(orb.gmres_products)))
    return out


def stick_flat_branch(bounds=(4.0, 4.3)):
    """The e = 0 flat orbit continued in Gamma: largest contact-time error against the closed form."""
    start = tps.solve_stick_flat(Gamma=4.1)
    tic = time.perf_counter()
    br = tps.continue_branch(start, "Gamma", bounds, multipliers=False, step=0.02, max_step=0.05)
    C = start.problem.C
    err = max(float(np.max(np.abs(np.sort(x[:C]) - np.sort(flat_stick_orbit(G, 2).t))))
              for G, x in zip(br.parameter_values, br.states))
    return dict(points=int(br.parameter_values.size), status=br.status, error=err,
                seconds=time.perf_counter() - tic, last=float(br.parameter_values[-1]))


def main():
    with one_blas_thread():
        counts = engine_counts()
        flat = stick_flat_branch()
        from validation.tps_stick import continuation
        branch, rows = continuation()
    lines = ["## One problem, one Newton", "",
             "Every nonlinear solve is `tps_solver.core.newton.newton` on a problem of the protocol of "
             "`core/problem.py`. Newton steps on each former loop's standard case, before (commit 33c4ade, "
             "five loops) and now (one engine):", "",
             "| case | before | now | residual now |", "|---|---|---|---|",
             f"| solve_kink(n_harmonics=8) | {BEFORE['kink_nit']} | {counts['kink_nit']} | {counts['kink_residual']:.2e} |",
             f"| solve_lattice_cycle (6 nodes, L = 100) | {BEFORE['cycle_nit']} | {counts['cycle_nit']} | "
             f"{counts['cycle_residual']:.2e} |",
             f"| stick flat, Gamma 4.1, perturbation 1e-2 | {BEFORE['stick_flat_nit_4.1']} | "
             f"{counts['stick_flat_nit_4.1']} | error {counts['stick_flat_error_4.1']:.1e} |",
             f"| stick flat, Gamma 4.6, perturbation 1e-2 | {BEFORE['stick_flat_nit_4.6']} | "
             f"{counts['stick_flat_nit_4.6']} | error {counts['stick_flat_error_4.6']:.1e} |",
             f"| shooting, coarse cycle x 1.01 | {BEFORE['shooting_nit']} steps, {BEFORE['shooting_maps']} maps | "
             f"{counts['shooting_nit']} steps, {counts['shooting_maps']} maps | {counts['shooting_residual']:.2e} |",
             "",
             "Shooting costs one period map more per Newton step than before: `scipy.sparse.linalg.gmres` "
             "forms the true residual b - Ax after its cycle (one Jacobian-vector product, i.e. one period "
             "map), which the private GMRES it replaced did not. The steps are the same; the final residual "
             "was 6.40e-13 before.", "",
             "**Continuation of impact-and-stick orbits** (new: `continue_branch(StickSolution, 'Gamma', ...)`):", "",
             f"- the flat e = 0 orbit over Gamma in [4.0, 4.3]: {flat['points']} points, status {flat['status']}, "
             f"largest contact-time error against the closed form {flat['error']:.1e} ({flat['seconds']:.2f} s);",
             f"- the Gamma = 4.1 kink at dx = 2 up to Gamma = 4.11: {branch.message}", "",
             "| Gamma | point | branch vs direct solve | time shift | FDA contact error | FDA lift-off error | checks |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['Gamma']} | {r['point']} | {r['branch_vs_direct']:.1e} | {r['time_shift']:.3g} | "
                     f"{r.get('fda_contact_error', float('nan')):.1e} | {r.get('fda_liftoff_error', float('nan')):.1e} | "
                     f"{r['all_pass']} |")
    lines += ["", "Printed by `python -m validation.house`."]
    text = "\n".join(lines) + "\n"
    print(text)
    write_section("house", text)
    return counts, flat, rows


if __name__ == "__main__":
    main()
