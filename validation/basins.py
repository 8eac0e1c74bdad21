"""Basins of the flat layer: which attractor random states of one node reach (docs/design.md, hazard 9).

What is measured
----------------
* :func:`basin_study` -- for (Gamma, e) in :data:`CASES` (M = 2, 64 samples,
  seed 0) the fraction of random initial states that reach each attractor of
  the single node, with its binomial standard error, period (forcing cycles),
  contact pattern and multipliers: point impacts, and the soft contact at
  cutoff 0.3 without (the model of ``simulate(..., method="soft")``) and with
  the sticking rule (docs/design.md, hazard 10).
* :func:`cutoff_scan` -- the reference case with the soft contact at
  cutoffs 0.3 ... 0.03, with and without the sticking rule: the point-impact
  basins are recovered as the cut-off shrinks.
* :func:`convergence_study` -- the f/2 fraction of the reference case against
  the number of samples (16 ... 1024): the binomial error shrinks like
  n^(-1/2) and the fractions agree within it.
* :func:`cross_check` -- the same samples classified with
  ``integrator="simulate"`` (:func:`tps_solver.simulate` on a uniform 3-node
  lattice) and with the closed-form ball: labels must agree.
* :func:`cost_study` -- seconds per sample (closed form) and per forcing cycle
  (closed form and simulate, point and soft), single-threaded BLAS.

Run ``python -m validation.basins`` from the repository root (a few minutes
on 2 cores) to print every table (markdown).
"""
import math
import time

import numpy as np

import tps_solver as tps
from validation.report import one_blas_thread
from tps_solver.analyses.basins import ball_cycle, flat_basins

#: (Gamma, e) of the study, M = 2.
CASES = ((2.5, 0.45), (4.1, 0.0), (4.1, 0.1), (4.4, 0.1))
CUTOFF = 0.3


def _summary(res, seconds):
    rows = []
    for a in res.attractors:
        rows.append(dict(Gamma=res.Gamma, e=res.e, model=_model_name(res), attractor=a.label,
                         period=a.period, fraction=a.fraction, stderr=a.stderr, interval=a.interval,
                         multipliers=a.multipliers, smooth=a.smooth, phases=a.phase_counts.tolist(),
                         transient=a.mean_transient, seconds=seconds))
    if res.irregular.count:
        near = ", ".join(f"p={p}: {c} (d~{d:.1e})" for p, (c, d) in res.irregular.near_periods.items())
        rows.append(dict(Gamma=res.Gamma, e=res.e, model=_model_name(res), attractor=f"irregular [{near}]",
                         period=None, fraction=res.irregular.fraction, stderr=res.irregular.stderr,
                         interval=res.irregular.interval, multipliers=None, smooth=None, phases=None,
                         transient=None, seconds=seconds))
    n_fail = int(np.sum(res.labels == -2))
    if n_fail:
        f = n_fail / res.n_samples
        rows.append(dict(Gamma=res.Gamma, e=res.e, model=_model_name(res), attractor="failed (event bound)",
                         period=None, fraction=f, stderr=math.sqrt(f * (1 - f) / res.n_samples),
                         interval=(f, f), multipliers=None, smooth=None, phases=None, transient=None,
                         seconds=seconds))
    return rows


def _model_name(res):
    if res.model == "point":
        return "point"
    return f"soft l={res.cutoff}" + (" +stick" if res.soft_sticking else "")


def basin_study(cases=CASES, n_samples=64, seed=0, soft=True):
    """Attractor fractions for every case and model; returns a list of row dicts (one per attractor)."""
    rows = []
    with one_blas_thread():
        for G, e in cases:
            runs = [dict(model="point")]
            if soft and e > 0:
                runs += [dict(model="soft", cutoff=CUTOFF), dict(model="soft", cutoff=CUTOFF, soft_sticking=True)]
            for kw in runs:
                t = time.perf_counter()
                res = flat_basins(G, e, M=2, n_samples=n_samples, seed=seed, **kw)
                rows += _summary(res, time.perf_counter() - t)
    return rows


def cutoff_scan(Gamma=2.5, e=0.45, cutoffs=(0.3, 0.2, 0.1, 0.03), n_samples=64, seed=0):
    """Soft contact (with and without the sticking rule) against the cut-off: rows per attractor."""
    rows = []
    with one_blas_thread():
        for ell in cutoffs:
            for st in (False, True):
                t = time.perf_counter()
                res = flat_basins(Gamma, e, n_samples=n_samples, seed=seed, model="soft", cutoff=ell,
                                  soft_sticking=st)
                rows += _summary(res, time.perf_counter() - t)
    return rows


def convergence_study(Gamma=2.5, e=0.45, sizes=(16, 64, 256, 1024), seed=0, label="f/2"):
    """Fraction of ``label`` against the number of samples: rows with n, fraction, stderr, interval."""
    rows = []
    with one_blas_thread():
        big = flat_basins(Gamma, e, n_samples=max(sizes), seed=seed)
    names = [a.label for a in big.attractors]
    idx = names.index(label) if label in names else None
    for n in sizes:                          # the first n samples of the big run are the n-sample run
        k = int(np.sum(big.labels[:n] == idx)) if idx is not None else 0
        f = k / n
        rows.append(dict(n=n, count=k, fraction=f, stderr=math.sqrt(f * (1 - f) / n)))
    return rows


def cross_check(cases=((2.5, 0.45), (4.4, 0.1)), n_samples=12, seed=0):
    """Labels from integrator="simulate" against the closed form on the same samples."""
    rows = []
    with one_blas_thread():
        for G, e in cases:
            t = time.perf_counter()
            a = flat_basins(G, e, n_samples=n_samples, seed=seed, periods=100)
            ta = time.perf_counter() - t
            t = time.perf_counter()
            b = flat_basins(G, e, n_samples=n_samples, seed=seed, periods=100, integrator="simulate")
            tb = time.perf_counter() - t
            la = [a.attractors[k].label if k >= 0 else "irregular" for k in a.labels]
            lb = [b.attractors[k].label if k >= 0 else "irregular" for k in b.labels]
            pts = max((np.abs(x.points - y.points).max() for x in a.attractors for y in b.attractors
                       if x.label == y.label), default=None)
            mu = max((np.abs(x.multipliers - y.multipliers).max() for x in a.attractors for y in b.attractors
                      if x.label == y.label), default=None)
            rows.append(dict(Gamma=G, e=e, n=n_samples, agree=sum(x == y for x, y in zip(la, lb)),
                             points=pts, multipliers=mu, closed=ta, simulate=tb))
    return rows


def cost_study(n_cycles=20):
    """Seconds per forcing cycle of one node: closed form and simulate, point and soft (one start each)."""
    rows = []
    with one_blas_thread():
        for model, cutoff, cyc in (("point", None, n_cycles), ("soft", CUTOFF, 3)):
            for integ in ("closed_form", "simulate"):
                k = cyc if not (model == "soft" and integ == "closed_form") else n_cycles
                t = time.perf_counter()
                _, ev = ball_cycle(2.5, 0.45, -1.3, 2.0, n_cycles=k, model=model, cutoff=cutoff, integrator=integ)
                dt = time.perf_counter() - t
                rows.append(dict(model=model, integrator=integ, cycles=k, events=len(ev), per_cycle=dt / k))
    return rows


def _fmt_mu(mu):
    if mu is None:
        return None
    return ", ".join(f"{m.real:.4g}{m.imag:+.4g}j" if abs(m.imag) > 0 else f"{m.real:.4g}" for m in mu)


def main():
    from validation.report import markdown_table

    t0 = time.perf_counter()
    print("## Basins of the flat layer (one node, M = 2, 64 samples, seed 0)\n")
    rows = basin_study()
    print(markdown_table(rows, [
        ("Gamma", "Gamma"), ("e", "e"), ("model", "model"), ("attractor", "attractor"),
        ("period (2pi)", "period"),
        ("fraction ± binomial s.e.", lambda r: f"{r['fraction']:.3f} ± {r['stderr']:.3f}"),
        ("95% Wilson", lambda r: f"[{r['interval'][0]:.3f}, {r['interval'][1]:.3f}]"),
        ("multipliers", lambda r: _fmt_mu(r["multipliers"])), ("smooth", "smooth"),
        ("phase counts", lambda r: None if r["phases"] is None else str(r["phases"])),
        ("mean transient (2pi)", "transient"), ("run s", "seconds")]))
    print("\n## Soft contact against its cut-off (Gamma = 2.5, e = 0.45, 64 samples, seed 0)\n")
    print(markdown_table(cutoff_scan(), [
        ("cutoff model", "model"), ("attractor", "attractor"), ("period (2pi)", "period"),
        ("fraction ± binomial s.e.", lambda r: f"{r['fraction']:.3f} ± {r['stderr']:.3f}"),
        ("multipliers", lambda r: _fmt_mu(r["multipliers"])), ("run s", "seconds")]))
    print("\n## Convergence with the number of samples (Gamma = 2.5, e = 0.45, point, f/2)\n")
    print(markdown_table(convergence_study(), [
        ("n", "n"), ("count", "count"), ("fraction", "fraction"), ("binomial s.e.", "stderr")]))
    print("\n## Closed-form ball against simulate (point impacts, same samples)\n")
    print(markdown_table(cross_check(), [
        ("Gamma", "Gamma"), ("e", "e"), ("samples", "n"), ("labels agree", "agree"),
        ("max points diff", "points"), ("max multipliers diff", "multipliers"),
        ("closed form s", "closed"), ("simulate s", "simulate")]))
    print("\n## Cost per forcing cycle (Gamma = 2.5, e = 0.45, start (w, zeta) = (-1.3, 2.0), 1 BLAS thread)\n")
    print(markdown_table(cost_study(), [
        ("model", "model"), ("integrator", "integrator"), ("cycles", "cycles"), ("events", "events"),
        ("s per cycle", "per_cycle")]))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s; tps_solver {tps.__version__}")


if __name__ == "__main__":
    main()
