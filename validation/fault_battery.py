"""The fault battery: concrete bad inputs and unbounded calls, each 'good' (refused by ValueError within
5 s, or an honest answer) or 'bad' (hangs, raw exception, silent answer).

Run ``python -m validation.fault_battery`` (about 10 s); it prints one row per item and the count.
"""
import os
import tempfile
import threading

import numpy as np
import tps_solver as tps


def battery():
    """Run every item; returns rows (name, 'good' or 'bad', what happened) and prints them."""
    fl = tps.FlatLayer(2.5, e=0.45)
    lat5 = tps.Lattice.planar(n_nodes=5, length=4.0)
    t = fl.t0 + 1.0
    w5, z5 = np.full(5, fl.velocity(t)), np.full(5, fl.height(t))
    rows = []

    def refuse(name, f, timeout=5.0):
        """good: ValueError within timeout (run in a thread; a hang counts as bad)."""
        out = {}
        def target():
            try:
                f(); out["r"] = "returned"
            except ValueError:
                out["r"] = "ValueError"
            except Exception as e:
                out["r"] = type(e).__name__
        th = threading.Thread(target=target, daemon=True); th.start(); th.join(timeout)
        r = out.get("r", "hang/slow")
        rows.append((name, "good" if r == "ValueError" else "bad", r))

    refuse("simulate t_end 1e9 periods", lambda: tps.simulate(lat5, 2.5, .45, w5, z5, t_start=t, t_end=t + 1e9 * 4 * np.pi))
    refuse("simulate soft cutoff 1e-12", lambda: tps.simulate(lat5, 2.5, .45, w5, z5, t_start=t, t_end=t + 4 * np.pi, method="soft", cutoff=1e-12))
    refuse("flat_basins n_samples 1e9", lambda: tps.flat_basins(2.5, 0.45, n_samples=10**9))
    refuse("solve_stick_lattice n_harmonics 1e9", lambda: tps.solve_stick_lattice(tps.Lattice.planar(n_nodes=9, length=40.0), n_harmonics=10**9))
    refuse("check_stability periods 1e9", lambda: tps.check_stability(fl, periods=10**9))
    refuse("continue_branch 3-tuple bounds", lambda: tps.continue_branch(fl, "Gamma", (2.3, 2.5, 2.7)))
    refuse("continue_branch multipliers='yes'", lambda: tps.continue_branch(fl, "Gamma", (2.4, 2.6), multipliers="yes"))
    refuse("continue_branch bothsides='yes'", lambda: tps.continue_branch(fl, "Gamma", (2.4, 2.6), bothsides="yes"))
    refuse("solve_stick_lattice w0 without zeta0", lambda: tps.solve_stick_lattice(tps.Lattice.planar(n_nodes=9, length=40.0), 4.1, w0=np.zeros(9)))
    refuse("front_width of a FlatLayer", lambda: tps.front_width(fl))
    refuse("load(None)", lambda: tps.load(None))
    refuse("load(123)", lambda: tps.load(123))
    d = tempfile.mkdtemp()
    refuse("load(directory)", lambda: tps.load(d))
    try:
        pat = tps.FlatLayer(4.5, 2, e=0.1).pattern
        rows.append(("FlatLayer(4.5, 2, e=0.1) falls back to the sticking orbit", "good" if pat == "stick" else "bad", pat))
    except ValueError:
        rows.append(("FlatLayer(4.5, 2, e=0.1) falls back to the sticking orbit", "bad", "ValueError"))
    # round trips
    try:
        cyc = tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=6, length=100.0))
        path = cyc.save(os.path.join(d, "c"))
        c2 = tps.load(path)
        same = c2.lattice.spacing == cyc.lattice.spacing and c2.e == cyc.e
        rows.append(("LatticeCycle round trip spacing/e bit-identical", "good" if same else "bad", str(same)))
    except Exception as e:
        rows.append(("LatticeCycle round trip", "bad", type(e).__name__))
    try:
        br = tps.continue_branch(fl, "Gamma", (2.3, 2.7))
        path = br.save(os.path.join(d, "b"))
        b2 = tps.load(path)
        same = ("time" in b2 and b2.time == br.time) and ("special_details" in b2)
        rows.append(("Branch keeps time and special_details", "good" if same else "bad", str(same)))
    except Exception as e:
        rows.append(("Branch round trip", "bad", type(e).__name__))
    good = sum(r[1] == "good" for r in rows)
    for r in rows: print("%-55s %-5s %s" % r)
    print(f"good {good} of {len(rows)}")
    return rows


# ------------------------------------------------------------------ the second battery
#: Run in a fresh process each (a hang, a crash or a memory blow-up stays there): the prelude, the
#: case's setup, then its call, which either raises (a ValueError is good for a "refuse" case when
#: the call itself took under 2 s) or, for a "check" case, sets ``good`` and ``what``.
_PRELUDE = r'''
import json, os, resource, sys, tempfile, time
import numpy as np
import tps_solver as tps
limit = 4 * 2 ** 30
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
fl = tps.FlatLayer(2.5, e=0.45)
def st(n):
    t = fl.t0 + 1.0
    return np.full(n, fl.velocity(t)), np.full(n, fl.height(t)), t
def lat(n, length):
    return tps.Lattice.planar(n_nodes=n, length=length)
def thick(**kw):
    from tps_solver.solvers.thickness import simulate_thickness
    w, z, t = st(5)
    args = dict(t_start=t, t_end=t + fl.period)
    args.update(kw)
    return simulate_thickness(lat(5, 4.0), args.pop("Gamma", 2.5), args.pop("e", 0.45), args.pop("w0", w), z,
                              np.ones(5), **args)
def stop(state):
    if state.iteration >= 3:
        raise KeyboardInterrupt
def exits(x):
    if x == 2:
        sys.exit(3)
    return x
import tps_solver.analyses.files, tps_solver.analyses.localized     # imports are not the call's time
'''

_BOMB = r'''
import io, zipfile
path = os.path.join(tempfile.mkdtemp(), "bomb.npz")
with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
    with zf.open("tree.npy", "w", force_zip64=True) as fh:
        head = io.BytesIO()
        np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False, "shape": (2400 << 17,)})
        fh.write(head.getvalue())
        for _ in range(2400):
            fh.write(bytes(1 << 20))
'''

_HUNG = r'''
import subprocess
script = os.path.join(tempfile.mkdtemp(), "hung.py")
with open(script, "w") as fh:
    fh.write("""
import threading
import tps_solver as tps
from tps_solver.analyses.sweep import SweepInterrupted
def task(x):
    if x == 0:
        threading.Event().wait()
    return x * x
if __name__ == "__main__":
    def stop(state):
        if state.iteration == 9:
            raise KeyboardInterrupt
    try:
        tps.sweep(task, {"x": list(range(10))}, max_workers=2, progress=False, callback=stop)
    except SweepInterrupted as exc:
        print("DONE", int(exc.finished.sum()), flush=True)
""")
'''

_TRUNCATED = r'''
d = tempfile.mkdtemp()
tps.sweep(abs, {"x": [1.0]}, executor="serial", store=d, progress=False)
with open(os.path.join(d, "sweep.json"), "w") as fh:
    fh.write('{"task": "bui')
'''

#: (name, kind, setup, call): a "refuse" case is good when ``call`` raises ValueError within 2 s;
#: a "check" case's call (statements) sets ``good`` and ``what``.
CASES2 = [
    ("lattice_kink 4001 nodes (dx 0.01, symmetric)", "refuse", "L = lat(4001, 40.0)",
     "tps.lattice_kink(L, symmetric=True)"),
    ("solve_kink e=0 by shooting, 2001 nodes", "refuse", "L = lat(2001, 20.0)",
     "tps.solve_kink(4.1, e=0.0, lattice=L)"),
    ("solve_kink e=0 anticontinuum, 4001 nodes", "refuse", "L = lat(4001, 40.0)",
     "tps.solve_kink(4.1, e=0.0, lattice=L, start='anticontinuum')"),
    ("solve_stick_lattice 2001 nodes", "refuse", "L = lat(2001, 20.0)", "tps.solve_stick_lattice(L)"),
    ("find_periodic_orbit dense multipliers, 3001 nodes", "refuse", "L = lat(3001, 30.0)",
     "tps.find_periodic_orbit(L, dense_max=10**4)"),
    ("check_stability jacobian=True, 4001 nodes", "refuse", "",
     "tps.check_stability(fl, n_nodes=4001, jacobian=True)"),
    ("continue_branch flat layer, step 1e-12, max_points 1e9", "refuse", "",
     "tps.continue_branch(fl, 'Gamma', (2.3, 2.7), step=1e-12, max_step=1e-12, min_step=1e-13, max_points=10**9)"),
    ("continue_branch stick solution, step 1e-12, max_points 1e9", "refuse", "S = tps.solve_stick_flat(4.1)",
     "tps.continue_branch(S, 'Gamma', (4.0, 4.2), step=1e-12, max_step=1e-12, min_step=1e-13, max_points=10**9)"),
    ("flat_basins reference engine, 1e6 samples", "refuse", "",
     "tps.flat_basins(2.5, 0.45, n_samples=10**6, engine='reference')"),
    ("simulate method='ode', 1e8 periods", "refuse", "w, z, t = st(5); L = lat(5, 4.0)",
     "tps.simulate(L, 2.5, .45, w, z, t_start=t, t_end=t + 1e8 * fl.period, method='ode')"),
    ("simulate record_segments, 1e6 periods (memory limit 0.1 GB)", "refuse",
     "w, z, t = st(5); L = lat(5, 4.0); from tps_solver.core import costs; costs.set_limits(memory=1e8)",
     "tps.simulate(L, 2.5, .45, w, z, t_start=t, t_end=t + 1e6 * fl.period, method='point', record_segments=True)"),
    ("simulate_thickness to 1e9 periods", "refuse", "", "thick(t_end=1e9 * fl.period)"),
    ("simulate_thickness max_events 1e12, chattering", "refuse", "",
     "thick(Gamma=4.0, e=0.9, stick_velocity=0.0, max_events=10**12)"),
    ("chatter_tail max_impacts 1e12 (power law)", "refuse", "",
     "tps.PowerLawRestitution(0.45, 4.0).chatter_tail(1.0, 1.0, max_impacts=10**12)"),
    ("front_width n_samples 1e10", "refuse",
     "from tps_solver.core.bunch import Bunch; K = Bunch(nodes=np.linspace(-1, 1, 6), period=4 * np.pi, "
     "t_start=0.0, height=lambda t: np.zeros((len(t), 6)))", "tps.front_width(K, n_samples=10**10)"),
    ("sweep over a 1e4 x 1e4 product", "refuse", "",
     "tps.sweep(abs, {'x': list(range(10**4)), 'y': list(range(10**4))}, executor='serial')"),
    ("sweep serial store of 1e6 points (time limit 5 min)", "refuse",
     "P = [{'x': float(i)} for i in range(10**6)]; from tps_solver.core import costs; costs.set_limits(time=300.0)",
     "tps.sweep(abs, P, executor='serial', store=tempfile.mkdtemp())"),
    ("FlatLayer(2.5, M=1e9)", "refuse", "", "tps.FlatLayer(2.5, M=10**9, e=0.45)"),
    ("Lattice.planar(length=1e-300)", "refuse", "", "lat(5, 1e-300)"),
    ("Lattice with spacing 1e-300", "refuse", "", "tps.Lattice(np.arange(5) * 1e-300)"),
    ("simulate w0 = +1e300", "refuse", "w, z, t = st(5)",
     "tps.simulate(lat(5, 4.0), 2.5, .45, w * 0 + 1e300, z, t_start=t, t_end=t + fl.period)"),
    ("simulate w0 = -1e300", "refuse", "w, z, t = st(5)",
     "tps.simulate(lat(5, 4.0), 2.5, .45, w * 0 - 1e300, z, t_start=t, t_end=t + fl.period)"),
    ("ThicknessRestitution at h = 1e300 (its limit 0, no warning)", "check",
     "import warnings; warnings.simplefilter('error'); from tps_solver.model.restitution import ThicknessRestitution",
     "r = ThicknessRestitution(0.45, h_e=2.0)(3.0, 1e300); good = r == 0.0; what = repr(r)"),
    ("simulate_thickness chi = 1e300 (a status, no warning)", "check",
     "import warnings; warnings.simplefilter('error')",
     "r = thick(chi=1e300, w0=st(5)[0] + 0.1 * np.arange(5)); good = not r.success and r.status == 2; "
     "what = 'status %d: %s' % (r.status, r.message[:50])"),
    ("ViscoelasticRestitution(b=1e300)(5)", "refuse", "", "tps.ViscoelasticRestitution(b=1e300)(5.0)"),
    ("ViscoelasticRestitution(0.5)(1e300)", "refuse", "", "tps.ViscoelasticRestitution(b=0.5)(1e300)"),
    ("PeriodMap stuck mask of the wrong shape", "refuse",
     "from tps_solver.solvers.shooting.period_map import PeriodMap",
     "PeriodMap(lat(5, 4.0), 2.5, .45, fl.period, 1.0, stuck=np.zeros(3, bool))"),
    ("simulate_thickness t_eval with nan", "refuse", "t = st(5)[2]", "thick(t_eval=[t + 0.1, np.nan, t + 0.5])"),
    ("check_stability perturbation = 1e300", "refuse", "", "tps.check_stability(fl, perturbation=1e300)"),
    ("check_stability perturbation = 1e3 (stable flat layer)", "refuse", "",
     "tps.check_stability(fl, perturbation=1e3)"),
    ("load: an unsealed zip bomb (2.5 GB in 2.4 MB)", "refuse", _BOMB, "tps.load(path)"),
    ("sweep: a truncated sweep.json", "refuse", _TRUNCATED,
     "tps.sweep(abs, {'x': [1.0, 2.0]}, executor='serial', store=d, progress=False)"),
    ("solve_stick_flat(3.0): the M = 1 orbit is not an f/2 orbit", "check", "",
     "r = tps.solve_stick_flat(3.0); good = not r.converged and r.status != 0; "
     "what = 'converged=%s, status %d' % (r.converged, r.status)"),
    ("flat_basins with a valid CallableRestitution", "check", "",
     "r = tps.flat_basins(2.5, tps.CallableRestitution(lambda v: 0.45 + 0 * np.asarray(v)), n_samples=8, "
     "periods=50); good = r.status == 0; what = 'status %d' % r.status"),
    ("sweep: sys.exit in one point", "check", "",
     "r = tps.sweep(exits, {'x': [1, 2, 3]}, executor='serial', progress=False); "
     "good = r.failed == [1] and r[2] == 3; what = 'failed points %s' % r.failed"),
    ("simulate_thickness Ctrl-C (a callback raises)", "check", "",
     "r = thick(t_end=fl.t0 + 1.0 + 20 * fl.period, callback=stop); good = r.status == 5; "
     "what = 'status %d' % r.status"),
    ("pool sweep with a hung point: Ctrl-C, then the process exits", "check", _HUNG,
     "p = subprocess.run([sys.executable, script], capture_output=True, text=True, timeout=60); "
     "good = p.returncode == 0 and 'DONE 9' in p.stdout; what = p.stdout.strip()[-30:]"),
]


def _run_case(name, kind, setup, call, env=None, timeout=60.0):
    """One case of :data:`CASES2` in a fresh process: ('good' or 'bad', what happened)."""
    import json
    import subprocess
    import sys

    body = "\n".join("    " + s for s in call.split("; ")) if kind == "check" else "    " + call
    prog = (_PRELUDE + "\n" + "\n".join(setup.split("; ")) + "\ntic = time.perf_counter()\n"
            "good, what = False, ''\ntry:\n" + body + "\n    outcome = 'returned'\n"
            "except Exception as exc:\n    outcome, what = type(exc).__name__, str(exc)[:120]\n"
            "print('RESULT ' + json.dumps([outcome, bool(good), what, time.perf_counter() - tic]), flush=True)\n")
    try:
        p = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return "bad", f"still running after {timeout:g} s"
    lines = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
    if not lines:
        return "bad", f"died (exit {p.returncode}): {p.stderr.strip()[-100:]}"
    outcome, good, what, seconds = json.loads(lines[-1][7:])
    if kind == "refuse":
        ok = outcome == "ValueError" and seconds < 2.0
        return ("good" if ok else "bad"), f"{outcome} after {seconds:.2g} s" + ("" if ok else f": {what[:70]}")
    ok = outcome == "returned" and good
    return ("good" if ok else "bad"), (what if outcome == "returned" else f"{outcome}: {what[:70]}")


def battery2(env=None, timeout=60.0):
    """Run every case of :data:`CASES2`, each in its own process; rows (name, verdict, what happened)."""
    rows = []
    for name, kind, setup, call in CASES2:
        # writing the bomb (2.4 GB through deflate) takes long on a loaded machine: not the call's time
        verdict, what = _run_case(name, kind, setup, call, env=env,
                                  timeout=4 * timeout if name.startswith("load:") else timeout)
        rows.append((name, verdict, what))
        print("%-62s %-5s %s" % (name, verdict, what), flush=True)
    print(f"good {sum(r[1] == 'good' for r in rows)} of {len(rows)}")
    return rows


def write(rows):
    """The section ``validation/sections/faults.md`` from the rows of :func:`battery`."""
    from validation.report import write_section

    good = sum(r[1] == "good" for r in rows)
    lines = ["## Faults: unbounded calls, loose options, interrupts, damaged files", "",
             f"The battery of `validation/fault_battery.py`: **{good} of {len(rows)} good** (7 of 16 at commit "
             "33c4ade). Good: refused by a `ValueError` naming the parameter within 5 s, or an honest answer.", "",
             "| item | verdict | what happened |", "|---|---|---|"]
    lines += [f"| {name} | {verdict} | {what} |" for name, verdict, what in rows]
    lines += ["", "Also in the default suite: `tests/test_interrupts.py` (SIGINT in a subprocess in 9 long calls: "
              "status 5 and an honest message in each), `tests/test_sweep_faults.py` (failed, corrupted and swapped "
              "points, a crashed worker, kill -9 then resume), `tests/test_file_faults.py` (1080 damaged files: "
              "1001 ValueErrors, 79 identical loads, 0 different values), `tests/test_refusals.py` (a test per "
              "unbounded call).", "", "Printed by `python -m validation.fault_battery`."]
    write_section("faults", "\n".join(lines))


#: The second battery at commit af36af4 (before its fixes), measured by
#: ``battery2(env=...)`` with that commit's package on PYTHONPATH and a 20 s limit per case.
BEFORE2 = [
    ('lattice_kink 4001 nodes (dx 0.01, symmetric)',
     'bad', 'still running after 20 s'),
    ('solve_kink e=0 by shooting, 2001 nodes',
     'bad', 'still running after 20 s'),
    ('solve_kink e=0 anticontinuum, 4001 nodes',
     'bad', 'still running after 20 s'),
    ('solve_stick_lattice 2001 nodes',
     'bad', 'still running after 20 s'),
    ('find_periodic_orbit dense multipliers, 3001 nodes',
     'bad', 'still running after 20 s'),
    ('check_stability jacobian=True, 4001 nodes',
     'bad', 'still running after 20 s'),
    ('continue_branch flat layer, step 1e-12, max_points 1e9',
     'bad', 'still running after 20 s'),
    ('continue_branch stick solution, step 1e-12, max_points 1e9',
     'bad', 'still running after 20 s'),
    ('flat_basins reference engine, 1e6 samples',
     'bad', 'still running after 20 s'),
    ("simulate method='ode', 1e8 periods",
     'bad', 'still running after 20 s'),
    ('simulate record_segments, 1e6 periods (memory limit 0.1 GB)',
     'bad', 'still running after 20 s'),
    ('simulate_thickness to 1e9 periods',
     'bad', 'still running after 20 s'),
    ('simulate_thickness max_events 1e12, chattering',
     'bad', 'returned after 0.36 s: '),
    ('chatter_tail max_impacts 1e12 (power law)',
     'bad', 'still running after 20 s'),
    ('front_width n_samples 1e10',
     'bad', 'MemoryError after 0.00015 s: Unable to allocate 74.5 GiB for an array '),
    ('sweep over a 1e4 x 1e4 product',
     'bad', 'still running after 20 s'),
    ('sweep serial store of 1e6 points (time limit 5 min)',
     'bad', 'still running after 20 s'),
    ('FlatLayer(2.5, M=1e9)',
     'bad', 'still running after 20 s'),
    ('Lattice.planar(length=1e-300)',
     'bad', 'returned after 0.00055 s: '),
    ('Lattice with spacing 1e-300',
     'bad', 'returned after 0.021 s: '),
    ('simulate w0 = +1e300',
     'bad', 'returned after 0.11 s: '),
    ('simulate w0 = -1e300',
     'bad', 'returned after 0.073 s: '),
    ('ThicknessRestitution at h = 1e300 (its limit 0, no warning)',
     'bad', 'RuntimeWarning: overflow encountered in scalar power'),
    ('simulate_thickness chi = 1e300 (a status, no warning)',
     'bad', 'RuntimeWarning: overflow encountered in divide'),
    ('ViscoelasticRestitution(b=1e300)(5)',
     'bad', 'RuntimeError after 7.1 s: the viscoelastic collision with kappa = 1.37'),
    ('ViscoelasticRestitution(0.5)(1e300)',
     'bad', 'RuntimeError after 6.8 s: the viscoelastic collision with kappa = 5.00'),
    ('PeriodMap stuck mask of the wrong shape',
     'bad', 'returned after 0.00067 s: '),
    ('simulate_thickness t_eval with nan',
     'bad', 'returned after 0.45 s: '),
    ('check_stability perturbation = 1e300',
     'bad', 'still running after 20 s'),
    ('check_stability perturbation = 1e3 (stable flat layer)',
     'bad', 'returned after 1.9 s: '),
    ('load: an unsealed zip bomb (2.5 GB in 2.4 MB)',
     'bad', 'ValueError after 29 s: decompressed everything first'),
    ('sweep: a truncated sweep.json',
     'bad', 'JSONDecodeError after 0.00048 s: Unterminated string starting at: line'),
    ('solve_stick_flat(3.0): the M = 1 orbit is not an f/2 orbit',
     'bad', 'converged=True, status 0'),
    ('flat_basins with a valid CallableRestitution',
     'bad', "ValueError: params['e'] has type CallableRestitution, which cannot be "),
    ('sweep: sys.exit in one point',
     'bad', 'died (exit 3): '),
    ('simulate_thickness Ctrl-C (a callback raises)',
     'bad', "TypeError: simulate_thickness() got an unexpected keyword argument 'ca"),
    ('pool sweep with a hung point: Ctrl-C, then the process exits',
     'bad', 'still running after 20 s'),
]


def write2(rows, before=None):
    """The section ``validation/sections/faults2.md`` from the rows of :func:`battery2`."""
    from validation.report import write_section

    before = BEFORE2 if before is None else before
    good = sum(r[1] == "good" for r in rows)
    was = {name: verdict for name, verdict, _ in before} if before else {}
    head = (f"**{good} of {len(rows)} good** ({sum(v == 'good' for v in was.values())} of {len(was)} at commit "
            "af36af4, the same cases with that commit's package, 20 s per case)" if was
            else f"**{good} of {len(rows)} good**")
    whats = {name: what for name, _, what in before} if before else {}
    lines = ["## Faults, second battery: sizes out of reach, raw inputs, honest flags", "",
             f"`validation/fault_battery.py` `battery2()`: {head}. Each case runs in its own process (4 GB "
             "address-space limit). Good: a `ValueError` naming the estimate or the parameter within 2 s of the "
             "call (refusals are decided from measured per-unit costs before any heavy work), or the honest "
             "flag (status 2, 5 or 9, `converged=False`).", "",
             "| case | before (af36af4) | after |", "|---|---|---|"]
    lines += [f"| {name} | {was.get(name, '-')}: {whats.get(name, '')} | {verdict}: {what} |"
              for name, verdict, what in rows]
    lines += ["", "Two cases are refused only under a lowered limit: their lower-bound estimates are within the "
              "default limits (1 h, 80 % of the available memory), so they run: `simulate(record_segments=True)` "
              "over 1e6 periods (at least 0.49 GB of records, 23 s) and a serial sweep storing 1e6 points (at "
              "least 0.5 ms of overhead per point, 8 min). `solve_kink(3.9 or 4.1, e=0, start='anticontinuum')` "
              "on 6 and 7 nodes now ends with `converged=False` and the discovery's message (50 s; a slow test) "
              "instead of an internal `ValueError`.", "",
              "Tests: `tests/test_fault_battery2.py` (each case in process, asserting its outcome; Ctrl-C and the "
              "hung worker by a callback that raises at a chosen point). Printed by "
              "`python -m validation.fault_battery` (the before column: `battery2(env=...)` with af36af4's "
              "package on PYTHONPATH, 20 s per case)."]
    write_section("faults2", "\n".join(lines))


def main():
    """Run both batteries and write their sections."""
    rows = battery()
    write(rows)
    rows2 = battery2()
    write2(rows2)
    return rows, rows2


if __name__ == "__main__":
    main()
