"""Continuation of periodic orbits: special points against closed forms and the exact lattice cycle.

* :func:`flat_special_points` -- the flat layer continued in Gamma from the stable orbit, both
  sides: the fold and the period doubling against ``FlatLayer.stability_window`` (an
  independent brentq on tr J) and the closed-form fold ``Gamma_SN = s pi M``;
* :func:`cycle_fold` -- the exact single-contact kink cycle of a coarse planar Neumann lattice
  continued in the node spacing down to its fold and back; the multiplier through +1 there,
  from the FDA period map (:func:`tps_solver.find_periodic_orbit`) on both sides of the fold;
* :func:`soft_branch` -- a soft-contact flat orbit on 3 nodes (shooting) continued in the cut-off
  or in Gamma: the branch's multipliers (exact soft monodromy) against the closed-form per-mode
  map ``SoftFlatOrbit.monodromy`` at every point.

Run ``python -m validation.continuation`` (about a minute) to print the tables and write
``validation/sections/continuation.md``; ``tests/test_continuation.py`` asserts the same numbers.
"""
import math
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, publish

__all__ = ["flat_special_points", "cycle_fold", "soft_branch", "main"]


def flat_special_points(cases=((0.45, 2), (0.3, 2), (0.6, 2), (0.45, 1))):
    """Fold and period doubling of the continued flat branch against the stability window.

    Returns
    -------
    rows : list of dict
        ``e``, ``M``, ``fold``, ``fold_err`` (against s pi M), ``pd``, ``pd_err`` (against
        ``stability_window``), ``points``, ``seconds``.
    """
    rows = []
    for e, M in cases:
        lo, hi = tps.FlatLayer.stability_window(e, M)
        start = tps.FlatLayer(0.5 * (lo + hi), M, e=e)
        clock = time.perf_counter()
        br = tps.continue_branch(start, "Gamma", (lo - 0.1, hi + 0.3), bothsides=True)
        seconds = time.perf_counter() - clock
        sp = dict(br.special_points)
        s = (1.0 - e) / (1.0 + e)
        rows.append(dict(e=e, M=M, fold=sp.get("fold", math.nan),
                         fold_err=abs(sp.get("fold", math.nan) - s * math.pi * M),
                         pd=sp.get("period_doubling", math.nan),
                         pd_err=abs(sp.get("period_doubling", math.nan) - hi),
                         points=int(br.parameter_values.size), seconds=seconds))
    return rows


def cycle_fold(n_nodes=8, length=140.0, Gamma=2.5, e=0.45, bounds=(8.0, 30.0)):
    """The kink cycle's branch in the spacing: the fold, and max|mu| on both sides of it.

    Returns
    -------
    dict
        ``fold`` (spacing), ``points``, ``min_spacing``, ``returns_to`` (largest spacing on the
        far side), ``mu_before``, ``mu_after`` (max|mu| at the points next to the fold),
        ``seconds``.
    """
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=length)
    cyc = tps.solve_lattice_cycle(lat, Gamma=Gamma, M=2, e=e, t0=None)
    clock = time.perf_counter()
    br = tps.continue_branch(cyc, "spacing", bounds, direction=-1, multipliers=False)
    seconds = time.perf_counter() - clock
    fold = next(d for d in br.special_details if d["kind"] == "fold")
    i = fold["index"]
    h0 = float(lat.spacing)
    mu = []
    for j in (i - 1, i + 1):
        h = br.parameter_values[j]
        scaled = tps.Lattice(lat.nodes * h / h0, "planar", "neumann")
        c = tps.solve_lattice_cycle(scaled, Gamma=Gamma, M=2, e=e, t0=None, tc_initial=br.states[j],
                                    continuation=False)
        orb = tps.find_periodic_orbit(scaled, Gamma=Gamma, M=2, e=e, guess=c)
        mu.append(float(np.max(np.abs(orb.multipliers))))
    return dict(fold=fold["value"], points=int(br.parameter_values.size),
                min_spacing=float(br.parameter_values.min()), returns_to=float(br.parameter_values[-1]),
                spacing_before=float(br.parameter_values[i - 1]), spacing_after=float(br.parameter_values[i + 1]),
                mu_before=mu[0], mu_after=mu[1], seconds=seconds)


def soft_branch(parameter="cutoff", bounds=(0.25, 0.35), max_points=3, step=0.004, Gamma=2.5, M=2, e=0.45,
                cutoff=0.3):
    """Soft flat orbit on a 3-node planar lattice (length 1), continued from a shooting orbit.

    Returns
    -------
    rows : list of dict
        Per branch point: ``parameter``, ``value``, ``error`` (largest distance between the
        branch's multipliers and the closed-form ones, both ways), ``n_multipliers``; the first
        row also carries ``seconds`` (the whole continuation) and ``points``.
    """
    from tps_solver.operators.lattice import lattice_eigenvalues

    ref = tps.SoftFlatOrbit(Gamma, M, e, cutoff)
    lat = tps.Lattice.planar(n_nodes=3, length=1.0)
    t_s = ref.t_exit + 0.5 * ref.flight
    w, z = ref.state(t_s)
    orb = tps.find_periodic_orbit(lat, Gamma, M, e, cutoff=cutoff, guess=(np.full(3, float(w)), np.full(3, float(z))),
                                  t_start=t_s, section="fixed")
    clock = time.perf_counter()
    br = tps.continue_branch(orb, parameter, bounds, max_points=max_points, step=step)
    seconds = time.perf_counter() - clock
    rows = []
    for value, mu in zip(br.parameter_values, br.multipliers):
        kw = dict(Gamma=Gamma, cutoff=cutoff)
        kw[parameter] = float(value)
        want = np.concatenate([np.linalg.eigvals(Mk) for Mk in tps.SoftFlatOrbit(kw["Gamma"], M, e, kw["cutoff"])
                               .monodromy(lattice_eigenvalues(lat), t_section=t_s)])
        mu = np.asarray(mu)
        d = np.abs(mu[:, None] - want[None, :])
        err = float(max(d.min(axis=0).max(), d.min(axis=1).max())) if mu.size == want.size else float("inf")
        rows.append(dict(parameter=parameter, value=float(value), error=err, n_multipliers=int(mu.size)))
    rows[0].update(seconds=seconds, points=len(rows))
    return rows


def main():
    flat = flat_special_points()
    cyc = cycle_fold()
    soft = soft_branch("cutoff", (0.25, 0.35), max_points=4) + soft_branch("Gamma", (2.4, 2.6), max_points=4)
    text = [
        "Code under test: `tps_solver/continuation.py` (`continue_branch`, `Branch`). Tests: "
        "`tests/test_continuation.py`. Reproduce: `python -m validation.continuation`.",
        "",
        "**Flat layer in Gamma** (both sides of the stable orbit; fold against the closed form "
        "Gamma_SN = s pi M, period doubling against `FlatLayer.stability_window`, an independent brentq "
        "on tr J = -(1 + e^2)):",
        "",
        markdown_table(flat, [("e", "e"), ("M", "M"), ("fold", lambda r: f"{r['fold']:.12g}"),
                              ("|fold - s pi M|", "fold_err"),
                              ("period doubling", lambda r: f"{r['pd']:.12g}"),
                              ("|PD - window|", "pd_err"), ("points", "points"), ("seconds", "seconds")]),
        "",
        "**Exact kink cycle in the node spacing** (planar Neumann lattice, 8 nodes, start at spacing 20, "
        "Gamma = 2.5, e = 0.45): the branch of single-contact kinks turns back at a fold and continues "
        "as an unstable branch; the Floquet multipliers (FDA period map) on the two sides of the fold:",
        "",
        markdown_table([cyc], [("fold spacing", lambda r: f"{r['fold']:.6g}"),
                               ("smallest spacing on the branch", lambda r: f"{r['min_spacing']:.6g}"),
                               ("spacing before / after", lambda r: f"{r['spacing_before']:.5g} / "
                                                                    f"{r['spacing_after']:.5g}"),
                               ("max mu before", "mu_before"), ("max mu after", "mu_after"),
                               ("points", "points"), ("seconds (no multipliers)", "seconds")]),
        "",
        f"The fold at spacing {cyc['fold']:.4g} is the end of the single-contact branch that natural "
        "continuation in the coupling located at 13.6 +- 0.5 % (section 'TPS and FDA on the same "
        f"lattice'); the largest multiplier goes from {cyc['mu_before']:.3f} to {cyc['mu_after']:.3f} "
        "through +1 there: the two single-contact kinks born at the fold, one stable and one unstable, "
        "are a saddle-node pair.",
        "",
        "**Soft-contact orbit by shooting** (cut-off 0.3, 3-node planar Neumann lattice of length 1, the flat "
        "orbit): continued in the cut-off and in Gamma; at every branch point the Floquet multipliers from the "
        "exact soft monodromy (`tps_solver.solvers.shooting.soft_monodromy`) against the closed-form per-mode map "
        "`SoftFlatOrbit.monodromy`:",
        "",
        markdown_table(soft, [("parameter", "parameter"), ("value", lambda r: f"{r['value']:.6g}"),
                              ("multiplier error", "error"), ("multipliers", "n_multipliers"),
                              ("seconds (whole branch)", "seconds")]),
        "",
        "Before the exact monodromy was used here, continuation differentiated the soft period map by central "
        "differences (step 1e-6, 4 n_nodes + 2 period maps per Jacobian). On the same branches (4 points each) "
        "the errors were 3.4e-10 to 3.0e-9 (cut-off) and 9.7e-10 to 1.1e-8 (Gamma), and each branch took 12-13 s. "
        "With the exact monodromy it is 5e-13 to 9e-12 and 3.4 s per branch, measured side by side in one session. "
        "Caching the Radau IIA tableau (70 ms of mpmath per soft run) then brought a branch to the 2.1-2.7 s in the table.",
    ]
    publish("continuation", "\n".join(text) + "\n")


if __name__ == "__main__":
    main()
