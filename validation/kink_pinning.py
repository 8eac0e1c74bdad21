"""The e = 0 kink under refinement: which pinned kink is stable, the pinning strength, the width.

On a lattice the front of a kink is pinned: a kink whose mirror point is a node and one whose
mirror point is midway between two nodes are two different periodic orbits, and shooting
(:func:`tps_solver.lattice_kink`: ten FDA periods of settling, then Newton--Krylov) ends on
one of them, stable or not (Newton converges to saddles too).  :func:`pinned_kink` computes it at one (Gamma, dx) and measures its symmetry
centre (:func:`symmetry_centre`), its leading Floquet multiplier (pinning strength
1 - |mu1|), its width and the time it took.  If the stable centring alternates between node
and bond with dx, the width sequence need not be monotone.

The width is the package's one definition (:func:`tps_solver.front_width`,
``instant="lower_far_field_top"``: the 10--90 % width of the height at the instant where the
lower far field is highest).  ``main`` writes ``validation/sections/kink_pinning.md`` with the
width at the finest spacing and, as its error bar, its change from the next coarser spacing.

Run ``python -m validation.kink_pinning [--gamma 3.9 4.1 4.4] [--dx 4 2 1 0.5]``; dx = 0.5
takes a few minutes per kink (one BLAS thread).  Results are cached per case in
``validation/data/kink_pinning/`` so that an interrupted run resumes.
"""
import argparse
import json
import os
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, one_blas_thread, publish

LENGTH = 40.0
CACHE = os.path.join(os.path.dirname(__file__), "data", "kink_pinning")


def symmetry_centre(orbit, n_samples=64):
    """Where the kink is centred: the mirror point c with zeta(x, t) = zeta(2c - x, t + T/2).

    Returns ``(kind, x_c, error)``: ``kind`` "node" or "bond" (c on a node or midway between two),
    ``x_c`` the position and ``error`` the max mismatch of heights over the period within 12 of c
    (rounding level for a symmetric kink).
    """
    x = np.asarray(orbit.lattice.nodes, float)
    n = x.size
    T = orbit.period
    ts = (orbit.t_start or 0.0) + T * np.arange(n_samples) / n_samples
    Z, Zs = np.asarray(orbit.height(ts)), np.asarray(orbit.height(ts + T / 2))
    dx = x[1] - x[0]
    best = (np.inf, 0)
    for k in range(2, 2 * n - 3):                       # mirror about index k / 2
        i = np.arange(n)
        m = k - i
        keep = (m >= 0) & (m < n) & (np.abs(i - k / 2) * dx <= 12.0)
        if keep.sum() < 3:
            continue
        best = min(best, (float(np.max(np.abs(Z[:, i[keep]] - Zs[:, m[keep]]))), k))
    err, k = best
    return ("node" if k % 2 == 0 else "bond"), float(x[0] + k / 2 * dx), err


def pinned_kink(Gamma, dx, length=LENGTH):
    """The pinned kink shooting converges to at (Gamma, dx) (dict of measured numbers; |mu1| says if stable).

    :func:`tps_solver.lattice_kink` from its default start (front at x = 0 on a node); measured:
    the symmetry centre (on a node or between two), the leading multiplier (the pinning
    strength is 1 - |mu1|), the width and the time.
    """
    n = int(round(length / dx)) + 1
    lat = tps.Lattice.planar(n_nodes=n, length=length)
    start = time.perf_counter()
    with one_blas_thread():
        orb = tps.lattice_kink(lat, Gamma=Gamma, e=0.0)
    seconds = time.perf_counter() - start
    row = dict(Gamma=Gamma, dx=dx, n_nodes=n, converged=bool(orb.converged),
               residual=float(orb.residual), nit=int(orb.nit), seconds=seconds)
    if not orb.converged:
        row.update(mu1=None, pinning=None, width=None, centre=None, symmetry_error=None, message=orb.message)
        return row
    (w,) = tps.front_width(orb, instant="lower_far_field_top")
    kind, xc, err = symmetry_centre(orb)
    mu1 = float(np.abs(np.asarray(orb.multipliers)[0]))
    row.update(mu1=mu1, pinning=1.0 - mu1, width=float(w), centre=kind, x_centre=xc, symmetry_error=err,
               message="")
    return row


def cached_kink(Gamma, dx):
    """:func:`pinned_kink`, cached as JSON in ``validation/data/kink_pinning/``."""
    os.makedirs(CACHE, exist_ok=True)
    path = os.path.join(CACHE, f"G{Gamma:g}_dx{dx:g}.json")
    if os.path.exists(path):
        with open(path) as fh:
            return json.load(fh)
    row = pinned_kink(Gamma, dx)
    with open(path, "w") as fh:
        json.dump(row, fh)
    return row


def continuum_width(rows):
    """Finest spacing's width and an error bar: its change from the next coarser spacing (None if < 2)."""
    s = sorted([r for r in rows if r["converged"]], key=lambda r: -r["dx"])
    if len(s) < 2:
        return None, None
    return s[-1]["width"], abs(s[-1]["width"] - s[-2]["width"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gamma", type=float, nargs="+", default=[3.9, 4.1, 4.4])
    ap.add_argument("--dx", type=float, nargs="+", default=[4.0, 2.0, 1.0, 0.5])
    args = ap.parse_args(argv)
    rows, est = [], []
    for G in args.gamma:
        gr = []
        for dx in args.dx:
            r = cached_kink(G, dx)
            print(r, flush=True)
            gr.append(r)
        rows += gr
        w, err = continuum_width(gr)
        est.append(dict(Gamma=G, dx_min=min(args.dx), width=w, error=err))
    text = [
        "The pinned e = 0 kink that shooting converges to, under refinement, by shooting (`tps.lattice_kink` from its default start, "
        "planar Neumann lattice of length 40, one BLAS thread) (`python -m validation.kink_pinning`). "
        "`centre`: the kink's mirror point c (zeta(x, t) = zeta(2c - x, t + T/2), to `symmetry_error`) is on a "
        "node or midway between two. Pinning strength: 1 - |mu1| (negative: the orbit shooting converged to is "
        "unstable, |mu1| > 1; Newton converges to saddles too). Width: "
        "`tps.front_width(orbit, instant='lower_far_field_top')`.", "",
        markdown_table(rows, [(k, k) for k in ("Gamma", "dx", "n_nodes", "converged", "nit", "residual", "centre",
                                              "symmetry_error", "mu1", "pinning", "width", "seconds")]), "",
        "Width at the finest spacing, with the change from the next coarser one as its error bar (not an "
        "extrapolation: see the centring column for why the sequence need not be monotone):", "",
        markdown_table(est, [(k, k) for k in ("Gamma", "dx_min", "width", "error")]),
    ]
    publish("kink_pinning", "\n".join(text))


if __name__ == "__main__":
    main()
