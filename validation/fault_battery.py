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


def main():
    """Run the battery and write its section."""
    rows = battery()
    write(rows)
    return rows


if __name__ == "__main__":
    main()
