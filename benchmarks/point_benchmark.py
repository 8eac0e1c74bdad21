"""Point impacts: ``PointIntegrator`` against ``method="exact"`` (and heyoka, if installed).

Flat planar Neumann lattice (length 10), Gamma = 2.5, e = 0.45, started on the flat orbit at
``t0 + 1e-6``; the exact contacts are ``t0 + kT``.  For each lattice size the methods run
interleaved, ``--repeat`` times, in one process with one BLAS thread (threadpoolctl); the
minimum of the CPU time (``time.process_time``) is reported, since the machine is shared
and noisy.

* ``ms/period (10)``: wall time of a 10-period run (set-up included, heyoka's compilation not)
  divided by 10;
* ``ms/period (steady)``: ``(time(30 periods) - time(10 periods)) / 20``;
* ``error``: max |t_contact - (t0 + kT)| over the contacts of the 10-period run.

With ``--kink`` it also times a 41-node pinned kink over 2 periods (``exact`` against the new
integrator) and checks that the event sequences agree.

With ``--split`` it also reports, for ``point``, how the steady time per period divides into
:meth:`PointIntegrator.advance` and the rest of the shared driver loop (impact rule, event log;
``simulate`` run with a timing subclass registered in ``driver.METHODS`` for the measurement only).
The split uses ``(time(310 periods) - time(10 periods)) / 300`` (the driver loop is a few
10 µs per period, below the noise of a 20-period difference).

With ``--baseline REV`` it also times ``point`` on the flat lattices with the event layer and
driver loop of git revision ``REV`` (``tps_solver/fda/events.py`` and ``driver.py`` read by
``git show``; the integrators of the working tree, their ``event_sets`` swapped for the old one
during the old runs) against the working tree, interleaved, over 10 and 310 periods, and checks
that both give bitwise identical results on the 41-node kink and on an e = 0 run with sticking.

With ``--compiled`` it runs the cases of the compiled-kernel table (21 and 101 nodes, dx 0.5 and
0.1, flat and perturbed by 1e-6 in the heights; 10 periods): ``point`` with its numpy search
(``compiled=False``), with the compiled search (``compiled=True``, the ``fast`` extra),
``exact`` and heyoka, interleaved, and checks that the two ``point`` paths give the same event
sequence (``--write``: to ``validation/sections/compiled_point.md``).

heyoka is a benchmark-only dependency (``pip install heyoka``); it is skipped when absent.

Run::

    PYTHONPATH=. python benchmarks/point_benchmark.py [--repeat 3] [--kink] [--split] [--baseline REV]
        [--compiled [--write]]
    (from the repository root)
"""
import argparse
import subprocess
import time
import types

import numpy as np
from threadpoolctl import threadpool_limits

import tps_solver as tps
from tps_solver.solvers.fda import driver, exact, flat_state, kink_state, ode, point
from tps_solver.solvers.fda.point import PointIntegrator

GAMMA, E, M = 2.5, 0.45, 2
LENGTH = 10.0
SPLIT_PERIODS = (10, 310)


def run_point(lattice, w0, zeta0, t_start, t_end):
    """``simulate(..., method="point")``; returns the event records (same driver as ``run_exact``)."""
    return tps.simulate(lattice, GAMMA, E, w0, zeta0, t_start=t_start, t_end=t_end, method="point").events


def run_exact(lattice, w0, zeta0, t_start, t_end):
    return tps.simulate(lattice, GAMMA, E, w0, zeta0, t_start=t_start, t_end=t_end, method="exact").events


class Heyoka:
    """The same lattice as a heyoka Taylor integrator with one terminal event per node."""

    def __init__(self, lattice):
        import heyoka as hy

        self.hy = hy
        n = lattice.n_nodes
        L = lattice.operator
        w = list(hy.make_vars(*[f"w{i}" for i in range(n)]))
        z = list(hy.make_vars(*[f"z{i}" for i in range(n)]))
        g = hy.sin(hy.time) - 1.0 / GAMMA
        sys = [(w[i], hy.sum([L[i, j] * w[j] for j in np.flatnonzero(L[i])]) + g) for i in range(n)]
        sys += [(z[i], w[i]) for i in range(n)]
        events = [hy.t_event(z[i], direction=hy.event_direction.negative) for i in range(n)]
        tic = time.perf_counter()
        self.ta = hy.taylor_adaptive(sys, np.zeros(2 * n), t_events=events)
        self.compile_time = time.perf_counter() - tic
        self.n = n

    def __call__(self, lattice, w0, zeta0, t_start, t_end):
        ta, n = self.ta, self.n
        ta.time = t_start
        ta.state[:n] = w0
        ta.state[n:] = zeta0
        times = []
        while True:
            ta.propagate_until(t_end)
            if ta.time >= t_end:
                break
            s = ta.state
            wv, zv = s[:n], s[n:]
            # the simultaneous set (54): every node at the plate to round-off, approaching
            con = (zv <= np.maximum(1e-12 * np.abs(wv), 1e-15)) & (wv < 0)
            times.extend([ta.time] * int(np.count_nonzero(con)))
            s[:n][con] = -E * wv[con]
            s[n:][con] = 0.0
        return np.rec.fromarrays([np.array(times)], names="t")


class _TimedPoint(PointIntegrator):
    """``PointIntegrator`` accumulating the CPU time of :meth:`advance` in ``spent[0]``."""

    spent = [0.0]

    def advance(self, *args, **kwargs):
        tic = time.process_time()
        try:
            return super().advance(*args, **kwargs)
        finally:
            self.spent[0] += time.process_time() - tic


def split_table(repeat):
    """Steady ms/period of ``point``: total, inside ``advance``, and the driver loop around it."""
    fl = tps.FlatLayer(GAMMA, M, E)
    t0 = fl.t0 + 1e-6
    driver.METHODS["point-timed"] = _TimedPoint
    try:
        print("\n| nodes | total | advance | driver loop |")
        print("|---|---|---|---|")
        for n in (21, 101):
            lat = tps.Lattice.planar(n_nodes=n, length=LENGTH)
            w, z = flat_state(lat, fl, t0)
            best = {}
            for _ in range(repeat):
                for periods in SPLIT_PERIODS:
                    _TimedPoint.spent[0] = 0.0
                    tic = time.process_time()
                    tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + periods * fl.period + 0.5,
                                 method="point-timed")
                    total = time.process_time() - tic
                    if total < best.get(periods, (np.inf,))[0]:
                        best[periods] = (total, _TimedPoint.spent[0])
            short, long_ = SPLIT_PERIODS
            tot = 1e3 * (best[long_][0] - best[short][0]) / (long_ - short)
            adv = 1e3 * (best[long_][1] - best[short][1]) / (long_ - short)
            print(f"| {n} | {tot:.3f} | {adv:.3f} | {tot - adv:.3f} |")
    finally:
        del driver.METHODS["point-timed"]


def _baseline(rev):
    """``simulate`` and ``event_sets`` of the event layer and driver of git revision ``rev``."""
    def source(name):
        return subprocess.run(["git", "show", f"{rev}:tps_solver/fda/{name}.py"], capture_output=True,
                              text=True, check=True).stdout

    ev = types.ModuleType("events_" + rev)
    ev.__package__ = "tps_solver.solvers.fda"
    exec(compile(source("events"), f"{rev}:tps_solver/fda/events.py", "exec"), ev.__dict__)
    lines = source("driver").splitlines(keepends=True)
    imp = [i for i, line in enumerate(lines) if line.startswith("from .events import")]
    assert len(imp) == 1, "the driver of this revision does not import the event layer in one line"
    names = [x.strip() for x in lines[imp[0]].split("import", 1)[1].split(",")]
    lines[imp[0]] = "\n"
    drv = types.ModuleType("driver_" + rev)
    drv.__package__ = "tps_solver.solvers.fda"
    drv.__dict__.update({name: getattr(ev, name) for name in names})
    exec(compile("".join(lines), f"{rev}:tps_solver/fda/driver.py", "exec"), drv.__dict__)
    return drv.simulate, ev.event_sets


def baseline_table(rev, repeat):
    """Steady ms/period of ``point``: event layer and driver of ``rev`` against the working tree."""
    old_simulate, old_event_sets = _baseline(rev)
    users = (exact, ode, point)
    current = [m.event_sets for m in users]
    fl = tps.FlatLayer(GAMMA, M, E)
    t0 = fl.t0 + 1e-6
    short, long_ = SPLIT_PERIODS
    print(f"\n| nodes | point, driver + events of {rev} | point, working tree | saved | ratio |")
    print("|---|---|---|---|---|")
    for n in (21, 101):
        lat = tps.Lattice.planar(n_nodes=n, length=LENGTH)
        w, z = flat_state(lat, fl, t0)
        best = {}
        for _ in range(repeat):
            for which, sim, es in (("old", old_simulate, old_event_sets), ("new", tps.simulate, None)):
                for m, cur in zip(users, current):
                    m.event_sets = es or cur
                try:
                    for periods in SPLIT_PERIODS:
                        tic = time.process_time()
                        sim(lat, GAMMA, E, w, z, t_start=t0, t_end=t0 + periods * fl.period + 0.5, method="point")
                        dt = time.process_time() - tic
                        best[which, periods] = min(best.get((which, periods), np.inf), dt)
                finally:
                    for m, cur in zip(users, current):
                        m.event_sets = cur
        old, new = (1e3 * (best[k, long_] - best[k, short]) / (long_ - short) for k in ("old", "new"))
        print(f"| {n} | {old:.3f} | {new:.3f} | {old - new:.3f} | {old / new:.2f} |")
    baseline_identity(rev, old_simulate, old_event_sets)


def baseline_identity(rev, old_simulate, old_event_sets):
    """Bitwise comparison of the results of ``rev`` and the working tree (kink; e = 0 with sticking)."""
    fl = tps.FlatLayer(GAMMA, M, E)
    kink = tps.Lattice.planar(n_nodes=41, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    fl0 = tps.FlatLayer(Gamma=4.1, e=0.0)
    lat5 = tps.Lattice.planar(n_nodes=5, length=4.0)
    t1 = fl0.t0 + 0.3
    w5, z5 = flat_state(lat5, fl0, t1)
    cases = [("kink, 41 nodes, 2 periods", kink, GAMMA, E, *kink_state(kink, fl, t0, width=2.0), t0,
              t0 + 2 * fl.period),
             ("e = 0, Gamma = 4.1, 5 nodes, 3 periods", lat5, 4.1, 0.0, w5,
              z5 * (1 + 0.05 * np.cos(np.pi * lat5.nodes / 4.0)), t1, t1 + 3 * fl0.period)]
    users = (exact, ode, point)
    current = [m.event_sets for m in users]
    print(f"\nresults of {rev} and the working tree (events, final t, w, zeta, stuck, status):")
    for label, lat, G, e, w, z, ta, tb in cases:
        for method in ("exact", "point"):
            out = []
            for sim, es in ((old_simulate, old_event_sets), (tps.simulate, None)):
                for m, cur in zip(users, current):
                    m.event_sets = es or cur
                try:
                    out.append(sim(lat, G, e, w, z, t_start=ta, t_end=tb, method=method))
                finally:
                    for m, cur in zip(users, current):
                        m.event_sets = cur
            a, b = out
            same = (a.events.dtype == b.events.dtype and a.events.tobytes() == b.events.tobytes()
                    and all(np.asarray(getattr(a, f)).tobytes() == np.asarray(getattr(b, f)).tobytes()
                            for f in ("t", "w", "zeta", "stuck")) and a.status == b.status)
            kinds = ", ".join(f"{k} {int(np.sum(b.events.kind == k))}" for k in ("impact", "stick", "liftoff"))
            print(f"  {label}, {method}: {b.n_events} events ({kinds}); bitwise identical: {same}")


def contact_error(events, fl):
    t = np.asarray(events.t)
    k = np.rint((t - fl.t0) / fl.period)
    return float(np.max(np.abs(t - fl.t0 - k * fl.period))) if t.size else float("nan")


def flat_table(repeat):
    fl = tps.FlatLayer(GAMMA, M, E)
    t0 = fl.t0 + 1e-6
    rows = []
    for n in (21, 101):
        lat = tps.Lattice.planar(n_nodes=n, length=LENGTH)
        w, z = flat_state(lat, fl, t0)
        methods = {"exact": run_exact, "point": lambda *a: run_point(*a)}
        try:
            hyk = Heyoka(lat)
            methods["heyoka"] = hyk
            print(f"n = {n}: heyoka compiled in {hyk.compile_time:.2f} s (not timed)")
        except ImportError:
            print("heyoka not installed: skipped")
        best = {name: [np.inf, np.inf] for name in methods}
        errors = {}
        for _ in range(repeat):
            for name, fn in methods.items():
                for i, periods in enumerate((10, 30)):
                    tic = time.process_time()
                    ev = fn(lat, w, z, t0, t0 + periods * fl.period + 0.5)
                    best[name][i] = min(best[name][i], time.process_time() - tic)
                    if periods == 10:
                        errors[name] = contact_error(ev, fl)
                        n_sets = np.unique(np.asarray(ev.t)).size
                        assert n_sets == 10, (name, n_sets)
        for name in methods:
            t10, t30 = best[name]
            rows.append((n, name, 1e3 * t10 / 10, 1e3 * (t30 - t10) / 20, errors[name]))
    print("\n| nodes | method | ms/period (10) | ms/period (steady) | contact-time error, 10 periods |")
    print("|---|---|---|---|---|")
    for n, name, a, b, err in rows:
        print(f"| {n} | {name} | {a:.3f} | {b:.3f} | {err:.1e} |")
    print("\nratios (steady state):")
    for n in (21, 101):
        sel = {name: b for m, name, a, b, err in rows if m == n}
        line = f"  n = {n}: exact/point = {sel['exact'] / sel['point']:.1f}"
        if "heyoka" in sel:
            line += f", point/heyoka = {sel['point'] / sel['heyoka']:.2f}"
        print(line)


def kink_check(repeat):
    fl = tps.FlatLayer(GAMMA, M, E)
    lat = tps.Lattice.planar(n_nodes=41, length=20.0, boundary="pinned")
    t0 = fl.t0 + 1.0
    w, z = kink_state(lat, fl, t0, width=2.0)
    t_end = t0 + 2 * fl.period
    best = {"exact": np.inf, "point": np.inf}
    for _ in range(repeat):
        tic = time.process_time()
        a = run_exact(lat, w, z, t0, t_end)
        best["exact"] = min(best["exact"], time.process_time() - tic)
        tic = time.process_time()
        b = run_point(lat, w, z, t0, t_end)
        best["point"] = min(best["point"], time.process_time() - tic)
    same = a.size == b.size and np.array_equal(a.node, b.node) and np.array_equal(a.kind, b.kind)
    dt = float(np.max(np.abs(a.t - b.t))) if same else float("nan")
    print(f"\nkink, 41 nodes, 2 periods: {a.size} events; exact {best['exact']:.2f} s, point "
          f"{best['point']:.2f} s (ratio {best['exact'] / best['point']:.1f}); same nodes and kinds: "
          f"{same}; max |dt| = {dt:.1e}")


#: (nodes, spacing, perturbation of the heights) of the compiled-kernel table
COMPILED_CASES = [(21, 0.5, 0.0), (21, 0.5, 1e-6), (101, 0.5, 0.0), (101, 0.5, 1e-6), (101, 0.1, 0.0)]


def compiled_table(repeat, periods=10):
    """Rows of ms/period for point (numpy), point (compiled), exact and heyoka on COMPILED_CASES."""
    fl = tps.FlatLayer(GAMMA, M, E)
    t0 = fl.t0 + 1e-6
    rows = []
    for n, dx, pert in COMPILED_CASES:
        lat = tps.Lattice.planar(n_nodes=n, length=dx * (n - 1))
        w, z = flat_state(lat, fl, t0)
        z = z + pert * np.linspace(0.0, 1.0, n) ** 2
        t_end = t0 + periods * fl.period + 0.5
        methods = {
            "point (numpy)": lambda: tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t_end, method="point",
                                                  compiled=False).events,
            "point (compiled)": lambda: tps.simulate(lat, GAMMA, E, w, z, t_start=t0, t_end=t_end,
                                                     method="point", compiled=True).events,
            "exact": lambda: run_exact(lat, w, z, t0, t_end),
        }
        try:
            hyk = Heyoka(lat)
            methods["heyoka"] = lambda: hyk(lat, w, z, t0, t_end)
        except ImportError:
            pass
        best, events = {k: np.inf for k in methods}, {}
        for _ in range(repeat):
            for name, fn in methods.items():
                tic = time.process_time()
                events[name] = fn()
                best[name] = min(best[name], time.process_time() - tic)
        a, b = events["point (numpy)"], events["point (compiled)"]
        same = a.size == b.size and np.array_equal(a.node, b.node) and np.array_equal(a.kind, b.kind)
        dt = float(np.max(np.abs(a.t - b.t))) if same and a.size else float("nan")
        row = dict(nodes=n, dx=dx, perturbed=pert > 0, events=int(b.size), same=same, dt=dt,
                   error=contact_error(b, fl) if pert == 0 else None)
        for name in methods:
            row[name] = 1e3 * best[name] / periods
        hy = row.get("heyoka")
        row["numpy/heyoka"] = row["point (numpy)"] / hy if hy else None
        row["compiled/heyoka"] = row["point (compiled)"] / hy if hy else None
        row["exact/compiled"] = row["exact"] / row["point (compiled)"]
        rows.append(row)
    return rows


def compiled_section(rows, periods=10):
    from validation.report import markdown_table

    cols = [("nodes", "nodes"), ("dx", "dx"), ("start", lambda r: "perturbed 1e-6" if r["perturbed"] else "flat"),
            ("events", "events"), ("point numpy ms/period", "point (numpy)"),
            ("point compiled ms/period", "point (compiled)"), ("exact ms/period", "exact"),
            ("heyoka ms/period", lambda r: r.get("heyoka")), ("numpy / heyoka", "numpy/heyoka"),
            ("compiled / heyoka", "compiled/heyoka"), ("exact / compiled", "exact/compiled"),
            ("same events (numpy, compiled)", lambda r: "yes" if r["same"] else "NO"),
            ("max dt", "dt"), ("flat contact-time error", "error")]
    return ("## Compiled kernels: point impacts against heyoka\n\n"
            f"Planar Neumann lattices, Gamma = {GAMMA}, e = {E}, started on the flat orbit at t0 + 1e-6 "
            f"(heights perturbed by 1e-6 (x/L)^2 where said), {periods} periods, one BLAS thread, CPU time, "
            "minimum over interleaved runs; heyoka's compilation not timed "
            "(`PYTHONPATH=. python benchmarks/point_benchmark.py --compiled --write`). `point numpy`: the "
            "reference path (`compiled=False`); `point compiled`: the contact search of each segment as one "
            "numba kernel (`tps_solver/solvers/fda/point_kernels.py`), the default with the `fast` extra. "
            "'max dt': largest difference of the two paths' event times (the perturbed starts break up into "
            "chatter, whose event times amplify last-bit differences). Flat contact-time error: max "
            "|t - (t0 + kT)| of the compiled path.\n\n" + markdown_table(rows, cols) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--kink", action="store_true")
    parser.add_argument("--split", action="store_true")
    parser.add_argument("--baseline", metavar="REV", help="git revision of the old event layer and driver")
    parser.add_argument("--compiled", action="store_true", help="the compiled-kernel table (see the docstring)")
    parser.add_argument("--write", action="store_true", help="with --compiled: write the REPORT section")
    args = parser.parse_args()
    if args.compiled:
        with threadpool_limits(1):
            text = compiled_section(compiled_table(args.repeat))
        print(text)
        if args.write:
            from validation.report import write_section
            print("wrote", write_section("compiled_point", text))
        return
    with threadpool_limits(1):
        flat_table(args.repeat)
        if args.split:
            split_table(args.repeat)
        if args.baseline:
            baseline_table(args.baseline, args.repeat)
        if args.kink:
            kink_check(max(1, args.repeat // 2))


if __name__ == "__main__":
    main()
