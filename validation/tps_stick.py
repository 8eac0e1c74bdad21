"""Validation of the impact-and-stick TPS (tps_solver.solvers.tps.stick) for e = 0.

Functions (each returns rows of measured numbers; ``main()`` prints markdown tables):

* :func:`flat_errors` -- the flat e = 0 orbit from a perturbed uniform start against the closed form;
* :func:`kink_from_shooting` -- the e = 0 kink (planar Neumann lattice of length 40, M = 2): the
  time-stepped guess of validation.shooting, shooting (``find_periodic_orbit``), then the stick TPS
  on the orbit's pattern; agreement with the FDA started on the TPS and with the orbit's contacts;
* :func:`pattern_vs_orbit` -- the pattern of the time-stepped guess against the orbit's;
* :func:`from_fda_guess` -- the stick TPS started directly on the guess run's pattern (no shooting);
* :func:`continuation` -- the Gamma = 4.1 kink followed in Gamma by :func:`tps_solver.continue_branch`,
  checked against direct Newton solves and the FDA;
* :func:`benchmark` / :func:`time_stepping` -- time to the TPS kink against FDA time stepping
  (exact and point integrators) from the same start to the same orbit at error 1e-8;
* :func:`discretisation_table` -- error against ``n_basis`` and ``n_quad`` (speed vs error).

Run ``python -m validation.tps_stick [flat] [kinks] [patterns] [fda_start] [continuation] [benchmark] [pareto]
[--dx ...]`` (default: flat kinks; lattice cases take minutes each, ``--quick`` keeps dx = 2).
Timings are wall-clock on the shared 2-core machine with single-threaded BLAS (threadpoolctl).
"""
import argparse
import math
import time

import numpy as np

import tps_solver as tps
from tps_solver.solvers.tps import stick as ts
from validation.report import one_blas_thread, phase_distance

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


#: Where the front width of a sticking kink is measured: :func:`tps_solver.front_width` at the instant where the
#: lower far field is highest (min(zeta_L, zeta_R) largest: both far fields and the front in flight), on 2048
#: samples of the period.
FRONT_WIDTH = dict(instant="lower_far_field_top", n_samples=2048)


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
        (out["front_width"],), (out["front_phase"],) = tps.front_width(sol, return_times=True, **FRONT_WIDTH)
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


def kink_from_shooting(dx, Gamma=4.1, length=40.0, guess_periods=10, n_basis=8, n_quad=16, tol=1e-10,
                       fda_periods=2):
    """e = 0 kink: time-stepped start (validation.shooting.e0_kink_guess), shooting, then the stick TPS
    on the shooting orbit's pattern; agreement with the FDA started on the TPS and with the orbit."""
    from validation.shooting import e0_kink_guess

    lat = tps.Lattice.planar(n_nodes=int(round(length / dx)) + 1, length=length)
    tic = time.perf_counter()
    run = e0_kink_guess(lat, Gamma, 2, guess_periods)
    t_guess = time.perf_counter() - tic
    tic = time.perf_counter()
    orb = tps.find_periodic_orbit(lat, Gamma=Gamma, M=2, e=0.0, guess=run, max_iter=80, multipliers=False)
    t_shoot = time.perf_counter() - tic
    tic = time.perf_counter()
    sol = ts.solve_stick_lattice(lat, Gamma, 2, 0.0, pattern=orb, n_basis=n_basis, n_quad=n_quad, tol=tol)
    t_call = time.perf_counter() - tic
    T = sol.period
    p = sol.pattern
    row = dict(dx=dx, n_nodes=lat.n_nodes, Gamma=Gamma, shooting_residual=orb.residual,
               converged=sol.converged, nit=sol.nit, residual=sol.residual, all_pass=sol.checks.all_pass,
               stick_w_max=sol.checks.stick_w_max, n_stick=int(np.sum(p.kind == "stick")),
               n_bounce=int(np.sum(p.kind == "bounce")), n_triggered=int(np.sum(p.trigger >= 0)),
               shortest_stick=float(np.nanmin(p.tau - p.t)),
               guess_seconds=t_guess, shooting_seconds=t_shoot, tps_seconds=t_call - (sol.time - sol.solve_time),
               tps_solve_seconds=sol.solve_time, check_seconds=sol.time - sol.solve_time, solution=sol, orbit=orb,
               guess_run=run, lattice=lat)
    err = 0.0
    for j in range(lat.n_nodes):
        d = phase_distance(orb.contact_times[j][:, None], sol.contact_times[j][None, :], T)
        err = max(err, float(np.max(np.min(d, axis=1))))
    row["shooting_contact_distance"] = err
    if sol.converged:
        chk = ts.check_with_fda(sol, periods=fda_periods)
        row.update(fda_contact_error=chk.contact_error, fda_liftoff_error=chk.liftoff_error,
                   fda_events_per_period=float(np.max(chk.events_per_period)))
        (row["front_width"],) = tps.front_width(sol, **FRONT_WIDTH)
    return row


def time_stepping(row, method="exact", max_periods=1000, target=1e-8, chunk=50):
    """Time-step the FDA from the same start (the final state of the guess run) and measure, after
    every period, the distance of the state to the TPS orbit at the same phase.

    The error is ``max(|w - w_tps|, |zeta - zeta_tps|)`` over the nodes at the instants
    ``t_s + k T`` (``t_s`` the shooting section).  Runs in chunks of ``chunk`` periods until the
    error is <= ``target`` or ``max_periods``; if not reached, the periods needed are
    extrapolated from the geometric rate fitted on the last half of the record (``extrapolated``).
    """
    sol, orb, run = row["solution"], row["orbit"], row["guess_run"]
    lat, T = row["lattice"], sol.period
    t_s = orb.t_start
    ref_w = sol.velocity([t_s])[0]
    ref_z = sol.height([t_s])[0]
    ref_w = np.where(orb.stuck0, 0.0, ref_w)
    ref_z = np.where(orb.stuck0, 0.0, ref_z)
    ref_gap = float(max(np.max(np.abs(ref_w - orb.w0)), np.max(np.abs(ref_z - orb.zeta0))))
    t0 = float(run.t)
    k0 = math.ceil((t0 - t_s) / T + 1e-9)
    w, z, stuck = np.asarray(run.w, float), np.asarray(run.zeta, float), np.asarray(run.stuck, bool)
    errs, seconds, k = [], 0.0, 0
    tc = t0
    while k < max_periods:
        te = t_s + T * (k0 + k + np.arange(chunk))
        tic = time.perf_counter()
        r = tps.simulate(lat, sol.Gamma, 0.0, w, z, t_start=tc, t_end=te[-1], method=method, t_eval=te,
                         stuck0=stuck)
        seconds += time.perf_counter() - tic
        if r.status != 0:
            break
        errs.extend(np.maximum(np.max(np.abs(r.w_eval - ref_w), axis=1),
                               np.max(np.abs(r.zeta_eval - ref_z), axis=1)).tolist())
        w, z, stuck, tc = np.asarray(r.w, float), np.asarray(r.zeta, float), np.asarray(r.stuck, bool), float(r.t)
        k += chunk
        if min(errs) <= target:
            break
    errs = np.asarray(errs)
    n = errs.size
    hit = np.nonzero(errs <= target)[0]
    h = max(2, n // 2)
    rate = float((errs[-1] / errs[n - h]) ** (1.0 / (h - 1))) if n > h else float("nan")
    per_period = seconds / max(n, 1)
    if hit.size:
        periods, extrapolated = int(hit[0]) + 1, False
    else:
        periods = n + math.log(target / errs[-1]) / math.log(rate) if 0 < rate < 1 else float("inf")
        extrapolated = True
    return dict(method=method, dx=row["dx"], periods_run=n, seconds_run=seconds, seconds_per_period=per_period,
                error_start=float(errs[0]), error_end=float(errs[-1]), rate=rate, periods_to_target=periods,
                seconds_to_target=periods * per_period, extrapolated=extrapolated, reference_gap=ref_gap,
                errors=errs)


def benchmark(dxs=(2.0,), Gamma=4.1, methods=("exact", "point"), max_periods=(1000,), target=1e-8):
    """Time to the stick-TPS kink (start -> shooting -> TPS) against FDA time stepping to the same
    orbit at error ``target``, side by side in one run (single-threaded BLAS)."""
    out = []
    with one_blas_thread():
        for i, dx in enumerate(dxs):
            row = kink_from_shooting(dx, Gamma)
            chain = row["guess_seconds"] + row["shooting_seconds"] + row["tps_seconds"]
            for m in methods:
                r = time_stepping(row, m, max_periods[min(i, len(max_periods) - 1)], target)
                # both start from the same 10-period guess run: its cost is in both totals
                r.update(tps_chain_seconds=chain, tps_seconds=row["tps_seconds"],
                         shooting_seconds=row["shooting_seconds"], guess_seconds=row["guess_seconds"],
                         fda_total_seconds=row["guess_seconds"] + r["seconds_to_target"],
                         ratio=(row["guess_seconds"] + r["seconds_to_target"]) / chain,
                         ratio_vs_tps_alone=r["seconds_to_target"] / row["tps_seconds"],
                         tps_converged=row["converged"])
                out.append(r)
            out[-1]["kink"] = row
    return out


def discretisation_table(row, n_basis=(1, 2, 3, 4, 6, 8), n_quad=(4, 6, 8, 12, 16, 24), ref=(8, 24)):
    """Contact / lift-off time error of the stick TPS against n_basis (n_quad = 16) and n_quad
    (n_basis = 6) on a kink (pattern of ``row``'s shooting orbit); reference ``ref`` = (n_basis, n_quad),
    and the distance to the shooting orbit's contact times."""
    lat, orb = row["lattice"], row["orbit"]
    G = row["Gamma"]
    pattern = ts.pattern_from_orbit(orb)
    T = pattern.period

    def solve(nb, nq):
        return ts.solve_stick_lattice(lat, G, 2, 0.0, pattern=pattern, n_basis=nb, n_quad=nq, tol=1e-12,
                                      max_iter=20, refresh=0)

    ref_sol = solve(*ref)
    out = []
    with one_blas_thread():
        for nb, nq in [(nb, 16) for nb in n_basis] + [(6, nq) for nq in n_quad if nq != 16]:
            s = solve(nb, nq)
            t_err = float(np.max(phase_distance(s.pattern.t, ref_sol.pattern.t, T)))
            st = np.isfinite(s.pattern.tau)
            l_err = float(np.max(phase_distance(s.pattern.tau[st], ref_sol.pattern.tau[st], T)))
            sh = 0.0
            for j in range(lat.n_nodes):
                d = phase_distance(orb.contact_times[j][:, None], s.contact_times[j][None, :], T)
                sh = max(sh, float(np.max(np.min(d, axis=1))))
            out.append(dict(n_basis=nb, n_quad=nq, converged=s.converged, nit=s.nit, residual=s.residual,
                            contact_error=t_err, liftoff_error=l_err, shooting_distance=sh,
                            solve_seconds=s.solve_time))
    out.append(dict(n_basis=ref[0], n_quad=ref[1], converged=ref_sol.converged, nit=ref_sol.nit,
                    residual=ref_sol.residual, contact_error=0.0, liftoff_error=0.0,
                    solve_seconds=ref_sol.solve_time, note="reference"))
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


def from_fda_guess(dx, Gamma=4.1, length=40.0, periods=10, max_iter=40):
    """The stick TPS started directly on the pattern of a time-stepped guess run (no shooting)."""
    from validation.shooting import e0_kink_guess

    lat = tps.Lattice.planar(n_nodes=int(round(length / dx)) + 1, length=length)
    run = e0_kink_guess(lat, Gamma, 2, periods)
    pattern = ts.pattern_from_fda(run, lat, 4 * np.pi)
    sol = ts.solve_stick_lattice(lat, Gamma, 2, 0.0, pattern=pattern, tol=1e-10, max_iter=max_iter, refresh=0)
    return dict(dx=dx, Gamma=Gamma, periods=periods, converged=sol.converged, nit=sol.nit,
                residual0=float(sol.residual_history[0]), residual=sol.residual,
                solve_seconds=sol.solve_time, message=sol.message)


def pattern_vs_orbit(dx, Gamma=4.1, length=40.0, periods=(10, 40, 160), row=None):
    """The pattern read from the time-stepped guess after ``periods`` periods against the shooting
    orbit's: same contacts and kinds? same triggers? distance of the contact times."""
    from validation.shooting import e0_kink_guess

    row = row or kink_from_shooting(dx, Gamma)
    lat = row["lattice"]
    p0 = ts.pattern_from_orbit(row["orbit"])
    T = p0.period
    out = []
    for P in periods:
        p = ts.pattern_from_fda(e0_kink_guess(lat, Gamma, 2, P), lat, T)
        same = p.t.size == p0.t.size and bool(np.all(p.node == p0.node) and np.all(p.kind == p0.kind))
        r = dict(dx=dx, periods=P, contacts=p.t.size, orbit_contacts=p0.t.size, same_kinds=same,
                 triggered=int(np.sum(p.trigger >= 0)), orbit_triggered=int(np.sum(p0.trigger >= 0)))
        if same:
            r.update(same_triggers=bool(np.all(p.trigger == p0.trigger)),
                     time_distance=float(np.max(phase_distance(p.t, p0.t, T))))
        out.append(r)
    return out


def continuation(dx=2.0, Gamma=4.1, upto=4.11, row=None, step=0.02, max_step=0.05, n_checks=3):
    """The Gamma kink (impact-and-stick TPS on the shooting orbit's pattern) followed in Gamma by the
    library's continuation (:func:`tps_solver.continue_branch`), each of ``n_checks`` branch points
    checked against a direct Newton solve at that Gamma from the start pattern (a second method) and
    that solve against the FDA.  Returns (branch, rows)."""
    row = row or kink_from_shooting(dx, Gamma)
    start = row["solution"]
    pattern = start.pattern
    T = pattern.period
    tic = time.perf_counter()
    br = tps.continue_branch(start, "Gamma", (Gamma, upto), multipliers=False, step=step, max_step=max_step)
    seconds = time.perf_counter() - tic
    C = start.problem.C
    picks = np.unique(np.linspace(1, br.parameter_values.size - 1, n_checks).round().astype(int))
    out = []
    for k in picks:
        G2, x = float(br.parameter_values[k]), br.states[k]
        sol = ts.solve_stick_lattice(row["lattice"], G2, 2, 0.0, pattern=pattern, tol=1e-11, max_iter=30,
                                     refresh=0)
        r = dict(Gamma_start=f"{Gamma:g}", Gamma=f"{G2:.6g}", point=int(k), branch_points=int(br.parameter_values.size),
                 branch_seconds=seconds, converged=sol.converged, nit=sol.nit,
                 branch_vs_direct=float(np.max(phase_distance(sol.unknowns[:C], x[:C], T))),
                 time_shift=float(np.max(phase_distance(sol.pattern.t, pattern.t, T))),
                 all_pass=sol.checks.all_pass)
        if sol.converged:
            chk = ts.check_with_fda(sol, periods=2)
            r.update(fda_contact_error=chk.contact_error, fda_liftoff_error=chk.liftoff_error)
        out.append(r)
    return br, out


KINK_COLS = ["Gamma", "dx", "shooting_residual", "converged", "nit", "residual", "all_pass", "stick_w_max",
             "fda_contact_error", "fda_liftoff_error", "shooting_contact_distance", "front_width", "n_stick",
             "n_bounce", "n_triggered", "shortest_stick", "shooting_seconds", "tps_seconds", "check_seconds"]
BENCH_COLS = ["dx", "method", "periods_run", "error_start", "error_end", "rate", "periods_to_target",
              "extrapolated", "seconds_per_period", "fda_total_seconds", "guess_seconds", "shooting_seconds",
              "tps_seconds", "tps_chain_seconds", "ratio", "ratio_vs_tps_alone", "reference_gap"]
PARETO_COLS = ["n_basis", "n_quad", "converged", "nit", "residual", "contact_error", "liftoff_error",
               "shooting_distance", "solve_seconds"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("parts", nargs="*", default=["flat", "kinks"],
                    help="flat, kinks, patterns, fda_start, continuation, benchmark, pareto")
    ap.add_argument("--quick", action="store_true", help="kinks at dx = 2 only")
    ap.add_argument("--dx", type=float, nargs="*", default=None)
    ap.add_argument("--gammas", type=float, nargs="*", default=None)
    ap.add_argument("--max-periods", type=int, nargs="*", default=[1000, 300],
                    help="time-stepping periods per dx of the benchmark (then extrapolated)")
    args = ap.parse_args(argv)
    parts = args.parts
    if "flat" in parts:
        print("## Flat e = 0 orbit: TPS from a perturbed uniform start (perturbation 1e-2)\n")
        rows = [flat_errors(G, n) for G in GAMMAS for n in (1, 4)]
        print(_table(rows, ["Gamma", "n_nodes", "converged", "nit", "contact_error", "liftoff_error",
                            "t_liftoff", "t1", "t2"]))
    if "kinks" in parts:
        dxs = [2.0] if args.quick else (args.dx or [2.0, 1.0, 0.5])
        gammas = args.gammas or list(GAMMAS)
        print("\n## Lattice kinks (Neumann, L = 40, e = 0, M = 2), pattern from the shooting orbit\n")
        rows = []
        with one_blas_thread():
            for dx in dxs:
                for G in (gammas if dx == 2.0 else [4.1]):
                    rows.append(kink_from_shooting(dx, G))
                    print(_table(rows[-1:], KINK_COLS), flush=True)
        print()
        print(_table(rows, KINK_COLS))
    if "fda_start" in parts:
        print("\n## The stick TPS started on the pattern of the 10-period time-stepped guess (no shooting)\n")
        rows = [from_fda_guess(dx) for dx in (args.dx or [2.0])]
        print(_table(rows, ["dx", "Gamma", "periods", "converged", "nit", "residual0", "residual",
                            "solve_seconds"]))
    if "patterns" in parts:
        print("\n## Pattern of the time-stepped guess vs the shooting orbit's (Gamma = 4.1)\n")
        rows = [r for dx in (args.dx or [2.0, 1.0]) for r in pattern_vs_orbit(dx)]
        print(_table(rows, ["dx", "periods", "contacts", "orbit_contacts", "same_kinds", "triggered",
                            "orbit_triggered", "same_triggers", "time_distance"]))
    if "continuation" in parts:
        print("\n## The Gamma = 4.1 kink (dx = 2) followed in Gamma by tps.continue_branch\n")
        with one_blas_thread():
            br, rows = continuation()
        print(br.message)
        print(_table(rows, ["Gamma_start", "Gamma", "point", "branch_points", "branch_seconds", "converged", "nit",
                            "branch_vs_direct", "time_shift", "fda_contact_error", "fda_liftoff_error",
                            "all_pass"]))
    if "benchmark" in parts:
        print("\n## Benchmark: stick TPS (start -> shooting -> TPS) vs FDA time stepping to error 1e-8\n")
        rows = benchmark(tuple(args.dx or [2.0, 1.0]), max_periods=tuple(args.max_periods))
        print(_table(rows, BENCH_COLS))
    if "pareto" in parts:
        print("\n## Discretisation: error vs n_basis (n_quad = 16) and n_quad (n_basis = 6), dx = 2\n")
        with one_blas_thread():
            rows = discretisation_table(kink_from_shooting(2.0, 4.1))
        print(_table(rows, PARETO_COLS))


if __name__ == "__main__":
    main()
