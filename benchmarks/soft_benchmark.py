"""Benchmark of the fast soft-contact integrator (``tps_solver.solvers.fda.soft.SoftIntegrator``).

Run ``python -m benchmarks.soft_benchmark`` (add ``--full`` for the 17-node Radau comparison over two
periods, several minutes; ``--baseline FILE`` to time another version of ``tps_solver/fda/soft.py``
side by side on the 481-node kink, e.g. ``git show REV:tps_solver/fda/soft.py > /tmp/soft_old.py``;
``--repeat N`` alternates N runs of each and shows the fastest).
Every timing is taken with ``threadpoolctl.threadpool_limits(1)`` and is reported both as wall-clock
and as process CPU time (the machine may be shared: compare CPU times measured in one run).

Measured, side by side in one run:

* the soft flat orbit over ``periods`` periods against the closed form ``SoftFlatOrbit``: largest
  error of the entry and exit times;
* a kink against the Radau reference ``simulate_soft`` (rtol 1e-11): largest state difference at
  the output times, and the ratio of the run times;
* the 481-node kink (dx = 0.1, cutoff 0.3, 2 periods by default): seconds per period, steps and
  events (and, with ``--baseline``, the same for the other version and the CPU-time ratio).

``--paths`` instead prints one table (:func:`paths_table`): the numpy path (``compiled=False``), the
compiled path (``compiled=True``, :mod:`tps_solver.solvers.fda.soft_kernels`) and the Radau reference
(``method="soft-radau"``, its default tolerances rtol 1e-10, atol 1e-12) side by side, CPU seconds per
period (min of ``--repeat`` runs, one BLAS thread) on the 101-node flat Neumann lattice (dx 0.5,
heights perturbed by 1e-6 (x/L)^2) and the 481-node pinned kink (Radau there only with
``--radau-kink``: minutes), with the two paths' largest event-time difference and the compiled
path's final-state difference from Radau.
"""
import argparse
import importlib.util
import time

import numpy as np

import tps_solver as tps
from tps_solver.solvers.fda import flat_state, kink_state
from tps_solver.solvers.fda import simulate
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.solvers.fda.soft import SoftIntegrator
from validation.report import one_blas_thread


def simulate_soft(lattice, Gamma, e, w0, zeta0, t_start, t_end, **kw):
    """The Radau reference of the soft contact (``simulate(..., method="soft-radau")``)."""
    return simulate(lattice, Gamma, e, w0, zeta0, t_start, t_end, method="soft-radau", **kw)

GAMMA, E, M, ELL = 2.5, 0.45, 2, 0.3


def drive(integ, t, w, z, t_end, t_eval=()):
    """Advance ``integ`` to ``t_end`` (the driver loop); returns (t, w, z, events, samples)."""
    stuck = np.zeros(w.size, bool)
    events, samples = [], []
    while t < t_end:
        s = integ.advance(t, w, z, stuck, t_end, t_eval)
        t, w, z, stuck = s.t, s.w, s.zeta, s.stuck
        events += s.events
        samples += s.samples
    return t, w, z, events, samples


def _timed(fun):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fun()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def flat_orbit_errors(periods=50, n_nodes=3, **options):
    """Entry/exit times of the soft flat orbit against the closed form over ``periods`` periods.

    Returns
    -------
    dict
        ``entry_error``, ``exit_error`` (largest absolute time errors), ``n_events``, ``wall``, ``cpu``.
    """
    orb = SoftFlatOrbit(GAMMA, M, E, ELL)
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=2.0)
    ts = orb.t_exit + 0.5 * orb.flight
    w, z = orb.state(ts)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, **options)
    (_, _, _, events, _), wall, cpu = _timed(
        lambda: drive(integ, ts, np.full(n_nodes, w), np.full(n_nodes, z), ts + periods * orb.period))
    imp = np.array([ev[0] for ev in events if ev[2] == "impact"])
    out = np.array([ev[0] for ev in events if ev[2] == "liftoff"])
    t_in = orb.t_exit + orb.flight + orb.period * np.round((imp - orb.t_exit - orb.flight) / orb.period)
    return dict(periods=periods, entry_error=float(np.max(np.abs(imp - t_in))),
                exit_error=float(np.max(np.abs(out - t_in[:out.size] - orb.tau_c))),
                n_events=len(events), wall=wall, cpu=cpu)


def _kink_case(n_nodes, length, periods, n_samples):
    """The pinned kink of the Radau comparisons: lattice, start time, state, end and output times."""
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=length, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_end = t0 + periods * fl.period
    t_eval = t0 + (t_end - t0) * np.arange(1, n_samples + 1) / n_samples
    return lat, t0, w, z, t_end, t_eval


def _sample_errors(samples, ref):
    """Per output time, max(|dw|, |dzeta|) of the ``drive`` samples against a ``simulate`` run."""
    return [float(max(np.max(np.abs(ws - ref.w_eval[k])), np.max(np.abs(zs - ref.zeta_eval[k]))))
            for k, (_, ws, zs) in enumerate(samples)]


def kink_vs_radau(n_nodes=9, length=8.0, periods=1.0, rtol=1e-11, n_samples=4, baseline=None, **options):
    """A pinned kink: SoftIntegrator against Radau ``simulate_soft`` (rtol ``rtol``), times and errors.

    Returns
    -------
    dict
        ``state_error`` (largest |dw|, |dzeta| over the samples), ``errors`` per sample, event
        counts, ``soft_wall``/``soft_cpu``, ``radau_wall``/``radau_cpu`` and their ratios; with
        ``baseline`` (another ``SoftIntegrator`` class, :func:`load_baseline`) also
        ``baseline_cpu`` and ``baseline_error`` (its state error against the same reference).
    """
    lat, t0, w, z, t_end, t_eval = _kink_case(n_nodes, length, periods, n_samples)
    integ = SoftIntegrator(lat, GAMMA, E, cutoff=ELL, **options)
    (_, _, _, events, samples), s_wall, s_cpu = _timed(lambda: drive(integ, t0, w, z, t_end, t_eval))
    ref, r_wall, r_cpu = _timed(lambda: simulate_soft(lat, GAMMA, E, w, z, t0, t_end, cutoff=ELL,
                                                      t_eval=t_eval, rtol=rtol, atol=0.1 * rtol))
    errs = _sample_errors(samples, ref)
    extra = {}
    if baseline is not None:
        (_, _, _, _, bsamples), _, b_cpu = _timed(
            lambda: drive(baseline(lat, GAMMA, E, cutoff=ELL, **options), t0, w, z, t_end, t_eval))
        extra = dict(baseline_cpu=b_cpu, baseline_error=max(_sample_errors(bsamples, ref)))
    return dict(**extra, n_nodes=n_nodes, length=length, periods=periods, state_error=max(errs), errors=errs,
                soft_impacts=sum(ev[2] == "impact" for ev in events), radau_impacts=int(ref.n_events),
                soft_wall=s_wall, soft_cpu=s_cpu, radau_wall=r_wall, radau_cpu=r_cpu,
                ratio_wall=r_wall / s_wall, ratio_cpu=r_cpu / s_cpu, soft_steps=integ.n_steps,
                radau_steps=int(ref.n_steps))


def sensitivity(n_nodes=17, length=8.0, periods=2.0, n_samples=8, eps=1e-13, **options):
    """Largest state change per output time when the initial velocity of a kink moves by ``eps``.

    Measures the conditioning of the soft model itself (slow contacts amplify perturbations).

    Returns
    -------
    list of float
    """
    lat, t0, w, z, t_end, t_eval = _kink_case(n_nodes, length, periods, n_samples)
    runs = [drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL, **options), t0, w + d, z, t_end, t_eval)[4]
            for d in (0.0, eps)]
    return [float(max(np.max(np.abs(a[1] - b[1])), np.max(np.abs(a[2] - b[2])))) for a, b in zip(*runs)]


def load_baseline(path):
    """Another version of ``tps_solver/fda/soft.py`` (a file path), loaded as a module of ``tps_solver.solvers.fda``.

    Returns
    -------
    type
        Its ``SoftIntegrator`` class.
    """
    spec = importlib.util.spec_from_file_location("tps_solver.solvers.fda._soft_baseline", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.SoftIntegrator


def big_kink(n_nodes=481, dx=0.1, periods=1, integrator=SoftIntegrator, **options):
    """Seconds per period of the soft kink on ``n_nodes`` nodes with spacing ``dx`` (pinned ends).

    ``integrator``: the class to time (default ``SoftIntegrator``; see :func:`load_baseline`).

    Returns
    -------
    dict
        ``wall_per_period``, ``cpu_per_period``, ``n_steps``, ``n_rejected``, event counts.
    """
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=dx * (n_nodes - 1), boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    integ = integrator(lat, GAMMA, E, cutoff=ELL, **options)
    (_, wf, zf, events, _), wall, cpu = _timed(lambda: drive(integ, t0, w, z, t0 + periods * fl.period))
    kinds = [ev[2] for ev in events]
    return dict(n_nodes=n_nodes, dx=dx, periods=periods, wall_per_period=wall / periods,
                cpu_per_period=cpu / periods, n_steps=integ.n_steps, n_rejected=integ.n_rejected,
                events=len(events), impacts=kinds.count("impact"), liftoffs=kinds.count("liftoff"),
                sticks=kinds.count("stick"), w=wf, zeta=zf, event_times=np.array([ev[0] for ev in events]))


def _perturbed_flat_case(n_nodes=101, dx=0.5, pert=1e-6):
    """The 101-node perturbed flat lattice (Neumann) of the compiled-path table: lattice, t0, w, zeta, period."""
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=dx * (n_nodes - 1))
    t0 = fl.t0 + 1e-6
    w, z = flat_state(lat, fl, t0)
    return lat, t0, w, z + pert * np.linspace(0.0, 1.0, n_nodes) ** 2, fl.period


def _big_kink_case(n_nodes=481, dx=0.1):
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=dx * (n_nodes - 1), boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    return lat, t0, w, z, fl.period


def paths_table(repeat=3, flat_periods=2, kink_periods=1, radau_kink=False):
    """CPU seconds per period of the numpy path, the compiled path and Radau, side by side.

    Returns
    -------
    list of dict
        One row per case: ``numpy``, ``compiled``, ``radau`` (s/period, min of ``repeat``; ``radau``
        None where not run), their ratios, events, ``dt`` (largest event-time difference of the two
        paths, NaN if their event sequences differ) and ``radau_error`` (largest state difference at
        the end, compiled path against Radau).
    """
    cases = [("flat 101 nodes, dx 0.5, perturbed 1e-6", _perturbed_flat_case(), flat_periods, True),
             ("kink 481 nodes, dx 0.1", _big_kink_case(), kink_periods, radau_kink)]
    rows = []
    # compile the kernels (cached on disk) before timing
    drive(SoftIntegrator(tps.Lattice.planar(n_nodes=5, length=4.0), GAMMA, E, cutoff=ELL, compiled=True),
          0.0, np.full(5, -1.0), np.full(5, 0.01), 3.0)
    for label, (lat, t0, w, z, period), periods, with_radau in cases:
        t_end = t0 + periods * period
        runs = {"numpy": lambda: drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled=False), t0, w, z, t_end),
                "compiled": lambda: drive(SoftIntegrator(lat, GAMMA, E, cutoff=ELL, compiled=True), t0, w, z, t_end)}
        if with_radau:
            runs["radau"] = lambda: simulate_soft(lat, GAMMA, E, w, z, t0, t_end, cutoff=ELL)
        best, out = {k: np.inf for k in runs}, {}
        for _ in range(repeat):
            for name, fn in runs.items():
                out[name], _, cpu = _timed(fn)
                best[name] = min(best[name], cpu / periods)
        a, b = out["numpy"][3], out["compiled"][3]
        same = len(a) == len(b) and all(x[1:3] == y[1:3] for x, y in zip(a, b))
        dt = max(abs(x[0] - y[0]) for x, y in zip(a, b)) if same else float("nan")
        row = dict(case=label, periods=periods, events=len(b), numpy=best["numpy"], compiled=best["compiled"],
                   radau=best.get("radau"), same=same, dt=dt, radau_error=None)
        if "radau" in out:
            ref = out["radau"]
            row["radau_error"] = float(max(np.max(np.abs(out["compiled"][1] - ref.w)),
                                           np.max(np.abs(out["compiled"][2] - ref.zeta))))
        rows.append(row)
    return rows


def print_paths_table(rows, repeat):
    print(f"soft integrator: numpy path vs compiled path vs Radau (CPU s per period, min of {repeat}, one BLAS "
          "thread; Gamma 2.5, e 0.45, cutoff 0.3, stick_speed 1e-4)")
    print("| case | periods | events | numpy | compiled | Radau | numpy/compiled | Radau/numpy | Radau/compiled "
          "| max dt numpy-compiled | state diff compiled-Radau |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        rad, err = r["radau"], r["radau_error"]
        cells = [r["case"], str(r["periods"]), str(r["events"]), f"{r['numpy']:.3g}", f"{r['compiled']:.3g}",
                 f"{rad:.3g}" if rad else "-", f"{r['numpy'] / r['compiled']:.1f}",
                 f"{rad / r['numpy']:.0f}" if rad else "-", f"{rad / r['compiled']:.0f}" if rad else "-",
                 f"{r['dt']:.1e}" + ("" if r["same"] else " (events differ)"),
                 f"{err:.1e}" if err is not None else "-"]
        print("| " + " | ".join(cells) + " |")


def _kink_line(r, label=""):
    return (f"kink n={r['n_nodes']} dx={r['dx']:g} cutoff={ELL:g}{label}: {r['wall_per_period']:.2f} s wall / "
            f"{r['cpu_per_period']:.2f} s cpu per period over {r['periods']} period(s); {r['n_steps']} steps "
            f"({r['n_rejected']} rejected), {r['events']} events ({r['impacts']} impacts, {r['liftoffs']} "
            f"lift-offs, {r['sticks']} sticks)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="add the 17-node, 2-period Radau comparison")
    parser.add_argument("--periods", type=int, default=2, help="periods of the 481-node kink")
    parser.add_argument("--baseline", default=None,
                        help="path of another soft.py to time side by side on the 481-node kink")
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs of the 481-node kink (alternating with the baseline); the fastest is shown")
    parser.add_argument("--paths", action="store_true",
                        help="only the numpy / compiled / Radau table (paths_table)")
    parser.add_argument("--radau-kink", action="store_true", help="with --paths: Radau on the 481-node kink too")
    parser.add_argument("--flat-periods", type=int, default=2, help="with --paths: periods of the flat lattice")
    args = parser.parse_args(argv)
    if args.paths:
        with one_blas_thread():
            rows = paths_table(args.repeat, args.flat_periods, args.periods, args.radau_kink)
        print_paths_table(rows, args.repeat)
        return
    with one_blas_thread():
        r = flat_orbit_errors(50)
        print(f"flat orbit, 50 periods: entry error {r['entry_error']:.2e}, exit error "
              f"{r['exit_error']:.2e}, {r['n_events']} events, {r['wall']:.2f} s wall / {r['cpu']:.2f} s cpu")
        base = load_baseline(args.baseline) if args.baseline else None
        r = b = None
        for _ in range(args.repeat):                 # alternate; keep the fastest run of each
            ri = big_kink(periods=args.periods)
            r = ri if r is None or ri["cpu_per_period"] < r["cpu_per_period"] else r
            if base is not None:
                bi = big_kink(periods=args.periods, integrator=base)
                b = bi if b is None or bi["cpu_per_period"] < b["cpu_per_period"] else b
        print(_kink_line(r))
        if base is not None:
            print(_kink_line(b, f" (baseline {args.baseline})"))
            same = b["events"] == r["events"]
            dt = float(np.max(np.abs(b["event_times"] - r["event_times"]))) if same else float("nan")
            print(f"baseline / this: cpu ratio {b['cpu_per_period'] / r['cpu_per_period']:.2f}, wall ratio "
                  f"{b['wall_per_period'] / r['wall_per_period']:.2f}; final state difference "
                  f"{max(np.max(np.abs(b['w'] - r['w'])), np.max(np.abs(b['zeta'] - r['zeta']))):.1e}, "
                  f"event times {dt:.1e}" + ("" if same else " (event counts differ)"))
        # like for like with Radau (which has no sticking rule): a negligible capture speed
        cases = [dict(n_nodes=9, length=8.0, periods=1.0)]
        if args.full:
            cases.append(dict(n_nodes=17, length=8.0, periods=2.0, n_samples=8))
        for case in cases:
            r = kink_vs_radau(**case, stick_speed=1e-8, max_events=5000,
                              baseline=load_baseline(args.baseline) if args.baseline else None)
            print(f"kink n={r['n_nodes']} over {r['periods']:g} periods vs Radau (rtol 1e-11): state error "
                  f"{r['state_error']:.2e} (per sample {', '.join(f'{x:.1e}' for x in r['errors'])}); "
                  f"impacts {r['soft_impacts']} / {r['radau_impacts']}; soft {r['soft_wall']:.2f} s wall "
                  f"{r['soft_cpu']:.2f} s cpu, Radau {r['radau_wall']:.1f} s wall {r['radau_cpu']:.1f} s cpu; "
                  f"ratio {r['ratio_wall']:.0f} (wall) {r['ratio_cpu']:.0f} (cpu)"
                  + (f"; baseline soft {r['baseline_cpu']:.2f} s cpu, state error {r['baseline_error']:.2e}"
                     if "baseline_cpu" in r else ""))
        if args.full:
            d = sensitivity(stick_speed=1e-8, max_events=5000)
            print("kink n=17: state change per sample after a 1e-13 change of the initial w: "
                  + ", ".join(f"{x:.1e}" for x in d))


if __name__ == "__main__":
    main()
