"""TPS against FDA on one discrete model: exact lattice cycles, the spectral lattice TPS, the FDA.

The continuum TPS (Green's-function quadrature) and the FDA (finite-difference
lattice) discretise the Laplacian differently, so comparing them mixes two
discretisation errors.  Here all three methods work on the *same* lattice:

* ``solve_lattice_cycle`` -- exact single-contact periodic orbits (the TPS summed
  to all orders, closed-form periodic response);
* ``solve_lattice`` -- the spectral TPS with N harmonics on that lattice;
* the FDA (``simulate``, ``check_stability``) -- event-driven integration.

Every function returns its numbers; ``main()`` writes ``validation/sections/lattice.md``.
Run:  python -m validation.lattice_tps     (about a minute)
"""
import math
import os
import time

import numpy as np

import tps_solver as tps
from tps_solver.solvers.fda import simulate
from validation.tps_branches import table4

HERE = os.path.dirname(os.path.abspath(__file__))
SECTION = os.path.join(HERE, "sections", "lattice.md")


def _lattice(kind, n, size, grid="uniform"):
    if kind == "planar":
        return tps.Lattice.planar(n_nodes=n, length=size, boundary="neumann")
    return tps.Lattice.axisymmetric(n_nodes=n, r_max=size, grid=grid)


def _cycle(kind, n=8, size=140.0, **kw):
    kw = dict(dict(Gamma=2.5, M=2, e=0.45, t0=None, r_core=0.21 * size), **kw)
    return tps.solve_lattice_cycle(_lattice(kind, n, size), **kw)


def fda_defect(kinds=("planar", "axisymmetric"), n=8, size=140.0):
    """Integrate the exact cycle with both FDA integrators for one period.

    Returns rows of dict(kind, method, defect_zeta, defect_w, max_dtc, impacts, time).
    """
    rows = []
    for kind in kinds:
        cyc = _cycle(kind, n, size)
        ts = cyc.t0 + 0.5 * cyc.period + 0.1
        w0, z0 = cyc.velocity([ts])[0], cyc.height([ts])[0]
        for method in ("exact", "ode"):
            start = time.perf_counter()
            run = simulate(cyc.lattice, cyc.Gamma, cyc.e, w0, z0, t_start=ts, t_end=ts + cyc.period,
                           method=method)
            imp = run.events[run.events.kind == "impact"]
            d = np.abs(np.mod(imp.t - cyc.tc[imp.node] + cyc.period / 2, cyc.period) - cyc.period / 2)
            rows.append(dict(kind=kind, method=method, converged=cyc.converged,
                             defect_zeta=float(np.max(np.abs(run.zeta - z0))),
                             defect_w=float(np.max(np.abs(run.w - w0))), max_dtc=float(np.max(d)),
                             impacts=int(imp.size), time=time.perf_counter() - start))
    return rows


def tps_convergence(kinds=("planar", "axisymmetric"), Ns=(16, 32, 64, 128, 256), n=8, size=140.0):
    """Spectral lattice TPS against the exact cycle: max |tc_N - tc| and max |zeta_N - zeta|.

    Returns dict kind -> (rows, fitted slope of the tc error).
    """
    out = {}
    for kind in kinds:
        cyc = _cycle(kind, n, size)
        t = np.linspace(0.0, cyc.period, 1024, endpoint=False)
        zc = cyc.height(t)
        rows = []
        for N in Ns:
            start = time.perf_counter()
            sol = tps.solve_lattice(cyc.lattice, Gamma=2.5, M=2, e=0.45, t0=None, n_harmonics=N,
                                    tol=1e-12, r_core=0.21 * size)
            el = time.perf_counter() - start
            dtc = np.abs(np.mod(sol.tc - cyc.tc + cyc.period / 2, cyc.period) - cyc.period / 2)
            rows.append(dict(N=N, converged=sol.converged, dtc=float(np.max(dtc)),
                             dzeta=float(np.max(np.abs(sol.height(t) - zc))), time=el))
        slope = float(np.polyfit(np.log([r["N"] for r in rows]), np.log([r["dtc"] for r in rows]), 1)[0])
        out[kind] = (rows, slope)
    return out


def branch_ends(cases=None):
    """Where the single-contact branch from the decoupled limit ends, on FDA lattices (no truncation).

    Returns rows of dict(case, preset, status, coupling, effective_spacing, time).
    """
    if cases is None:
        cases = [("kink, 41 nodes, L = 8 (paper)", "planar", 41, 8.0, "uniform"),
                 ("kink, 81 nodes, L = 8", "planar", 81, 8.0, "uniform"),
                 ("kink, 20 nodes, L = 400", "planar", 20, 400.0, "uniform"),
                 ("oscillon, 40 nodes uniform, R = 20", "axisymmetric", 40, 20.0, "uniform"),
                 ("oscillon, 40 nodes uniform, R = 800", "axisymmetric", 40, 800.0, "uniform")]
    rows = []
    for name, kind, n, size, grid in cases:
        lat = _lattice(kind, n, size, grid)
        for preset, kw in (("e = 0.45", dict(e=0.45, t0=None)), ("t0 = 0 (paper)", dict(t0=0.0))):
            start = time.perf_counter()
            cyc = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, r_core=0.1 * size if kind != "planar" else 1.0,
                                          **kw)
            rows.append(dict(case=name, preset=preset, status=cyc.status, converged=cyc.converged,
                             coupling=cyc.coupling, effective_spacing=lat.spacing / math.sqrt(cyc.coupling),
                             time=time.perf_counter() - start))
    return rows


def stability_of_cycles(n=8, size=140.0, periods=20):
    """check_stability of the exact cycles where they exist (coarse lattices), both integrators."""
    rows = []
    for kind in ("planar", "axisymmetric"):
        cyc = _cycle(kind, n, size)
        for method in ("exact", "ode"):
            start = time.perf_counter()
            chk = tps.check_stability(cyc, periods=periods, method=method, jacobian=(method == "exact"))
            mu = np.abs(chk.multipliers)
            rows.append(dict(kind=kind, method=method, stable=chk.stable, growth=chk.growth_factor,
                             final_defect=float(np.max(chk.defects[-1])),
                             multipliers=chk.multipliers_kind,
                             max_abs_mu=float(mu[0]) if mu.size else float("nan"),
                             differentiable=chk.differentiable, time=time.perf_counter() - start))
    return rows


def main():
    start = time.perf_counter()
    defect = fda_defect()
    conv = tps_convergence()
    ends = branch_ends()
    stab = stability_of_cycles()
    parts = ["## TPS and FDA on the same lattice\n",
             f"Command: `python -m validation.lattice_tps` (this run: {time.perf_counter() - start:.0f} s). "
             "Gamma = 2.5, M = 2, e = 0.45 unless stated; coarse lattices (8 nodes, spacing 20 planar / "
             "20 radial) where single-contact orbits exist.\n",
             "### The FDA integrates the exact TPS cycle (N -> infinity) for one period\n",
             table4(defect, ["kind", "method", "converged", "defect_zeta", "defect_w", "max_dtc", "impacts",
                             "time"]),
             "\n### Spectral lattice TPS against the exact cycle\n"]
    for kind, (rows, slope) in conv.items():
        parts.append(f"**{kind}** (fitted slope of max|dtc| vs N: {slope:.2f}):\n\n"
                     + table4(rows, ["N", "converged", "dtc", "dzeta", "time"]) + "\n")
    parts += ["The neighbours' impacts put kinks into w_j (Fourier coefficients ~ 1/n^2), so the truncated "
              "contact condition (46) carries an O(1/N) tail; the exact cycle removes it.\n",
              "### Where the single-contact branch ends on FDA lattices (exact cycles, no truncation)\n",
              table4(ends, ["case", "preset", "status", "coupling", "effective_spacing", "time"]),
              "\nStatus 0: the orbit exists on the lattice as given. Status 4: the branch from the decoupled "
              "limit ends at the coupling shown (a fold); effective spacing = lattice spacing / sqrt(coupling). "
              "Status 2: Newton cannot start even at the decoupled limit (t0 = 0 is the flat orbit's fold).\n",
              "### Stability of the existing cycles (check_stability on their own lattice)\n",
              table4(stab, ["kind", "method", "stable", "growth", "final_defect", "multipliers", "max_abs_mu",
                            "differentiable", "time"])]
    text = "\n".join(parts)
    with open(SECTION, "w") as fh:
        fh.write(text)
    print(text)
    return dict(defect=defect, convergence=conv, branch_ends=ends, stability=stab)


if __name__ == "__main__":
    main()
